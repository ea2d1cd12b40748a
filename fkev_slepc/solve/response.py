"""The steady periodic elastic response of a linkage at constant crank speed (docs/response.md §3).

    M(θ) q̈ + C(θ) q̇ + K(θ) q = f(θ),       θ = Ωt,

with the exact periodic coefficients of :mod:`fkev_slepc.model.periodic` (M, C = ΩC₁ + C_d,
K = K₀ + Ω²K₂ for the case's terms) and the rigid-body inertia loads of
:mod:`fkev_slepc.model.loads` (f = Ω² f₂(θ) plus gravity), both of one
:class:`~fkev_slepc.solve.periodic_system.PeriodicSystem` (the system Floquet takes), solved by harmonic balance
(:mod:`~fkev_slepc.solve.response_hb`) and by shooting on the monodromy
(:mod:`~fkev_slepc.solve.response_shooting`): the two are independent (a global collocation
and a Magnus time-stepper) and the result carries their difference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.solve.response_hb import HarmonicResponse, harmonic_balance
from fkev_slepc.solve.response_shooting import ShootingResponse, shooting


@dataclass(frozen=True)
class PeriodicResponse:
    """The periodic response of one (speed, case): q at the harmonic-balance angles, the
    shooting solution at the same angles, and the multipliers."""

    omega: float
    case: str
    hb: HarmonicResponse
    shoot: ShootingResponse | None

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

    def attracting(self, tol: float = 1e-6) -> bool | None:
        """False where some |μ| > 1 + tol: the periodic response exists but does not attract."""
        return None if self.shoot is None else bool(self.max_abs_multiplier <= 1.0 + tol)


def periodic_response(system, omega: float, case: str = "", *, harmonics: int | None = None, tol: float = 1e-10,
                      shoot: bool = True, shooting_tol: float = 1e-11) -> PeriodicResponse:
    """Harmonic balance (and, with ``shoot``, shooting at the same angles) of ``system``
    (an object with ``mck(theta)`` -> (M, C, K) and ``load(theta)``, e.g. a
    :class:`~fkev_slepc.solve.periodic_system.PeriodicSystem`).

    Raises ``response_shooting.ResonanceError`` where (I − Φ) is singular to working precision."""
    sh = None
    if shoot:  # first: it refuses an exact resonance before the collocation solves a singular system
        sh = shooting(system.mck, system.load, omega, np.zeros(1), tol=shooting_tol)
    hb = harmonic_balance(system.mck, system.load, omega, harmonics=harmonics, tol=tol)
    if sh is not None:
        sh = _resample(sh, hb.theta, system, omega)
    return PeriodicResponse(float(omega), case, hb, sh)


def _resample(sh: ShootingResponse, theta, system, omega) -> ShootingResponse:
    """The shooting solution at other angles: integrated again from its periodic initial state."""
    from fkev_slepc.solve import floquet
    from fkev_slepc.solve.response_shooting import _Cached

    cache = _Cached(system.mck, system.load, omega)
    gen = floquet.second_order(lambda th: cache(th)[:3])
    forcing = floquet.second_order_forcing(lambda th: cache(th)[0], lambda th: cache(th)[3])
    x0 = np.concatenate([sh.q[0], sh.dq[0]])
    x = floquet.trajectory(gen, x0, theta, forcing=forcing, steps=sh.steps, period=2.0 * np.pi)
    n = sh.q.shape[1]
    return ShootingResponse(np.asarray(theta), x[:, :n], x[:, n:], sh.multipliers, sh.error, sh.rcond, sh.steps,
                            sh.closure)
