"""Dense reference solver: every eigenvalue of (λ²M + λC + K)x = 0 by LAPACK (scipy).

The QEP is scaled first (λ = s·ν with s ≈ |λ₁|, then divided by s²‖M‖) and linearized in the
reversed variable μ = 1/ν (docs/theory.md §10.2): in SI units ‖K‖/‖M‖ ~ 1e9-1e11 and a plain
companion form of the unscaled problem loses digits on the lowest modes. Problems without a
Coriolis term are solved as a generalized eigenproblem in μ = -λ² instead (symmetric-definite
when K is symmetric), which is exact and cheaper.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
import scipy.linalg as la

from fkev_slepc.model.qep import GENERAL, LINEAR_SYMMETRIC, QEP
from fkev_slepc.solve.acceptance import DenseQEP, check_pairs, pair_error
from fkev_slepc.solve.finite import require_finite
from fkev_slepc.solve.modes import reported
from fkev_slepc.solve.polish import polish_reported
from fkev_slepc.solve.protocol import EigenSolution
from fkev_slepc.solve.stability import check_divergence
from fkev_slepc.solve.thresholds import IMAG_TOL, SolveSettings


def _lambda_from_mu(mu: np.ndarray) -> np.ndarray:
    """λ = ±sqrt(-μ) for K x = μ M x (μ = ω² > 0 gives ±iω; μ < 0 gives a real pair)."""
    root = np.sqrt(-np.asarray(mu, dtype=complex))
    return np.concatenate([root, -root])


def balance(M, K) -> np.ndarray:
    """Symmetric diagonal scaling d (D = diag(d)) with D K D and D M D balanced entry-wise.

    d_i = (|K_ii| |M_ii|)^(-1/4) puts every DOF's stiffness and mass on one scale, so that a
    rigid link (K_ii ~ 1e19) or a heavy lumped mass (M_ii ~ 1e4 kg) no longer dominates the
    norms against which LAPACK's backward errors are measured. Eigenvalues are unchanged
    (D K D x̃ = μ D M D x̃ with x = D x̃). Powers of 2, so the scaling itself is exact.
    The SLEPc engine balances its operators the same way (:func:`balanced`).
    """
    k, m = np.abs(K.diagonal()), np.abs(M.diagonal())  # dense arrays or scipy sparse matrices
    good = (k > 0) & (m > 0) & np.isfinite(k * m)
    d = np.ones(k.size)
    d[good] = (k[good] * m[good]) ** -0.25
    return np.exp2(np.round(np.log2(d)))


def balanced(qep: QEP) -> tuple[QEP, np.ndarray]:
    """``qep`` with D M D, D C D, D K D (:func:`balance`; same sparsity pattern) and d."""
    d = balance(qep.mass, qep.stiffness)

    def scaled(A):
        if A is None:
            return None
        B = A.copy()
        rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
        B.data = A.data * d[rows] * d[A.indices]
        return B

    return QEP(scaled(qep.mass), scaled(qep.damping), scaled(qep.stiffness), qep.kind), d


def symmetric_low_modes(M: np.ndarray, K: np.ndarray, eigvals_only: bool = False):
    """All (μ, V) of K v = μ M v (K, M symmetric, M positive definite), accurate at the low end.

    Solved inverted, M v = ν K v with ν = 1/μ, the way SLEPc's shift-and-invert about 0 does:
    LAPACK's symmetric-definite solver has an *absolute* eigenvalue error ~ε‖B⁻¹A‖, which on
    ``eigh(K, M)`` is set by the stiffest DOF over the lightest mass and made the lowest
    frequency of a rhombus linkage with a rigid crank and a 1e4 kg mass at B 6.6e-6 wrong;
    inverted, that error is relative to the largest ν = 1/μ₁ instead (tests/test_stress.py).
    When K is indefinite (divergence) the shift σ = 2|μ_min| + ... makes K + σM definite and
    ν = 1/(μ + σ). V is None when ``eigvals_only``.
    """
    sigma = 0.0
    for _ in range(2):
        try:
            out = la.eigh(M, K + sigma * M, eigvals_only=eigvals_only)
        except la.LinAlgError:  # K + σM not positive definite: shift past the lowest μ
            mu_min = la.eigh(K, M, eigvals_only=True, subset_by_index=[0, 0])[0]
            sigma = 2.0 * max(-mu_min, 0.0) + np.finfo(float).eps * la.norm(K, 1) / la.norm(M, 1)
            continue
        nu, V = (out, None) if eigvals_only else out
        with np.errstate(divide="ignore"):
            return 1.0 / nu - sigma, V
    return (la.eigh(K, M, eigvals_only=True), None) if eigvals_only else la.eigh(K, M)


def as_dense(qep: QEP) -> DenseQEP:
    """``qep`` with numpy arrays (pair errors and certificates of small models without sparse
    overhead, which cost more than the solve at thesis size)."""
    C = None if qep.damping is None else qep.damping.toarray()
    return DenseQEP(qep.mass.toarray(), C, qep.stiffness.toarray(), qep.kind)


def _spectrum(M: np.ndarray, C: np.ndarray | None, K: np.ndarray, kind: str, hint=None):
    """Every eigenvalue of a balanced dense QEP, without eigenvectors except on the symmetric
    path (where LAPACK's come almost free): (λ, method, scaled QEP (s, M_s, C_s, K_s) whose
    eigenvalues are λ/s, V of K v = μ M v or None)."""
    if kind == LINEAR_SYMMETRIC:  # operators.classify decides; no second symmetry test here
        mu, V = symmetric_low_modes(M, K)
        return _lambda_from_mu(mu), "dense-eigh", (1.0, M, None, K), V
    if C is None:
        alpha, beta = la.eig(M, K, right=False, homogeneous_eigvals=True)  # ν = α/β = 1/μ
        with np.errstate(divide="ignore", invalid="ignore"):
            mu = beta / alpha
        return _lambda_from_mu(mu), "dense-eig", (1.0, M, None, K), None
    lam, scaled = qz(M, C, K, hint)
    return lam, "dense-qz", scaled, None


def all_eigenvalues(qep: QEP) -> np.ndarray:
    """All 2n eigenvalues of ``qep`` (the dense engine's balanced LAPACK path, no eigenvectors).
    Used by the whole-spectrum divergence check of the SLEPc engine (solve/stability.py)."""
    return _balanced_spectrum(as_dense(qep), None).lam


def qz(M: np.ndarray, C: np.ndarray, K: np.ndarray, hint=None):
    """Eigenvalues λ of λ²M + λC + K by QZ of a scaled, reversed companion pencil (no
    eigenvectors: see :func:`null_vectors`), and the scaled QEP (s, M_s, C_s, K_s)."""
    n = M.shape[0]
    # λ = s·ν with s ≈ |λ₁| (from the symmetric part of K): the wanted low modes get |ν| ≈ 1.
    # Measured on Bahgat-Willmert meshes of 36-360 DOFs this gives 5-40x smaller pair errors
    # for the low modes than s² = ‖K‖/‖M‖, which centres the scaling on the highest modes.
    # A sweep's hint (|λ₁| of the previous speed, or of the structure) is such an s already.
    nM = la.norm(M, 1)
    if hint is not None and np.isfinite(hint) and hint > 0:
        s = float(hint)
    else:
        mu = symmetric_low_modes(M, (K + K.T) / 2, eigvals_only=True)[0]
        small = np.abs(mu).min()
        s = np.sqrt(small) if small > 0 else np.sqrt(la.norm(K, 1) / nM)
    norm = s * s * nM
    Ms, Cs, Ks = M * (s * s / norm), C * (s / norm), K / norm
    A = np.zeros((2 * n, 2 * n))
    B = np.zeros((2 * n, 2 * n))
    A[:n, n:] = B[:n, :n] = np.eye(n)
    A[n:, :n], A[n:, n:], B[n:, n:] = -Ms, -Cs, Ks
    # Homogeneous pairs (α, β): μ = α/β, ν = 1/μ = β/α; a singular K (β = 0) gives λ = 0.
    alpha, beta = la.eig(A, B, right=False, homogeneous_eigvals=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        return s * beta / alpha, (s, Ms, Cs, Ks)


def null_vectors(M: np.ndarray, C: np.ndarray | None, K: np.ndarray, lam: np.ndarray, start=None) -> np.ndarray:
    """Eigenvectors of the QEP for the eigenvalues ``lam`` only, by one step of inverse iteration
    x = P(λ)⁻¹b, P(λ) = λ²M + λC + K (one batched LU of k n×n matrices), unit 2-norm.

    With λ accurate to round-off, one step from a fixed generic b leaves in x only a round-off
    share of the other eigenvectors (the pair error of every pair is checked afterwards); for
    the few pairs a point reports this costs far less than LAPACK's eigenvectors of all 2n
    pairs. An exactly singular P(λ) falls back to the SVD's null vector. Equal eigenvalues get
    different b, so a double eigenvalue keeps two independent vectors. ``start[i]`` picks the b
    of eigenvalue i (default i): a batch of problems passes each pair's index in its own problem,
    so that a problem gets the same vectors batched or alone."""
    lam = np.asarray(lam, dtype=complex)
    n = M.shape[-1]  # M, C, K may also be stacks (k, n, n), one per eigenvalue
    if lam.size == 0:
        return np.zeros((n, 0), complex)
    L = lam[:, None, None]
    P = L * L * M + K if C is None else L * L * M + L * C + K
    b = _start(n)[(np.arange(lam.size) if start is None else np.asarray(start)) % _N_START]
    try:
        X = np.linalg.solve(P, b[:, :, None])[..., 0]
        if not np.all(np.isfinite(X)):
            raise np.linalg.LinAlgError("overflow")
    except np.linalg.LinAlgError:
        X = np.linalg.svd(P)[2][:, -1, :].conj()
    return (X / np.linalg.norm(X, axis=1, keepdims=True)).T


_N_START = 7  # distinct start vectors: up to 7-fold repeated eigenvalues keep independent vectors


@lru_cache(maxsize=8)
def _start(n: int) -> np.ndarray:
    """Fixed generic complex start vectors (_N_START, n), reproducible for every n."""
    rng = np.random.default_rng(20261128)
    return rng.uniform(0.5, 1.5, (_N_START, n)) * np.exp(2j * np.pi * rng.uniform(size=(_N_START, n)))


def _vector_pairs(lam: np.ndarray, n_modes: int, imag_tol: float = IMAG_TOL) -> np.ndarray:
    """Indices of the pairs whose eigenvectors a point needs: the ones it reports
    (:func:`modes.reported`: the ``n_modes`` lowest oscillatory ones and every real one), the
    only ones :func:`polish.polish_reported` polishes."""
    osc, is_real = reported(lam, max(n_modes, 1), imag_tol)
    return np.concatenate([osc, np.flatnonzero(is_real & np.isfinite(lam))])


# Problems up to this size are batched by DenseEngine.solve_many (per-pair stacks of n×n matrices).
BATCH_MAX_N = 64


class _Spectrum(NamedTuple):
    """One problem's LAPACK result: λ, method, the balanced and scaled QEP (eigenvalues λ/s),
    LAPACK's vectors of K v = μ M v (symmetric path) or None, and the balancing d."""

    lam: np.ndarray
    method: str
    s: float
    M: np.ndarray
    C: np.ndarray | None
    K: np.ndarray
    V: np.ndarray | None
    d: np.ndarray


def _balanced_spectrum(q: DenseQEP, hint) -> _Spectrum:
    d = balance(q.mass, q.stiffness)
    C = None if q.damping is None else d[:, None] * q.damping * d
    lam, method, (s, Ms, Cs, Ks), V = _spectrum(d[:, None] * q.mass * d, C, d[:, None] * q.stiffness * d, q.kind, hint)
    return _Spectrum(lam, method, s, Ms, Cs, Ks, V, d)


def _per_pair(mats: list, counts: list):
    """One matrix per used pair, ``counts[i]`` copies of ``mats[i]`` ((k, n, n); zeros for a
    missing C; None if every one is missing), or the one problem's own matrix."""
    if all(A is None for A in mats):
        return None
    if len(mats) == 1:
        return mats[0]
    n = next(A for A in mats if A is not None).shape[0]
    stack = np.stack([np.zeros((n, n)) if A is None else A for A in mats])
    return stack[np.repeat(np.arange(len(mats)), counts)]


def _eigenvectors(parts: list, used: list) -> list:
    """Each problem's eigenvectors (NaN columns where not used): LAPACK's on the symmetric path,
    else :func:`null_vectors` of every used pair of every problem in one batched solve."""
    n = parts[0].d.size
    X = [np.full((n, p.lam.size), complex(np.nan, np.nan)) for p in parts]
    for x, p, u in zip(X, parts, used):
        if p.V is not None:
            x[:, u] = np.hstack([p.V, p.V])[:, u]
    inv = [i for i, p in enumerate(parts) if p.V is None]
    if inv:
        sub, su = [parts[i] for i in inv], [used[i] for i in inv]
        lam = np.concatenate([p.lam[u] / p.s for p, u in zip(sub, su)])
        counts = [u.size for u in su]
        Y = null_vectors(*(_per_pair([getattr(p, m) for p in sub], counts) for m in "MCK"), lam,
                         np.concatenate([np.arange(k) for k in counts]))
        for i, y in zip(inv, np.split(Y, np.cumsum(counts)[:-1], axis=1)):
            X[i][:, used[i]] = y
    for x, p, u in zip(X, parts, used):
        x[:, u] *= p.d[:, None]
    return X


def _pair_errors(dense: list, parts: list, X: list, used: list) -> list:
    """Each problem's pair errors (NaN where no vector), all problems' pairs in one evaluation."""
    counts = [u.size for u in used]
    q = DenseQEP(*(_per_pair([getattr(q, m) for q in dense], counts) for m in ("mass", "damping", "stiffness")),
                 dense[0].kind if len(dense) == 1 else GENERAL)
    lam = np.concatenate([p.lam[u] for p, u in zip(parts, used)])
    cols = np.concatenate([x[:, u] for x, u in zip(X, used)], axis=1)
    flat = pair_error(q, lam, cols)
    out = []
    for p, u, e in zip(parts, used, np.split(flat, np.cumsum(counts)[:-1])):
        err = np.full(p.lam.size, np.nan)
        err[u] = e
        out.append(err)
    return out


def _sym_definite(dense: list) -> list:
    """The Cholesky certificate of every problem at once (True: sym(K) positive definite), or
    None each (then :func:`check_divergence` decides problem by problem)."""
    S = np.stack([q.stiffness for q in dense])
    try:
        np.linalg.cholesky(0.5 * (S + S.transpose(0, 2, 1)))  # raises if any one is not
    except np.linalg.LinAlgError:
        return [None] * len(dense)
    return [True] * len(dense)


class DenseEngine:
    """QZ / symmetric-definite LAPACK solver; returns all 2n eigenvalues of the QEP.

    Every path solves a diagonally balanced problem (:func:`balance`) in an inverted variable,
    so the low modes are the *largest* eigenvalues LAPACK computes (docs/numerical-stability.md).
    Eigenvectors (and pair errors) only of the pairs a point reports (:func:`null_vectors`).
    Implements :class:`~fkev_slepc.solve.protocol.Engine`; ``settings`` are the thresholds
    (default: the code defaults; ``max_pair_error`` overrides theirs).
    """

    name = "dense"

    def __init__(self, settings: SolveSettings | None = None, *, max_pair_error: float | None = None):
        settings = SolveSettings() if settings is None else settings
        if max_pair_error is not None:
            settings = settings.replace(max_pair_error=float(max_pair_error))
        self.solve_settings = settings

    @property
    def max_pair_error(self) -> float:
        return self.solve_settings.max_pair_error

    def solve(self, qep: QEP, n_modes: int = 0, want_vectors: bool = False, hint=None) -> EigenSolution:
        """Every eigenvalue of ``qep``; eigenvectors (and pair errors) of the pairs a point
        reports. ``hint`` ≈ |λ₁| (a sweep's previous speed) saves the QZ path its scale solve."""
        return self._solve_all([qep], n_modes, want_vectors, [hint])[0]

    def solve_many(self, qeps: list, n_modes: int = 0, want_vectors: bool = False, hints=None) -> list:
        """:meth:`solve` of several problems of one model (e.g. the cases of one crank speed).

        LAPACK runs problem by problem; the rest (eigenvectors of the reported pairs, pair
        errors, the Cholesky certificate) runs once for all of them: at thesis size its numpy
        overhead per problem cost about as much as the QZ itself (scripts/bench_small.py).
        """
        hints = [None] * len(qeps) if hints is None else list(hints)
        if len(qeps) > 1 and qeps[0].n > BATCH_MAX_N:
            return [self._solve_all([q], n_modes, want_vectors, [h])[0] for q, h in zip(qeps, hints)]
        return self._solve_all(qeps, n_modes, want_vectors, hints)

    def _solve_all(self, qeps: list, n_modes: int, want_vectors: bool, hints: list) -> list:
        st = self.solve_settings
        for q in qeps:
            require_finite(q)  # a point failure with the reason, not LAPACK's ValueError
        dense = [as_dense(q) for q in qeps]
        parts = [_balanced_spectrum(q, h) for q, h in zip(dense, hints)]
        used = [_vector_pairs(p.lam, n_modes, st.imag_tol) for p in parts]
        X = _eigenvectors(parts, used)
        errors = _pair_errors(dense, parts, X, used)
        definite = _sym_definite(dense) if len(dense) > 1 else [None]
        out = []
        for qep, q, p, x, err, pd in zip(qeps, dense, parts, X, errors, definite):
            # beyond the assembled K's round-off
            lam, x, err, note = polish_reported(qep, p.lam, x, err, n_modes, st)
            # LAPACK always "converges"; the pairs still have to satisfy the QEP (the same check
            # as the SLEPc engine's: on over-refined meshes the assembled K no longer determines them).
            msg = "; ".join(m for m in (note, check_pairs(q, lam, x, err, max(n_modes, 1), st)[1]) if m)
            # The whole spectrum is at hand: the divergence check uses it when no certificate decides.
            verdict = check_divergence(q, spectrum=lam, sym_definite=pd, imag_tol=st.imag_tol)
            out.append(EigenSolution(lam, err, x if want_vectors else None, not msg, p.method, msg, verdict,
                                     st.imag_tol))
        return out

    def settings(self) -> dict:
        return {"engine": "dense", "method": "LAPACK (scipy.linalg): eigh / eig / QZ of a scaled reversed companion",
                "max_pair_error": self.max_pair_error, "thresholds": self.solve_settings.as_dict()}

    def close(self) -> None:
        pass
