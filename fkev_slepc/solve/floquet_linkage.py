"""Floquet stability of a linkage at constant crank speed (docs/theory.md §18, docs/stability.md).

``floquet_multipliers(model_or_scene, omega, case="full", ...) -> LinkageFloquet``: the
multipliers of one crank revolution of M(θ)q̈ + C(θ)q̇ + K(θ)q = 0 with the exact periodic
coefficients of :mod:`fkev_slepc.model.periodic` (Rayleigh damping from the scene's [damping]
unless ``damping=False``), integrated in the crank angle by :func:`fkev_slepc.solve.floquet.monodromy`.

How:

1. The first-order generator A(θ) (1/rad) is built exactly at ``samples`` equispaced crank
   angles and evaluated in between by its trigonometric interpolant; the samples double until
   the interpolant's relative error at the midpoints (measured against the exact coefficients
   there) is below ``interp_tol``. The Magnus integrator then costs one GEMM per block of steps
   for the coefficients, whatever the model.
2. Lagrangian cases (``LAGRANGIAN_CASES``) are integrated in canonical coordinates (q, p),
   p = M q̇ + Ω N₁ q, where A is Hamiltonian when undamped: each Magnus step is then exactly
   symplectic, so |μ| = 1 holds to round-off wherever the exact system is stable, and det Φ = 1.
   ``no_coriolis`` and ``no_tangential`` drop one half of a Lagrangian term and are not
   Hamiltonian; they use the state (q, q̇). Both are scaled DOF by DOF (q̂ᵢ = dᵢqᵢ,
   p̂ᵢ = pᵢ/dᵢ, dᵢ = (Mᵢᵢ Kᵢᵢ)^¼), which keeps the canonical structure.
3. ``reduce`` projects on co-rotating frozen modes (:mod:`fkev_slepc.solve.floquet_reduce`):
   undamped frozen modes of the case at ``basis_angles`` equispaced angles, unit-normalised, each
   node translation written in its link's frame, SVD-compressed (Galerkin on a Lagrangian system
   is Lagrangian, so the reduced steps stay symplectic). ``reduce="auto"`` grows the basis level
   by level until max|μ| and the retained Floquet frequencies change by less than ``reduce_tol``
   (:mod:`fkev_slepc.solve.floquet_truncation`, which states the rule); ``reduce=r`` takes the
   lowest r modes per angle and measures the same changes against 2r. ``truncation`` holds them.
   ``reduce="links"`` / ``"links:N"`` project instead on each link's Craig–Bampton component
   modes in its own frame (:mod:`fkev_slepc.solve.floquet_components`, docs/theory.md §18.8),
   through the same projection and the same convergence rule (modes per link doubled).

Result (``LinkageFloquet``): ``multipliers`` (2n,) complex sorted by |μ|, ``exponents`` (2n,)
complex in 1/s (Re: growth rate; Im unwrapped to the mode's frequency, rad/s, by its
eigenvector's Rayleigh quotient on the frozen stiffness and mass at the start angle), ``max_abs``,
``growth_per_revolution`` (= max|μ|), ``monodromy`` (the :class:`Monodromy`, Φ in the scaled
coordinates), ``error`` (multiplier error estimate), ``interp_error``, ``samples``, ``n_dof``,
``basis`` (None or the basis size), ``truncation`` (None or the :class:`Truncation` measured)
and ``truncation_error`` (its larger measure).

``TrigInterpolant(start, samples)``: the trigonometric interpolant used in step 1 (callable
θ -> (len(θ), n, n)), for any other smooth 2π-periodic matrix function sampled at k equispaced
angles; ``to_dense(pattern, data)``: (k, nnz) CSR data -> (k, n, n).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as la

from fkev_slepc.model.periodic import periodic_pieces
from fkev_slepc.solve.floquet import Monodromy, monodromy
from fkev_slepc.solve.floquet_reduce import compress, frozen_pool, reduced_coefficients
from fkev_slepc.solve.floquet_components import LINK_MODES, link_components
from fkev_slepc.solve.floquet_truncation import (
    AUTO_ANGLES, AUTO_MIN_STEPS, AUTO_MODES, LINKS_STEP_RATIO, REDUCE_TOL, Truncation, between, converge, link_modes,
    resolve_reduce,
)

TWO_PI = 2.0 * np.pi


def to_dense(pattern, data: np.ndarray) -> np.ndarray:
    """(k, nnz) CSR data on ``pattern`` -> (k, n, n) dense stacks."""
    rows = np.repeat(np.arange(pattern.n), np.diff(pattern.indptr))
    out = np.zeros((data.shape[0], pattern.n, pattern.n))
    out[:, rows, pattern.indices] = data
    return out


@dataclass(frozen=True)
class _Coefficients:
    """Dense per-angle matrices of one speed (after an optional Galerkin projection)."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    N: np.ndarray | None  # Ω N₁ (canonical form), None for a non-Lagrangian case
    V: np.ndarray | None  # K₀ + Ω² V₂
    Cd: np.ndarray | None  # Rayleigh C_d
    Kd: np.ndarray | None  # Ω K_d


def _coefficients(model, thetas, omega, case, damping, basis=None) -> _Coefficients:
    p = periodic_pieces(model, thetas, case)
    pat = model.pattern
    M, C, K = p.coefficients(omega) if damping else (
        p.mass, omega * p.gyro, p.stiffness + omega * omega * p.speed_stiffness)
    N = V = Cd = Kd = None
    if p.lagrangian:
        N = omega * p.coupling
        V = p.stiffness + omega * omega * p.potential
    if damping and p.damping is not None:
        Cd, Kd = p.damping, omega * p.damping_stiffness
    if basis is not None:
        return _Coefficients(*reduced_coefficients(model, p, thetas, omega, damping, basis))
    return _Coefficients(*(None if x is None else to_dense(pat, x) for x in (M, C, K, N, V, Cd, Kd)))


def _scaling(c: _Coefficients) -> np.ndarray:
    m = np.abs(np.mean(np.diagonal(c.M, axis1=1, axis2=2), axis=0))
    k = np.abs(np.mean(np.diagonal(c.K, axis1=1, axis2=2), axis=0))
    k = np.where(k > 0, k, np.max(k))
    return (m * k) ** 0.25


def _generator_samples(c: _Coefficients, omega: float, d: np.ndarray) -> np.ndarray:
    """A(θ) in 1/rad at the sample angles, scaled by d (see the module docstring)."""
    k, n, _ = c.M.shape
    Minv = np.linalg.inv(c.M)
    A = np.zeros((k, 2 * n, 2 * n))
    if c.N is not None:  # (q, p): q̇ = M⁻¹(p - Nq), ṗ = (Nᵀ - C_d) q̇ - (V + K_d) q
        G = np.swapaxes(c.N, 1, 2) - (0.0 if c.Cd is None else c.Cd)
        A[:, :n, :n] = -Minv @ c.N
        A[:, :n, n:] = Minv
        A[:, n:, :n] = -G @ Minv @ c.N - c.V - (0.0 if c.Kd is None else c.Kd)
        A[:, n:, n:] = G @ Minv
        s = np.concatenate([d, 1.0 / d])
    else:  # (q, q̇)
        A[:, :n, n:] = np.eye(n)
        A[:, n:, :n] = -Minv @ c.K
        A[:, n:, n:] = -Minv @ c.C
        mk = np.abs(np.mean(np.diagonal(c.K, axis1=1, axis2=2), axis=0))
        mm = np.mean(np.diagonal(c.M, axis1=1, axis2=2), axis=0)
        s = np.concatenate([d, d / np.sqrt(np.where(mk > 0, mk, mk.max()) / mm)])
    A = A * s[None, :, None] / s[None, None, :]
    return A / abs(omega)


def _dirichlet(theta: np.ndarray, k: int) -> np.ndarray:
    """Weights (len(θ), k) of the trigonometric interpolant on the k (even) nodes 2πj/k:
    D(x) = sin(kx/2) cot(x/2)/k at x = θ - 2πj/k, by angle addition (sin(kθ_j/2) = 0,
    cos(kθ_j/2) = (-1)^j), so only O(len(θ) + k) transcendental evaluations."""
    half, node = 0.5 * theta[:, None], np.pi * np.arange(k)[None, :] / k
    sx = np.sin(half) * np.cos(node) - np.cos(half) * np.sin(node)  # sin(x/2)
    cx = np.cos(half) * np.cos(node) + np.sin(half) * np.sin(node)  # cos(x/2)
    sk = np.sin(k * half) * np.where(np.arange(k) % 2, -1.0, 1.0)[None, :]  # sin(kx/2)
    small = np.abs(sx) < 1e-12
    with np.errstate(invalid="ignore", divide="ignore"):
        w = sk * cx / (k * np.where(small, 1.0, sx))
    return np.where(small, np.sign(cx) ** k, w)


class TrigInterpolant:
    """θ -> (len(θ), n, n): the trigonometric interpolant of ``samples`` (k even, (k, n, n)) taken
    at start + 2πj/k, j = 0..k-1 (period 2π)."""

    def __init__(self, start, samples: np.ndarray):
        self.start, self.S = start, samples
        self.k = samples.shape[0]

    def __call__(self, theta):
        theta = np.asarray(theta, dtype=float)
        W = _dirichlet(theta - self.start, self.k)
        n = self.S.shape[1]
        return (W @ self.S.reshape(self.k, -1)).reshape(theta.size, n, n)


@dataclass(frozen=True)
class LinkageFloquet:
    omega: float
    case: str
    multipliers: np.ndarray
    exponents: np.ndarray
    monodromy: Monodromy
    interp_error: float
    samples: int
    n_dof: int
    basis: int | None = None
    truncation: Truncation | None = None
    covered_rad_s: float | None = None  # link-frame components: highest retained fixed-interface frequency

    @property
    def truncation_error(self) -> float | None:
        """None unless reduced with its truncation measured: the larger of |Δ max|μ|| and the
        largest relative change of a retained Floquet frequency (:class:`Truncation`)."""
        return None if self.truncation is None else self.truncation.value

    @property
    def max_abs(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    @property
    def growth_per_revolution(self) -> float:
        return self.max_abs

    @property
    def error(self) -> float:
        return self.monodromy.error


def _build(model, omega, case, damping, start, samples, interp_tol, basis, max_samples=1024):
    """Generator samples doubled until the interpolant of k samples matches the exact generator
    at the k midpoints to ``interp_tol`` (relative); the midpoints then join the samples."""
    sign = 1.0 if omega > 0 else -1.0
    angle = lambda tau: start + sign * tau

    def exact(tau):
        c = _coefficients(model, angle(tau), omega, case, damping, basis)
        return c, _generator_samples(c, omega, d)

    k = max(4, 2 * (int(samples) // 2))
    c0 = _coefficients(model, angle(TWO_PI * np.arange(k) / k), omega, case, damping, basis)
    d = _scaling(c0)
    S = _generator_samples(c0, omega, d)
    while True:
        tau_mid = TWO_PI * (np.arange(k) + 0.5) / k
        _, mid = exact(tau_mid)
        err = float(np.max(np.abs(TrigInterpolant(0.0, S)(tau_mid) - mid)) / np.max(np.abs(S)))
        both = np.empty((2 * k,) + S.shape[1:])
        both[0::2], both[1::2] = S, mid
        S, k = both, 2 * k
        if err <= interp_tol or k >= max_samples:
            return TrigInterpolant(0.0, S), err, k, c0, d


def _unwrapped_exponents(mono: Monodromy, c: _Coefficients, d, omega: float) -> np.ndarray:
    """log(μ)|Ω|/2π with Im shifted by a multiple of |Ω| to the mode's frequency (Rayleigh
    quotient of the eigenvector's q part, the Floquet solution's shape at the start angle, on the
    frozen stiffness and mass there)."""
    mu, X = la.eig(mono.phi)
    n = c.M.shape[1]
    q = X[:n] / d[:, None]
    Mb, Kb = c.M[0], c.K[0]
    Kb = 0.5 * (Kb + Kb.T)
    num = np.einsum("ik,ij,jk->k", q.conj(), Kb, q).real
    den = np.einsum("ik,ij,jk->k", q.conj(), Mb, q).real
    w_est = np.sqrt(np.maximum(num / den, 0.0))
    s = np.log(mu.astype(complex)) * abs(omega) / TWO_PI
    W = abs(omega)
    cands = np.stack([s.imag + np.round((sg * w_est - s.imag) / W) * W for sg in (1.0, -1.0)])
    pick = np.argmin(np.abs(np.abs(cands) - w_est[None, :]), axis=0)
    s = s.real + 1j * cands[pick, np.arange(s.size)]
    order = np.argsort(-np.abs(mu), kind="stable")
    return mu[order], s[order]


def full_min_steps(model, omega: float, case: str = "full", damping: bool = True, start: float = 0.0,
                   basis=None) -> int:
    """The full model's (or, given ``basis``, the reduced model's) least Magnus step count over a
    revolution, 2·2π·ρ(A) at ``start``."""
    c = _coefficients(model, np.array([float(start)]), omega, case, damping, basis)
    A = _generator_samples(c, omega, _scaling(c))
    return int(np.ceil(2.0 * TWO_PI * np.max(np.abs(la.eigvals(A[0])))))


def default_reduction(model, omega: float, case: str = "full", damping: bool = True, start: float = 0.0):
    """``reduce="default"`` resolved for one speed (docs/engine.md): None (the full model) below
    ``AUTO_MIN_STEPS`` full-model steps; above, ``"links"`` where the link-component level of
    4·``LINK_MODES`` modes per link (the first that can end its sequence) is a strict sub-basis
    needing at most 1/``LINKS_STEP_RATIO`` of the full model's steps, else ``"auto"``."""
    full = full_min_steps(model, omega, case, damping, start)
    if full < AUTO_MIN_STEPS:
        return None
    basis = link_components(model).basis(4 * LINK_MODES)
    if basis.shape[1] < model.n_free and LINKS_STEP_RATIO * full_min_steps(
            model, omega, case, damping, start, basis) <= full:
        return "links"
    return "auto"


def floquet_multipliers(model_or_scene, omega: float, case: str = "full", *, damping: bool = True,
                        start: float = 0.0, order: int = 6, steps: int | None = None,
                        tol: float = 1e-10, samples: int = 16, interp_tol: float = 1e-12,
                        reduce: int | str | None = None, basis_angles: int = AUTO_ANGLES,
                        threshold: float = 1e-10, reduce_tol: float = REDUCE_TOL,
                        max_basis: int | None = None, check_truncation: bool = True,
                        basis: np.ndarray | None = None) -> LinkageFloquet:
    """Floquet multipliers of one crank revolution at crank speed ``omega`` (rad/s, ≠ 0).

    ``reduce``: None (the full model), ``"default"`` (:func:`default_reduction`: None below
    ``AUTO_MIN_STEPS`` full-model steps, above ``"links"`` or ``"auto"``), ``"auto"`` (the convergence sequence of
    :mod:`fkev_slepc.solve.floquet_truncation`, to ``reduce_tol``, at most ``max_basis``
    vectors) or r (the pool of r modes at ``basis_angles`` angles compressed at ``threshold``;
    its truncation measured against the pool of 2r unless ``check_truncation`` is False),
    ``"links"`` (link-frame component modes, :mod:`fkev_slepc.solve.floquet_components`: the
    modes per link double from ``LINK_MODES`` by the same convergence rule; ``covered_rad_s``
    states the highest retained fixed-interface frequency) or ``"links:N"`` (N modes per link,
    measured against 2N). ``basis``: an explicit basis instead: a co-rotated V̂ (n, R) or a
    :class:`~fkev_slepc.solve.floquet_components.LinkBasis`."""
    from fkev_slepc.model.operators import Model

    if not np.isfinite(omega) or omega == 0.0:
        raise ValueError(f"omega: the Floquet analysis needs a non-zero crank speed, got {omega!r}")
    model = model_or_scene if isinstance(model_or_scene, Model) else Model(model_or_scene, (case,))
    try:
        reduce = resolve_reduce(reduce)
    except ValueError as err:
        raise ValueError(f"reduce: {err}") from None
    if reduce == "default":
        reduce = default_reduction(model, omega, case, damping, start)
    if basis is None and reduce is not None:
        opts = dict(damping=damping, start=start, order=order, steps=steps, tol=tol, samples=samples,
                    interp_tol=interp_tol)
        solve = lambda V: floquet_multipliers(model, omega, case, basis=V, **opts)  # noqa: E731
        pool = lambda r: frozen_pool(model, omega, case, r, basis_angles, start)  # noqa: E731
        n, squeeze, first = int(model.n_free), compress, AUTO_MODES
        if isinstance(reduce, str) and reduce.startswith("links"):  # link-frame component modes
            comp = link_components(model)
            pool, squeeze, first = comp.basis, lambda P, tau: P, LINK_MODES  # noqa: E731
        if reduce in ("auto", "links"):
            res, trunc = converge(solve, pool, n, modes=min(first, n - 1), tol=reduce_tol,
                                  max_basis=max_basis, compress=squeeze, retained=min(AUTO_MODES, n - 1))
            return replace(res, truncation=trunc)
        r = min(reduce, n - 1) if link_modes(reduce) is None else link_modes(reduce)
        res = solve(squeeze(pool(r), threshold))
        if not check_truncation:
            return res
        ref = solve(squeeze(pool(min(2 * r, n - 1) if link_modes(reduce) is None else max(2 * r, 1)), threshold))
        return replace(res, truncation=between(ref, res, r, reduce_tol, [
            (x.basis, x.max_abs, float(np.max(x.exponents.real))) for x in (res, ref)]))
    gen, ierr, k, c, d = _build(model, omega, case, damping, start, samples, interp_tol, basis)
    # the step must resolve the fastest oscillation: h·ρ(A) <= 1 on the coarse half of the
    # step doubling (Magnus is exact for constant A, but the linkage's A turns with the links)
    rho = float(np.max(np.abs(la.eigvals(gen.S[0]))))
    mono = monodromy(gen, TWO_PI, order=order, steps=steps, tol=tol,
                     min_steps=int(np.ceil(2.0 * TWO_PI * rho)))
    mu, s = _unwrapped_exponents(mono, c, d, omega)
    return LinkageFloquet(float(omega), case, mu, s, mono, ierr, k, int(model.n_free),
                          None if basis is None else basis.shape[1], None, getattr(basis, "covered_rad_s", None))
