"""Floquet stability of a linkage at constant crank speed (docs/theory.md §18, docs/stability.md).

``floquet_multipliers(system, settings=DEFAULTS) -> LinkageFloquet``: the multipliers of one crank
revolution of M(θ)q̈ + C(θ)q̇ + K(θ)q = 0 for the :class:`~fkev_slepc.periodic.system.PeriodicSystem`
``system`` (``PeriodicSystem(model, omega, case, damping=...)``: the exact periodic coefficients of
:mod:`fkev_slepc.model.periodic`, Rayleigh damping from the scene's [damping] unless ``damping=False``),
with every tolerance and the reduction from the :class:`~fkev_slepc.periodic.settings.PeriodicSettings`
``settings``, integrated in the crank angle by :func:`fkev_slepc.periodic.magnus.monodromy`.

How:

1. The first-order generator A(θ) (1/rad) of :class:`~fkev_slepc.periodic.system.PeriodicSystem`
   is built exactly at ``samples`` equispaced crank angles and evaluated in between by its
   trigonometric interpolant; the samples double until the interpolant's relative error at the
   midpoints (measured against the exact coefficients there) is below ``interp_tol``. The Magnus integrator then costs one GEMM per block of steps
   for the coefficients, whatever the model.
2. Lagrangian cases (``LAGRANGIAN_CASES``) are integrated in canonical coordinates (q, p),
   p = M q̇ + Ω N₁ q, where A is Hamiltonian when undamped: each Magnus step is then exactly
   symplectic, so |μ| = 1 holds to round-off wherever the exact system is stable, and det Φ = 1;
   their steps use the structure (:mod:`fkev_slepc.periodic.hamiltonian`: the interpolant holds
   about half the entries, a commutator takes half the products).
   A lone rotating link is integrated in its own frame, where the generator is constant
   (:meth:`PeriodicSystem.link_frame`); wherever the samples agree to round-off the monodromy is
   one exponential, exp(2π A) (two Magnus steps and one for the error estimate: exact).
   ``no_coriolis`` and ``no_tangential`` drop one half of a Lagrangian term and are not
   Hamiltonian; they use the state (q, q̇). Both are scaled DOF by DOF (q̂ᵢ = dᵢqᵢ,
   p̂ᵢ = pᵢ/dᵢ, dᵢ = (Mᵢᵢ Kᵢᵢ)^¼), which keeps the canonical structure; the scaling is fixed
   once per system, so the samples and the midpoints are the same function.
3. ``reduce`` projects on co-rotating frozen modes (:mod:`fkev_slepc.periodic.reduce`):
   undamped frozen modes of the case at ``basis_angles`` equispaced angles, unit-normalised, each
   node translation written in its link's frame, SVD-compressed (Galerkin on a Lagrangian system
   is Lagrangian, so the reduced steps stay symplectic). ``reduce="auto"`` grows the basis level
   by level until max|μ| and the retained Floquet frequencies change by less than ``reduce_tol``
   (:mod:`fkev_slepc.periodic.truncation`, which states the rule); ``reduce=r`` takes the
   lowest r modes per angle and measures the same changes against 2r. ``truncation`` holds them.
   ``reduce="links"`` / ``"links:N"`` project instead on each link's Craig–Bampton component
   modes in its own frame (:mod:`fkev_slepc.periodic.components`, docs/theory.md §18.8),
   through the same projection and the same convergence rule (modes per link doubled).

Result (``LinkageFloquet``): ``multipliers`` (2n,) complex sorted by |μ|, ``exponents`` (2n,)
complex in 1/s (Re: growth rate; Im unwrapped to the mode's frequency, rad/s, by its
eigenvector's Rayleigh quotient on the frozen stiffness and mass at the start angle), ``max_abs``
(max|μ|, the growth factor per revolution), ``monodromy`` (the :class:`Monodromy`, Φ in the scaled
coordinates), ``error`` (the error estimate of the multipliers' moduli |μ|: the monodromy's
step-doubling estimate plus
``interp_multiplier_error`` = 2π · ``interp_error`` · max|A| · max|μ|, the first-order bound of
the interpolation error on Φ, where the interpolant stopped at its sample cap above ``interp_tol``;
one that meets ``interp_tol`` is as accurate as its samples, whose own round-off every monodromy
shares, and adds nothing), ``interp_error``, ``samples``, ``n_dof``,
``basis`` (None or the basis size) and ``truncation`` (None or the :class:`Truncation` measured;
``truncation.value`` its larger measure).

``TrigInterpolant`` and ``to_dense`` are re-exported from :mod:`fkev_slepc.periodic.interpolant`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as la

from fkev_slepc.periodic.magnus import Monodromy, exponential_monodromy, monodromy, multiplier_change
from fkev_slepc.periodic.components import link_components
from fkev_slepc.periodic.moving import moving_pool
from fkev_slepc.periodic.reduce import compress, frozen_pool
from fkev_slepc.periodic.settings import DEFAULTS, PeriodicSettings
from fkev_slepc.periodic.system import CONSTANT_TOL, Coefficients, PeriodicSystem, spread
from fkev_slepc.periodic.interpolant import TrigInterpolant, to_dense
from fkev_slepc.periodic.truncation import (
    Truncation, basis_levels, converge, frequency_change, link_modes, moving_modes, resolve_reduce,
)

TWO_PI = 2.0 * np.pi
START_H_RHO = 4.0  # h·ρ(A) of the first Magnus level (docs/engine.md "Step count"); the steps then double on the error
# the Magnus steps' share of a reduced level's low Floquet frequencies' error: a thousandth of the
# truncation tolerance whose frequency measure compares them (``reduce_tol``, relative); the full
# model's frequencies enter no result and are not asked (``Monodromy.second_error`` states them)
FREQUENCY_TOL_SHARE = 1e-3
# every multiplier, matched (phases too), to GAP_SHARE of the smallest distance between two multipliers
# (at least 2π·edge_rtol): two levels whose coarse steps both misplace a narrow band agree on the moduli
# (|μ| = 1 on both, symplectic steps) and would call an unstable speed stable (Bahgat–Willmert thesis
# mesh at 582.7007 rad/s: 256 and 512 steps stable, max|μ| - 1 = 3.5e-3 from 1,024 on). An instability
# begins where two multipliers collide: with every multiplier within a quarter of the smallest gap no
# collision hides in the error, so the verdict is the converged one (docs/engine.md "Step count")
GAP_SHARE = 0.25
PHASE_TOL_PER_RTOL = TWO_PI


def matched_tolerance(edge_rtol: float):
    """μ -> the matched multipliers' step tolerance: max(2π·edge_rtol, GAP_SHARE·min |μᵢ - μⱼ|)."""
    def tol(mu):
        gap = np.abs(mu[:, None] - mu[None, :])[np.triu_indices(mu.size, 1)]
        return max(PHASE_TOL_PER_RTOL * edge_rtol, GAP_SHARE * float(np.min(gap, initial=np.inf)))
    return tol


__all__ = ["LinkageFloquet", "TrigInterpolant", "floquet_multipliers", "full_min_steps", "to_dense"]


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
    interp_multiplier_error: float = 0.0  # the interpolation error's bound on the multipliers
    covered_rad_s: float | None = None  # link-frame components: highest retained fixed-interface frequency

    @property
    def max_abs(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    @property
    def error(self) -> float:
        """The multiplier error estimate: the monodromy's step doubling plus the bound of the
        generator's interpolation error (every error that enters the result)."""
        return self.monodromy.error + self.interp_multiplier_error


def _unwrapped_exponents(mu, X, c: Coefficients, d, omega: float) -> np.ndarray:
    """log(μ)|Ω|/2π with Im shifted by a multiple of |Ω| to the mode's frequency (Rayleigh
    quotient of the eigenvector's q part, the Floquet solution's shape at the start angle, on the
    frozen stiffness and mass there)."""
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


def _step_measure(c: Coefficients, d, omega: float, retained: int):
    """The (spectrum, change) pair that the Magnus step count is decided on (``monodromy``'s
    ``measure``; docs/engine.md "Step count"): what the results use. The multipliers' moduli,
    compared sorted (the growth factors the verdict reads: the largest difference between the two
    levels' sorted |μ|, absolute), the ``retained`` lowest Floquet frequencies (relative,
    :func:`~fkev_slepc.periodic.truncation.frequency_change`: the frequencies the truncation
    measures compare), and every multiplier matched (absolute: the phases place the bands;
    :func:`matched_tolerance`)."""

    def spectrum(phi):
        mu, X = la.eig(phi)
        with np.errstate(divide="ignore", invalid="ignore"):  # a blown-up coarse level (μ = 0): NaN, never converged
            return _unwrapped_exponents(mu, X, c, d, omega)

    def change(fine, coarse):
        moduli = float(np.max(np.abs(np.sort(np.abs(fine[0])) - np.sort(np.abs(coarse[0])))))
        return moduli, frequency_change(coarse[1], fine[1], omega, retained), multiplier_change(fine, coarse)[0]

    return spectrum, change


def full_min_steps(model, omega: float, case: str = "full", damping: bool = True, start: float = 0.0,
                   basis=None) -> int:
    """The full model's (or, given ``basis``, the reduced model's) least Magnus step count over a
    revolution, 2·2π·ρ(A) at ``start``."""
    A = PeriodicSystem(model, omega, case, damping=damping, basis=basis, start=start).generator(np.zeros(1))
    return int(np.ceil(2.0 * TWO_PI * np.max(np.abs(la.eigvals(A[0])))))


def default_reduction(model, omega: float, case: str = "full", damping: bool = True, start: float = 0.0,
                      settings: PeriodicSettings = DEFAULTS):
    """``reduce="default"`` resolved for one speed (docs/engine.md) by the fields of ``settings``:
    None (the full model) below ``auto_min_steps`` full-model steps; above, ``"links"`` where the
    link-component level of 4·``link_modes`` modes per link (the first that can end its sequence)
    is a strict sub-basis needing at most 1/``links_step_ratio`` of the full model's steps, else ``"auto"``."""
    full = full_min_steps(model, omega, case, damping, start)
    if full < settings.auto_min_steps:
        return None
    basis = link_components(model).basis(4 * settings.link_modes)
    if basis.shape[1] < model.n_free and settings.links_step_ratio * full_min_steps(
            model, omega, case, damping, start, basis) <= full:
        return "links"
    return "auto"


def floquet_multipliers(system: PeriodicSystem, settings: PeriodicSettings = DEFAULTS, *, check_truncation: bool = True,
                        comm=None, progress=None) -> LinkageFloquet:
    """Floquet multipliers of one crank revolution of ``system`` (its model, crank speed ≠ 0, case,
    damping, start angle; with its ``basis`` — a co-rotated V̂ (n, R), a
    :class:`~fkev_slepc.periodic.components.LinkBasis` or a moving basis — on that basis alone).

    ``settings`` (:class:`~fkev_slepc.periodic.settings.PeriodicSettings`): every tolerance and the
    reduction ``reduce``, resolved by :func:`~fkev_slepc.periodic.settings.resolve_reduce` (the one
    meaning: ``"none"`` the full model, ``"default"`` — the settings' default — decided per speed by
    :func:`default_reduction`): ``"auto"`` (frozen modes at ``basis_angles`` angles, the sequence of
    :mod:`fkev_slepc.periodic.truncation` to ``reduce_tol``, at most ``max_basis`` vectors), r (the pool
    of r modes compressed at ``threshold``), ``"links"`` / ``"links:N"`` (link-frame component modes,
    :mod:`fkev_slepc.periodic.components`; ``covered_rad_s`` states the highest retained fixed-interface
    frequency), ``"moving"`` / ``"moving:R"`` (fkev_slepc/periodic/moving.py); the sequences climb the one
    reduction ladder (fkev_slepc/periodic/ladder.py), a fixed level is measured against its double unless
    ``check_truncation`` is False. ``comm``: an MPI communicator whose ranks share every monodromy's
    steps (collective; one speed on several ranks). ``progress(steps done, steps)``: called by the Magnus
    integrator after each block of steps (:func:`monodromy`). ``monodromy_tol``: the error of the
    multipliers' moduli asked of the integrator, relative to max(1, max|μ|) (the steps double from
    h·ρ(A) ≈ ``START_H_RHO`` until the step-doubling estimate, pre-asymptotic levels guarded, is below
    it, and on a reduced basis that of the lowest four Floquet frequencies below
    ``FREQUENCY_TOL_SHARE``·``reduce_tol`` relative, and every multiplier matched within
    :func:`matched_tolerance` of the gaps between them: :func:`_step_measure`,
    :func:`~fkev_slepc.periodic.magnus.step_doubling_error`); 1e-8 keeps the verdict's 10 × error a
    tenth of its 1e-6 (docs/engine.md "Step count")."""
    if not np.isfinite(system.omega) or system.omega == 0.0:
        raise ValueError(f"omega: the Floquet analysis needs a non-zero crank speed, got {system.omega!r}")
    if not isinstance(settings, PeriodicSettings):
        raise ValueError(f"settings: must be a PeriodicSettings (got {type(settings).__name__})")
    reduce = None if system.basis is not None else resolve_reduce(settings.reduce)
    if reduce == "default":
        reduce = default_reduction(system.model, system.omega, system.case, system.damping, system.start, settings)
    if reduce is None:
        return _monodromy(system, settings, comm, progress)
    return _reduced(system, reduce, settings, check_truncation, comm, progress)


def _reduced(system: PeriodicSystem, reduce, st: PeriodicSettings, check: bool, comm, progress) -> LinkageFloquet:
    """The multipliers on the reduction ``reduce`` (resolved, not None): its basis levels on the one
    ladder (:func:`~fkev_slepc.periodic.truncation.converge`), or a fixed level against its double."""
    model, omega, case = system.model, system.omega, system.case
    n = int(model.n_free)
    pool = lambda r: frozen_pool(model, omega, case, r, st.basis_angles, system.start)  # noqa: E731
    squeeze, first, fixed, moving = compress, st.auto_modes, None if reduce == "auto" else reduce, False
    if isinstance(reduce, str) and reduce.startswith("links"):  # link-frame component modes
        pool, squeeze, first, fixed = link_components(model).basis, _kept, st.link_modes, link_modes(reduce)
    elif isinstance(reduce, str) and reduce.startswith("moving"):  # the moving frozen-mode basis
        pool, squeeze, first = moving_pool(model, omega, case, st.moving_angles), _kept, st.moving_modes
        fixed, moving = moving_modes(reduce), True
    solve = lambda V: _monodromy(system.on(V), st, comm, progress)  # noqa: E731
    if fixed is None:  # the moving basis: its error falls an order or more per doubling, one pair decides
        levels = basis_levels(pool, squeeze, n, min(first, n - 1), st.max_basis or None)
        res, trunc = converge(solve, levels, n, tol=st.reduce_tol, retained=min(st.auto_modes, n - 1),
                              confirm=not moving)
        return replace(res, truncation=trunc)
    r = fixed if link_modes(reduce) is not None else min(fixed, n - 1)
    twice = max(2 * r, 1) if link_modes(reduce) is not None else min(2 * r, n - 1)
    level = lambda k: squeeze(pool(k), st.threshold)  # noqa: E731
    if not check:
        return solve(level(r))
    res, trunc = converge(solve, (level(k) for k in (r, twice)), n, tol=st.reduce_tol, retained=r, fixed=True)
    return replace(res, truncation=trunc)


def _kept(P, tau):
    """The identity ``compress`` of the link components and the moving basis (each level is its pool)."""
    return P


def _monodromy(system: PeriodicSystem, st: PeriodicSettings, comm=None, progress=None) -> LinkageFloquet:
    """The multipliers of ``system`` as it is (on its basis, or the full model): the steps of the module
    docstring, the first level at h·ρ(A) ≈ ``START_H_RHO``."""
    basis, model, omega = system.basis, system.model, system.omega
    system = system.link_frame() or system  # a lone rotating link: constant in its own frame
    interp = system.interpolant(st.samples, st.interp_tol, st.max_samples)
    gen = interp.generator
    c = system.coefficients(np.array([system.start]))
    if spread(gen.S) <= CONSTANT_TOL:  # constant A: Φ = exp(2π A), by its eigenvalues
        mono, lam, X = exponential_monodromy(gen.S[0], TWO_PI, system.start)
        mu = np.exp(TWO_PI * lam)
    else:
        # the first level takes h·ρ(A) ≈ START_H_RHO (Magnus is exact for constant A; only the
        # turning of A's stiff parts with the links needs resolving), then the steps double on the
        # multiplier error, pre-asymptotic levels guarded (magnus.step_doubling_error); the stiff
        # bound h·ρ(A) <= 1/2 of the earlier rule (or 2^16) is the cap: no run takes more steps than it could
        rho = float(np.max(np.abs(la.eigvals(gen.S[0]))))
        mono = monodromy(gen, TWO_PI, order=st.magnus_order, steps=st.steps or None, tol=np.inf,
                         mu_tol=st.monodromy_tol, min_steps=int(np.ceil(TWO_PI * rho / START_H_RHO)),
                         max_steps=max(2**16, int(2 ** np.ceil(np.log2(2.0 * TWO_PI * rho)))),
                         comm=comm, progress=progress,  # frequencies: compared by the truncation only
                         second_tol=np.inf if basis is None else FREQUENCY_TOL_SHARE * st.reduce_tol,
                         matched_tol=matched_tolerance(st.edge_rtol),
                         measure=_step_measure(c, system.dof_scaling, omega, min(st.auto_modes, model.n_free)))
        mu, X = la.eig(mono.phi)
    mu, s = _unwrapped_exponents(mu, X, c, system.dof_scaling, omega)
    # first-order bound of the interpolation error on Φ over one revolution, ‖δΦ‖ <= 2π ‖δA‖ max|μ|
    bound = TWO_PI * interp.error * interp.peak * mono.max_abs if interp.error > st.interp_tol else 0.0
    return LinkageFloquet(float(omega), system.case, mu, s, mono, interp.error, interp.samples, int(model.n_free),
                          None if basis is None else basis.shape[1], None, bound,
                          getattr(basis, "covered_rad_s", None))
