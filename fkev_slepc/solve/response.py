"""The steady periodic elastic response of a linkage at constant crank speed (docs/response.md §3).

    M(θ) q̈ + C(θ) q̇ + K(θ) q = f(θ),       θ = Ωt,

with the exact periodic coefficients of :mod:`fkev_slepc.model.periodic` (M, C = ΩC₁ + C_d,
K = K₀ + Ω²K₂ for the case's terms) and the rigid-body inertia loads of
:mod:`fkev_slepc.model.loads` (f = Ω² f₂(θ) plus gravity), solved by harmonic balance
(:mod:`~fkev_slepc.solve.response_hb`) and by shooting on the monodromy
(:mod:`~fkev_slepc.solve.response_shooting`): the two are independent (a global collocation
and a Magnus time-stepper) and the result carries their difference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.process_loads import process_load_vectors
from fkev_slepc.solve.response_hb import HarmonicResponse, harmonic_balance
from fkev_slepc.solve.response_shooting import ShootingResponse, shooting


class LinkageSystem:
    """Dense coefficient and load stacks of a Model's periodic system at crank speed ``omega``
    (rad/s) for ``case``, with gravity ``gravity`` ([gx, gy], m/s², ground frame): the generic
    interface of the response solvers."""

    def __init__(self, model, case: str, omega: float, gravity=(0.0, 0.0)):
        from fkev_slepc.model.periodic import periodic_pieces

        self.model, self.case, self.omega = model, case, float(omega)
        self.gravity = np.asarray(gravity, dtype=float).reshape(2)
        self._pieces = periodic_pieces
        pat = model.pattern
        self.rows = np.repeat(np.arange(pat.n), np.diff(pat.indptr))
        self.cols = np.asarray(pat.indices)
        self.n = pat.n

    def dense(self, data: np.ndarray) -> np.ndarray:
        out = np.zeros((data.shape[0], self.n, self.n))
        out[:, self.rows, self.cols] = data
        return out

    def coefficients(self, theta):
        pp = self._pieces(self.model, theta, self.case)
        return tuple(self.dense(x) for x in pp.coefficients(self.omega))

    def load(self, theta) -> np.ndarray:
        lp = self.model.load_pieces(theta)
        f = self.omega**2 * lp.per_w2
        gx, gy = self.gravity
        if gy:
            f = f - gy * lp.gravity  # lp.gravity: the load of 1 m/s² along -Y
        if gx:
            f = f - gx * x_gravity(self.model, theta)
        return f + process_load_vectors(self.model, theta)  # [[loads]], zeros without


def x_gravity(model, theta) -> np.ndarray:
    """Load vectors (n_θ, n_free) of gravity 1 m/s² along -X: the element part is the model's
    -Y gravity piece of frames turned by -90° (the uniform field (-1, 0) has the element
    components of (0, -1) at φ + 90°), the particles' part -m_P (-1, 0) in their node frames."""
    from dataclasses import replace

    from fkev_slepc.model.loads import element_loads

    mech = model.mechanism
    state = model.angle_state(theta, with_loads=False)
    turned = replace(state, phi=state.phi + 0.5 * np.pi)
    el = element_loads(mech, model.stacks, turned).element["gravity"]
    axis = mech.node_axis[mech.mass_nodes]
    m = mech.mass_value
    part = np.stack([m * axis[:, 0], -m * axis[:, 1], np.zeros_like(m)], axis=-1)  # m (1, 0)·(axis, normal)
    part = np.broadcast_to(part, (state.size,) + part.shape)
    pat = model.pattern
    return pat.scatter_vector(el) + pat.scatter_vector(np.ascontiguousarray(part), mech.mass_dofs)


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
    (an object with ``coefficients(theta)`` and ``load(theta)``, e.g. :class:`LinkageSystem`).

    Raises ``response_shooting.ResonanceError`` where (I − Φ) is singular to working precision."""
    sh = None
    if shoot:  # first: it refuses an exact resonance before the collocation solves a singular system
        sh = shooting(system.coefficients, system.load, omega, np.zeros(1), tol=shooting_tol)
    hb = harmonic_balance(system.coefficients, system.load, omega, harmonics=harmonics, tol=tol)
    if sh is not None:
        sh = _resample(sh, hb.theta, system, omega)
    return PeriodicResponse(float(omega), case, hb, sh)


def _resample(sh: ShootingResponse, theta, system, omega) -> ShootingResponse:
    """The shooting solution at other angles: integrated again from its periodic initial state."""
    from fkev_slepc.solve import floquet
    from fkev_slepc.solve.response_shooting import _Cached

    cache = _Cached(system.coefficients, system.load, omega)
    gen = floquet.second_order(lambda th: cache(th)[:3])
    forcing = floquet.second_order_forcing(lambda th: cache(th)[0], lambda th: cache(th)[3])
    x0 = np.concatenate([sh.q[0], sh.dq[0]])
    x = floquet.trajectory(gen, x0, theta, forcing=forcing, steps=sh.steps, period=2.0 * np.pi)
    n = sh.q.shape[1]
    return ShootingResponse(np.asarray(theta), x[:, :n], x[:, n:], sh.multipliers, sh.error, sh.rcond, sh.steps,
                            sh.closure)
