"""Shooting for the periodic response of M(θ)q̈ + C(θ)q̇ + K(θ)q = f(θ), θ = Ωt, on the
monodromy of fkev_slepc/periodic/magnus.py (docs/response.md §3).

In θ the state x = (q, q') obeys x' = A(θ)x + b(θ) with the coefficients (Ω²M, ΩC, K) and the
load f. One revolution from x(0) = 0 under the load gives the particular state x_p(2π); the
periodic response starts from x₀ with (I − Φ)x₀ = x_p, Φ the monodromy. The multipliers μ
(eigenvalues of Φ) come with it: some |μ| > 1 means the periodic response exists but does not
attract (the machine would not settle on it); a multiplier at 1 makes (I − Φ) singular (exact
resonance: no periodic response, or not a unique one), which is refused.

**The periodic response where harmonic balance cannot converge** (:func:`periodic_shot`, docs/response.md
§3): the same x₀ at the step count N that brings its own step-doubling estimate below ``tol``. The
monodromy runs on the augmented state (x, 1), whose Φ̃ = [[Φ, x_p], [0, 1]] carries the particular
state (on a Hamiltonian generator by the structured augmented steps of
:func:`fkev_slepc.periodic.hamiltonian.forced`), and its levels N/2, N are compared on x₀ = (I − Φ)⁻¹x_p itself (``measure`` of
:func:`fkev_slepc.periodic.magnus.monodromy`): ``error`` is the change of x₀ between the two, the
larger over the state's two halves (displacements, and velocities or momenta), each relative to its
own largest component, divided by 2⁶ − 1 where the level before shows the integrator's rate (the
pre-asymptotic guard of :func:`~fkev_slepc.periodic.magnus.step_doubling_error`). The result is
evaluated at any crank angles by the same Magnus steps from x₀ (:class:`PeriodicShot`, ``at``):
exact in every harmonic of the load, no trigonometric interpolation of the response. It takes any
generator and forcing of the state: a linkage's are those of its PeriodicSystem (scaled, on the
interpolant Floquet takes; fkev_slepc/periodic/response.py).

:func:`shooting` and :func:`adapters` are the generic path of a system given by the interface of
:mod:`fkev_slepc.periodic.harmonic_balance` (``coefficients(theta)`` -> dense (M, C, K) stacks (k, n, n)
in the time form, ``load(theta)`` -> (k, n)) that is not a PeriodicSystem (closed-form oscillators):
their (q, q') generator of (Ω²M, ΩC, K) is no linkage's. A linkage is shot on its PeriodicSystem's
generator, the one Floquet takes (the response's fallback and its ``--shooting`` cross-check,
fkev_slepc/periodic/response.py; tests/test_layout.py checks that no other generator is built).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la

from fkev_slepc.periodic import hamiltonian, magnus
from fkev_slepc.periodic.settings import DEFAULTS

# (I − Φ) is singular to working precision when its smallest singular value is below this
# fraction of 1 + ‖Φ‖₂ (the size of the two terms it is the difference of)
RESONANCE_TOL = 1e-12


class ResonanceError(ValueError):
    """(I − Φ) is singular to working precision: a Floquet multiplier at 1 (exact resonance)."""


@dataclass(frozen=True)
class ShootingResponse:
    theta: np.ndarray  # (k,) rad, the angles asked for
    q: np.ndarray  # (k, n)
    dq: np.ndarray  # (k, n) dq/dθ
    multipliers: np.ndarray  # (2n,) complex, by decreasing |μ|
    error: float  # the monodromy's relative step-doubling estimate of Φ (and of x_p, the larger)
    rcond: float  # σ_min(I − Φ) / (1 + ‖Φ‖₂): distance from exact resonance
    steps: int
    closure: float  # ‖x(2π) − x(0)‖ / ‖x(0)‖ of the integrated periodic state

    @property
    def max_abs_multiplier(self) -> float:
        return float(np.abs(self.multipliers).max())


class _Cached:
    """(Ω²M, ΩC, K) and f at the last θ array: the generator and the forcing ask for the same
    angles one after the other."""

    def __init__(self, coefficients, load, omega):
        self.coefficients, self.load, self.w = coefficients, load, float(omega)
        self.key, self.value = None, None

    def __call__(self, theta):
        key = theta.tobytes()
        if key != self.key:
            M, C, K = (np.asarray(x, dtype=float) for x in self.coefficients(theta))
            self.key, self.value = key, (self.w**2 * M, self.w * C, K, np.asarray(self.load(theta), dtype=float))
        return self.value


def adapters(coefficients, load, omega):
    """(generator, forcing) of the state x = (q, q') in θ, sharing one cache of (Ω²M, ΩC, K, f)."""
    cache = _Cached(coefficients, load, omega)
    gen = magnus.second_order(lambda th: cache(th)[:3])
    forcing = magnus.second_order_forcing(lambda th: cache(th)[0], lambda th: cache(th)[3])
    return gen, forcing


def _periodic_state(phi, particular, mu, omega):
    """(x₀, LU of I − Φ, rcond) of the periodic state (I − Φ)x₀ = x_p of a forced monodromy Φ, x_p
    (``mu`` its multipliers).

    Raises
    ------
    ResonanceError
        (I − Φ) singular to working precision (a multiplier at 1), with the closest multiplier.
    """
    I_phi = np.eye(phi.shape[0]) - phi
    sv = la.svdvals(I_phi)
    rcond = float(sv[-1] / (1.0 + la.norm(phi, 2)))
    if rcond < RESONANCE_TOL:
        near = mu[np.argmin(np.abs(mu - 1.0))]
        raise ResonanceError(f"exact resonance at Ω = {omega:g} rad/s: (I - Φ) is singular to working precision "
                             f"(σ_min / (1 + ‖Φ‖) = {rcond:.1e}; multiplier μ = {near.real:.12g}{near.imag:+.3g}j "
                             "at 1): the periodic response does not exist or is not unique")
    lu = la.lu_factor(I_phi)
    return la.lu_solve(lu, particular), lu, rcond


def _relative(e, x0) -> float:
    """The larger of ‖e_q‖∞/‖q₀‖∞ and ‖e_q'‖∞/‖q₀'‖∞ of a state change e (2n,) at the state x₀."""
    n = x0.size // 2
    return float(max(np.abs(e[:n]).max() / max(np.abs(x0[:n]).max(), 1e-300),
                     np.abs(e[n:]).max() / max(np.abs(x0[n:]).max(), 1e-300)))


def states_at(generator, forcing, x0, thetas, steps: int, order: int = 6) -> np.ndarray:
    """The periodic state (k, 2n) at any crank angles ``thetas`` (k,) (taken mod 2π, any order)
    from its state ``x0`` at θ = 0, by Magnus steps of at most 2π/``steps``."""
    th = np.mod(np.asarray(thetas, dtype=float), 2.0 * np.pi)
    u, back = np.unique(th, return_inverse=True)
    path = u if u[0] == 0.0 else np.r_[0.0, u]
    x = magnus.trajectory(generator, x0, path, forcing=forcing, order=order, steps=steps, period=2.0 * np.pi)
    return x[path.size - u.size:][back.ravel()]


def shooting(coefficients, load, omega: float, thetas, *, steps: int | None = None, tol: float = DEFAULTS.shooting_tol,
             order: int = 6, max_steps: int = 2**14) -> ShootingResponse:
    """The periodic response at ``thetas`` (increasing, in [0, 2π]) by shooting on the monodromy.

    Raises
    ------
    ResonanceError
        (I − Φ) singular to working precision (a multiplier at 1), with the closest multiplier.
    """
    gen, forcing = adapters(coefficients, load, omega)
    with np.errstate(over="ignore", invalid="ignore"):  # the first, too coarse step sizes may overflow
        mono = magnus.monodromy(gen, 2.0 * np.pi, forcing=forcing, order=order, steps=steps, tol=tol,
                                 max_steps=max_steps)
    x0, _, rcond = _periodic_state(mono.phi, mono.particular, mono.multipliers, omega)
    thetas = np.asarray(thetas, dtype=float)
    path = np.r_[thetas, 2.0 * np.pi] if thetas[-1] < 2.0 * np.pi else thetas
    x = magnus.trajectory(gen, x0, path, forcing=forcing, order=order, steps=mono.steps, period=2.0 * np.pi)
    closure = float(np.linalg.norm(x[-1] - x0) / max(np.linalg.norm(x0), 1e-300))
    x = x[: thetas.size]
    n = x0.size // 2
    err = max(mono.phi_error, mono.particular_error or 0.0)
    return ShootingResponse(thetas, x[:, :n], x[:, n:], mono.multipliers, err, rcond, mono.steps, closure)


@dataclass(frozen=True)
class PeriodicShot:
    """The periodic response by shooting (:func:`periodic_shot`), evaluable at any crank angles."""

    x0: np.ndarray  # (2n,) the periodic state at τ = 0 (the generator's state and angle)
    multipliers: np.ndarray  # (2n,) complex, by decreasing |μ|
    error: float  # relative step-doubling estimate of x₀ (N/2 against N steps; module docstring)
    monodromy_error: float  # the multipliers' step-doubling estimate (absolute)
    rcond: float  # σ_min(I − Φ) / (1 + ‖Φ‖₂): distance from exact resonance
    steps: int
    generator: object = field(repr=False)
    forcing: object = field(repr=False)
    order: int = 6
    dof_scale: np.ndarray | None = None  # the state's first half is d ⊙ q (None: q itself)
    sign: float = 1.0  # the crank angle θ = start + sign·τ
    start: float = 0.0

    @property
    def max_abs_multiplier(self) -> float:
        return float(np.abs(self.multipliers).max())

    def state(self, theta) -> np.ndarray:
        """The generator's state (k, 2n) at the crank angles ``theta`` (k,), rad."""
        tau = self.sign * (np.atleast_1d(np.asarray(theta, dtype=float)) - self.start)
        return states_at(self.generator, self.forcing, self.x0, tau, self.steps, self.order)

    def at(self, theta) -> np.ndarray:
        """q (k, n) at the crank angles ``theta`` (k,), rad."""
        q = self.state(theta)[:, : self.x0.size // 2]
        return q if self.dof_scale is None else q / self.dof_scale[None, :]


def _state_spectrum(phi):
    """The level spectrum of the augmented monodromy [[Φ, x_p], [0, 1]] (:func:`periodic_shot`):
    (multipliers of Φ, the periodic state x₀ = (I − Φ)⁻¹x_p; NaN where I − Φ is singular)."""
    n = phi.shape[0] - 1
    mu = la.eigvals(phi[:n, :n])
    try:
        x0 = np.linalg.solve(np.eye(n) - phi[:n, :n], phi[:n, n])
    except np.linalg.LinAlgError:
        x0 = np.full(n, np.nan)
    return mu, x0


def _state_change(fine, coarse) -> tuple[float, float]:
    """(max |μ − μ_coarse|, the relative change of the periodic state: :func:`_relative`) of two levels."""
    return magnus.multiplier_change(fine, coarse)[0], _relative(fine[1] - coarse[1], fine[1])


def periodic_shot(generator, forcing, omega: float, *, tol: float, order: int = 6, min_steps: int = 16,
                  max_steps: int = 2**16, **placement) -> PeriodicShot:
    """The periodic response of x' = A(τ)x + b(τ) (period 2π; ``generator``, ``forcing`` as
    :func:`fkev_slepc.periodic.magnus.monodromy` takes them; ``omega`` the crank speed, rad/s, named
    by a resonance) by shooting, the steps doubled from ``min_steps`` until the periodic state's
    step-doubling estimate is ≤ ``tol`` or ``max_steps`` is reached (the estimate is reported either
    way; module docstring). ``placement``: :class:`PeriodicShot`'s ``dof_scale``, ``sign``, ``start``
    (how the state and τ map to q and the crank angle; default q, θ = τ).

    Raises
    ------
    ResonanceError
        (I − Φ) singular to working precision (a multiplier at 1): the response is not filled.
    """
    def generic(tau):
        return magnus._augmented(generator, forcing, tau)[0]

    augmented = hamiltonian.forced(generator, forcing) or generic  # structured steps where A is Hamiltonian
    mono = magnus.monodromy(augmented, 2.0 * np.pi, order=order, mu_tol=np.inf, second_tol=tol, min_steps=min_steps,
                            max_steps=max_steps, measure=(_state_spectrum, _state_change))
    n = mono.phi.shape[0] - 1
    x0, _, rcond = _periodic_state(mono.phi[:n, :n], mono.phi[:n, n], mono.multipliers, omega)
    return PeriodicShot(x0, mono.multipliers, float(mono.second_error), float(mono.error), rcond, mono.steps,
                        generator, forcing, order, **placement)
