"""Dense reference solver: every eigenvalue of (λ²M + λC + K)x = 0 by LAPACK (scipy).

The QEP is scaled first (λ = s·ν with s ≈ |λ₁|, then divided by s²‖M‖) and linearized in the
reversed variable μ = 1/ν (docs/theory.md §10.2): in SI units ‖K‖/‖M‖ ~ 1e9-1e11 and a plain
companion form of the unscaled problem loses digits on the lowest modes. Problems without a
Coriolis term are solved as a generalized eigenproblem in μ = -λ² instead (symmetric-definite
when K is symmetric), which is exact and cheaper.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la

from fkev_slepc.solve.refine import polish_reported
from fkev_slepc.solve.modes import check_pairs
from fkev_slepc.solve.stability import check_divergence
from fkev_slepc.model.qep import LINEAR_SYMMETRIC, MAX_PAIR_ERROR, QEP, EigenSolution, pair_error


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


def symmetric_low_modes(M: np.ndarray, K: np.ndarray):
    """All (μ, V) of K v = μ M v (K, M symmetric, M positive definite), accurate at the low end.

    Solved inverted, M v = ν K v with ν = 1/μ, the way SLEPc's shift-and-invert about 0 does:
    LAPACK's symmetric-definite solver has an *absolute* eigenvalue error ~ε‖B⁻¹A‖, which on
    ``eigh(K, M)`` is set by the stiffest DOF over the lightest mass and made the lowest
    frequency of a rhombus linkage with a rigid crank and a 1e4 kg mass at B 6.6e-6 wrong;
    inverted, that error is relative to the largest ν = 1/μ₁ instead (tests/test_stress.py).
    When K is indefinite (divergence) the shift σ = 2|μ_min| + ... makes K + σM definite and
    ν = 1/(μ + σ).
    """
    sigma = 0.0
    for _ in range(2):
        try:
            nu, V = la.eigh(M, K + sigma * M)
        except la.LinAlgError:  # K + σM not positive definite: shift past the lowest μ
            mu_min = la.eigh(K, M, eigvals_only=True, subset_by_index=[0, 0])[0]
            sigma = 2.0 * max(-mu_min, 0.0) + np.finfo(float).eps * la.norm(K, 1) / la.norm(M, 1)
            continue
        with np.errstate(divide="ignore"):
            return 1.0 / nu - sigma, V
    return la.eigh(K, M)


def all_eigenpairs(qep: QEP, want_vectors: bool = True):
    """All 2n eigenvalues (and, if asked, eigenvectors) of ``qep``: (λ, X or None, method).

    Shared by :class:`DenseEngine` and the whole-spectrum divergence check of the SLEPc engine
    (solve/stability.py)."""
    M = qep.mass.toarray()
    K = qep.stiffness.toarray()
    d = balance(M, K)
    M, K = d[:, None] * M * d, d[:, None] * K * d
    if qep.kind == LINEAR_SYMMETRIC:  # operators.classify decides; no second symmetry test here
        mu, V = symmetric_low_modes(M, K)
        lam, X, method = _lambda_from_mu(mu), np.hstack([V, V]), "dense-eigh"
    elif qep.damping is None:
        (alpha, beta), V = _eig(M, K, want_vectors)  # ν = α/β = 1/μ
        with np.errstate(divide="ignore", invalid="ignore"):
            mu = beta / alpha
        lam, X, method = _lambda_from_mu(mu), None if V is None else np.hstack([V, V]), "dense-eig"
    else:
        lam, X = qz(M, d[:, None] * qep.damping.toarray() * d, K, want_vectors)
        method = "dense-qz"
    return lam, (d[:, None] * X if want_vectors else None), method


def _eig(A, B, want_vectors):
    """Homogeneous generalized eigenvalues (α, β) of (A, B), and right vectors if wanted."""
    if want_vectors:
        return la.eig(A, B, homogeneous_eigvals=True)
    return la.eig(A, B, right=False, homogeneous_eigvals=True), None


def qz(M: np.ndarray, C: np.ndarray, K: np.ndarray, want_vectors: bool = True):
    """(λ, X or None) of λ²M + λC + K by QZ of a scaled, reversed companion pencil."""
    n = M.shape[0]
    # λ = s·ν with s ≈ |λ₁| (from the symmetric part of K): the wanted low modes get |ν| ≈ 1.
    # Measured on Bahgat-Willmert meshes of 36-360 DOFs this gives 5-40x smaller pair errors
    # for the low modes than s² = ‖K‖/‖M‖, which centres the scaling on the highest modes.
    mu, _ = symmetric_low_modes(M, (K + K.T) / 2)
    small = np.abs(mu).min()
    nM = la.norm(M, 1)
    s = np.sqrt(small) if small > 0 else np.sqrt(la.norm(K, 1) / nM)
    norm = s * s * nM
    Ms, Cs, Ks = M * (s * s / norm), C * (s / norm), K / norm
    Z, I = np.zeros((n, n)), np.eye(n)
    A = np.block([[Z, I], [-Ms, -Cs]])
    B = np.block([[I, Z], [Z, Ks]])
    # Homogeneous pairs (α, β): μ = α/β, ν = 1/μ = β/α; a singular K (β = 0) gives λ = 0.
    (alpha, beta), V = _eig(A, B, want_vectors)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = s * beta / alpha
    return lam, None if V is None else V[:n]


class DenseEngine:
    """QZ / symmetric-definite LAPACK solver; returns all 2n eigenpairs of the QEP.

    Every path solves a diagonally balanced problem (:func:`balance`) in an inverted variable,
    so the low modes are the *largest* eigenvalues LAPACK computes (docs/numerical-stability.md).
    """

    name = "dense"

    def __init__(self, max_pair_error: float = MAX_PAIR_ERROR):
        self.max_pair_error = float(max_pair_error)

    def solve(self, qep: QEP, n_modes: int = 0, want_vectors: bool = False, hint=None) -> EigenSolution:
        lam, X, method = all_eigenpairs(qep)
        err = pair_error(qep, lam, X)
        lam, X, err = polish_reported(qep, lam, X, err, n_modes)  # beyond the assembled K's round-off
        # LAPACK always "converges"; the pairs still have to satisfy the QEP (the same check as
        # the SLEPc engine's: on over-refined meshes the assembled K no longer determines them).
        msg = check_pairs(qep, lam, X, err, max(n_modes, 1), self.max_pair_error)[1]
        # The whole spectrum is at hand: the divergence check uses it when no certificate decides.
        verdict = check_divergence(qep, spectrum=lam)
        return EigenSolution(lam, err, X if want_vectors else None, not msg, method, msg, verdict)

    def settings(self) -> dict:
        return {"engine": "dense", "method": "LAPACK (scipy.linalg): eigh / eig / QZ of a scaled reversed companion",
                "max_pair_error": self.max_pair_error}

    def close(self) -> None:
        pass
