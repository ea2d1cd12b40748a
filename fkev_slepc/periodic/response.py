"""The steady periodic elastic response of a linkage at constant crank speed (docs/response.md §3).

    M(θ) q̈ + C(θ) q̇ + K(θ) q = f(θ),       θ = Ωt,

with the exact periodic coefficients of :mod:`fkev_slepc.model.periodic` (M, C = ΩC₁ + C_d,
K = K₀ + Ω²K₂ for the case's terms) and the rigid-body inertia loads of
:mod:`fkev_slepc.model.loads` (f = Ω² f₂(θ) plus gravity), both of one
:class:`~fkev_slepc.periodic.system.PeriodicSystem` (the system Floquet takes), solved by harmonic balance
(:mod:`~fkev_slepc.periodic.harmonic_balance`) and by shooting on the monodromy
(:mod:`~fkev_slepc.periodic.shooting`): the two are independent (a global collocation
and a Magnus time-stepper) and the result carries their difference. On large meshes both run on the
link-frame component basis q = W(θ)z (fkev_slepc/periodic/component_response.py, docs/response.md §3.1),
the truncation measured by doubling the modes per link and carried with the result.

**Which method gives the response.** Harmonic balance, H doubled to ``tol``; on the full model
with ``fallback`` (the default), where its estimates say it will not converge
(:func:`~fkev_slepc.periodic.harmonic_balance.will_not_converge`) the doubling is abandoned and the
response is the shooting solution (:func:`~fkev_slepc.periodic.shooting.periodic_shot`, its own
step-doubling error ≤ ``tol``): ``method`` says which, ``error`` is that method's estimate. An exact
resonance ((I − Φ) singular) raises: the response is never filled from the abandoned balance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.periodic.floquet import START_H_RHO
from fkev_slepc.periodic.interpolant import TrigInterpolant
from fkev_slepc.periodic.system import CONSTANT_ANGLES, CONSTANT_TOL, PeriodicSystem, spread
from fkev_slepc.periodic.harmonic_balance import HarmonicResponse, harmonic_balance, harmonics_of
from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.periodic.verdict import DECAYS, GROWS, NEUTRAL, verdict
from fkev_slepc.periodic.magnus import trajectory
from fkev_slepc.periodic.shooting import PeriodicShot, ShootingResponse, adapters, periodic_shot
from fkev_slepc.periodic.component_response import (
    RESPONSE_REDUCE_TOL, ProjectedSystem, ResponseTruncation, converged_response, response_reduction,
)


@dataclass(frozen=True)
class PeriodicResponse:
    """The periodic response of one (speed, case): q at the harmonic-balance angles, the
    shooting solution at the same angles, and the multipliers; where the balance was abandoned,
    the response by shooting (``periodic``), which :meth:`at` then evaluates."""

    omega: float
    case: str
    hb: HarmonicResponse  # or component_response.LiftedResponse (the same interface, q in the global DOFs)
    shoot: ShootingResponse | None
    truncation: ResponseTruncation | None = None  # on the link-component basis: measured by doubling
    periodic: PeriodicShot | None = None  # the response by shooting where the balance was abandoned

    @property
    def method(self) -> str:
        """``"harmonic balance"`` or ``"shooting"``: the method that gave the response."""
        return "harmonic balance" if self.periodic is None else "shooting"

    @property
    def error(self) -> float:
        """The estimated relative error of the response, by the method that gave it."""
        return self.hb.error if self.periodic is None else self.periodic.error

    def at(self, theta) -> np.ndarray:
        """q (k, n) at any crank angles ``theta`` (k,), rad, from the method that gave the response."""
        return (self.hb if self.periodic is None else self.periodic).at(theta)

    @property
    def theta(self) -> np.ndarray:
        return self.hb.theta

    @property
    def q(self) -> np.ndarray:
        return self.hb.q

    @property
    def methods_difference(self) -> float:
        """max |q_HB − q_shooting| / max |q| over the angles (NaN without shooting)."""
        if self.shoot is None:
            return float("nan")
        return float(np.abs(self.hb.q - self.shoot.q).max() / max(np.abs(self.hb.q).max(), 1e-300))

    @property
    def max_abs_multiplier(self) -> float:
        return float("nan") if self.shoot is None else self.shoot.max_abs_multiplier


DOES_NOT_ATTRACT = "does not attract"


def response_verdict(max_abs: float, error: float, attract_tol: float = DEFAULTS.attract_tol) -> str | None:
    """Does the periodic response attract, by the one verdict rule of the periodic analyses
    (fkev_slepc/periodic/verdict.py) with the tolerance ``PeriodicSettings.attract_tol``:
    ``"does not attract"`` where max|μ| − 1 > t (the response exists, the machine does not settle on
    it), ``"neutral"`` where |max|μ| − 1| <= t (undamped), else ``"attracts"``; t = attract_tol +
    SAFETY·``error``, as in the Floquet verdict. None without multipliers (``max_abs`` NaN: no
    shooting) or without their error."""
    v = verdict(max_abs, error, attract_tol)
    return None if v is None else {GROWS: DOES_NOT_ATTRACT, NEUTRAL: "neutral", DECAYS: "attracts"}[v]


def periodic_response(system, omega: float, case: str = "", *, harmonics: int | None = None, tol: float = 1e-10,
                      shoot: bool = False, shooting_tol: float = DEFAULTS.shooting_tol, reduce=None,
                      reduce_tol: float = RESPONSE_REDUCE_TOL, settings=DEFAULTS,
                      fallback: bool = True) -> PeriodicResponse:
    """Harmonic balance (and, with ``shoot``, shooting at the same angles) of ``system``
    (an object with ``mck(theta)`` -> (M, C, K) and ``load(theta)``, e.g. a
    :class:`~fkev_slepc.periodic.system.PeriodicSystem`). Where the system and its load are
    constant in the link frame (:func:`static_response`) the harmonic balance is that one static
    solve, whatever ``harmonics``. ``reduce`` (a PeriodicSystem only; one meaning,
    :func:`~fkev_slepc.periodic.settings.resolve_reduce`): "none" the full model,
    "links"/"links:N" the link-frame component basis (modes per link doubled to ``reduce_tol``, or
    N measured against 2N, on the one ladder: fkev_slepc/periodic/component_response.py),
    None (not given) or "default" the full model up to ``full_max_dofs`` free DOFs, else "links";
    with ``shoot`` the cross-check shoots on the system's own generator (:func:`shooting_at`); ``link_modes`` and
    ``full_max_dofs`` are those of ``settings`` (:class:`~fkev_slepc.periodic.settings.PeriodicSettings`).
    ``fallback``: on the full model with H doubled, the response by shooting (to ``tol``) where the
    balance will not converge (module docstring).

    Raises ``periodic.shooting.ResonanceError`` where (I − Φ) is singular to working precision."""
    hb = static_response(system)
    mode = (None if hb is not None or not hasattr(system, "model")
            else response_reduction(system.model, reduce, settings.full_max_dofs))
    trunc, target = None, system
    if mode is not None:
        modes = None if mode == "links" else int(mode[6:])
        hb, trunc = converged_response(system, omega, modes=modes, harmonics=harmonics, tol=tol, reduce_tol=reduce_tol,
                                       link_modes=settings.link_modes)
        target = hb.system
    check = None
    if shoot:  # before the full collocation: it refuses an exact resonance before a singular solve
        check = _shot(target.reduced if isinstance(target, ProjectedSystem) else target, omega, shooting_tol, settings)
    shot = None
    if hb is None:
        hb = harmonic_balance(system.mck, system.load, omega, harmonics=harmonics, tol=tol, abandon=fallback)
        if hb.abandoned:
            shot = _shot(system, omega, tol, settings)
    sh = None if check is None else shooting_at(check, hb.theta, target)
    return PeriodicResponse(float(omega), case, hb, sh, trunc, shot)


def static_response(system) -> HarmonicResponse | None:
    """The periodic response of a system whose coefficients and load are constant in the link frame
    (a lone rotating link without gravity: ``system.link_frame()``), else None: in link-frame
    coordinates q = W(θ)q̂ the response is the constant q̂ of one static solve K̂ q̂ = Wᵀf (harmonic
    balance at zero harmonics); in the global DOFs it has the harmonics 0 and 1 of W(θ) exactly.
    ``error``: the larger spread of the link-frame generator and load over the angles tested."""
    frame = system.link_frame() if hasattr(system, "link_frame") else None
    if frame is None:
        return None
    th = frame.angle(2.0 * np.pi * np.arange(CONSTANT_ANGLES) / CONSTANT_ANGLES)
    f_hat = np.einsum("kij,ki->kj", frame.frame(th), system.load(th))
    if spread(f_hat) > CONSTANT_TOL:
        return None
    K = frame.coefficients(th[:1]).K[0]
    q_hat = np.linalg.solve(K, f_hat[0])
    theta = 2.0 * np.pi * np.arange(3) / 3
    q = frame.frame(theta) @ q_hat
    c = harmonics_of(q)
    dq = np.real(1j * np.exp(1j * theta)[:, None] * c[1][None, :])
    err = max(spread(frame.generator(frame.angle(th))), spread(f_hat))
    return HarmonicResponse(theta, q, dq, c, err, float(1.0 / np.linalg.cond(K, 1)))


def _shot(system, omega: float, tol: float, settings=DEFAULTS) -> PeriodicShot:
    """:func:`~fkev_slepc.periodic.shooting.periodic_shot` of ``system``: on a PeriodicSystem in its
    scaled state, the generator by the trigonometric interpolant Floquet takes
    (``PeriodicSystem.interpolant`` with the samples of ``settings``) and the load's forcing by one on the
    same samples, doubled until it too meets ``interp_tol`` at the midpoints (each Magnus node then
    costs a weighted sum, not an assembly); any other system in (q, q') from ``mck`` and ``load``."""
    if not isinstance(system, PeriodicSystem):
        return periodic_shot(*adapters(system.mck, system.load, omega), omega, tol=tol)
    interp = system.interpolant(settings.samples, settings.interp_tol, settings.max_samples)
    k = interp.samples
    B = system.forcing(2.0 * np.pi * np.arange(k) / k)
    while True:
        mid = system.forcing(2.0 * np.pi * (np.arange(k) + 0.5) / k)
        err = np.abs(TrigInterpolant(0.0, B)(2.0 * np.pi * (np.arange(k) + 0.5) / k) - mid).max()
        both = np.empty((2 * k,) + B.shape[1:])
        both[0::2], both[1::2] = B, mid
        if err <= settings.interp_tol * max(np.abs(B).max(), 1e-300) or k >= settings.max_samples:
            break
        B, k = both, 2 * k
    forcing = TrigInterpolant(0.0, B[:, :, None], drop=0.1 * settings.interp_tol)  # as the generator's
    rho = float(np.max(np.abs(np.linalg.eigvals(interp.generator.S[0]))))  # first level as Floquet's
    return periodic_shot(interp.generator, lambda tau: forcing(tau)[:, :, 0], omega, tol=tol,
                         min_steps=int(np.ceil(2.0 * np.pi * rho / START_H_RHO)), dof_scale=system.dof_scaling,
                         sign=float(np.sign(omega)), start=system.start)


def shooting_at(shot: PeriodicShot, theta, system) -> ShootingResponse:
    """The shooting cross-check at the crank angles ``theta`` (the balance's) from ``shot``, the
    periodic state shot on the system's own generator (:func:`_shot`: for a linkage its PeriodicSystem's,
    the one Floquet takes): q from the state, dq/dθ from x' = A x + b there, lifted to the global
    DOFs on a link-component basis (``system`` a ProjectedSystem), and the closure of one revolution
    integrated from x₀."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    x = shot.state(theta)
    tau = np.mod(shot.sign * (theta - shot.start), 2.0 * np.pi)
    dx = np.einsum("kij,kj->ki", shot.generator(tau), x) + shot.forcing(tau)
    n = x.shape[1] // 2
    d = 1.0 if shot.dof_scale is None else shot.dof_scale[None, :]
    q, dq = x[:, :n] / d, shot.sign * dx[:, :n] / d
    if isinstance(system, ProjectedSystem):  # z -> q = W z + Δq
        q, dq = system.lift(theta, q, dq)
    end = trajectory(shot.generator, shot.x0, np.array([0.0, 2.0 * np.pi]), forcing=shot.forcing, order=shot.order,
                     steps=shot.steps)[-1]
    closure = float(np.linalg.norm(end - shot.x0) / max(np.linalg.norm(shot.x0), 1e-300))
    return ShootingResponse(theta, q, dq, shot.multipliers, max(shot.error, shot.monodromy_error), shot.rcond,
                            shot.steps, closure)
