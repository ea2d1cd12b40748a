"""Shooting for the periodic response of M(θ)q̈ + C(θ)q̇ + K(θ)q = f(θ), θ = Ωt, on the
monodromy of fkev_slepc/periodic/magnus.py (docs/response.md §3).

In θ the state x = (q, q') obeys x' = A(θ)x + b(θ) with the coefficients (Ω²M, ΩC, K) and the
load f. One revolution from x(0) = 0 under the load gives the particular state x_p(2π); the
periodic response starts from x₀ with (I − Φ)x₀ = x_p, Φ the monodromy. The multipliers μ
(eigenvalues of Φ) come with it: some |μ| > 1 means the periodic response exists but does not
attract (the machine would not settle on it); a multiplier at 1 makes (I − Φ) singular (exact
resonance: no periodic response, or not a unique one), which is refused.

Same generic interface as :mod:`fkev_slepc.periodic.harmonic_balance`: ``coefficients(theta)`` -> dense
(M, C, K) stacks (k, n, n) in the time form, ``load(theta)`` -> (k, n).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from fkev_slepc.periodic import magnus
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


def shooting(coefficients, load, omega: float, thetas, *, steps: int | None = None, tol: float = DEFAULTS.shooting_tol,
             order: int = 6, max_steps: int = 2**14) -> ShootingResponse:
    """The periodic response at ``thetas`` (increasing, in [0, 2π]) by shooting on the monodromy.

    Raises
    ------
    ResonanceError
        (I − Φ) singular to working precision (a multiplier at 1), with the closest multiplier.
    """
    cache = _Cached(coefficients, load, omega)
    gen = magnus.second_order(lambda th: cache(th)[:3])
    forcing = magnus.second_order_forcing(lambda th: cache(th)[0], lambda th: cache(th)[3])
    with np.errstate(over="ignore", invalid="ignore"):  # the first, too coarse step sizes may overflow
        mono = magnus.monodromy(gen, 2.0 * np.pi, forcing=forcing, order=order, steps=steps, tol=tol,
                                 max_steps=max_steps)
    n2 = mono.phi.shape[0]
    I_phi = np.eye(n2) - mono.phi
    sv = la.svdvals(I_phi)
    rcond = float(sv[-1] / (1.0 + la.norm(mono.phi, 2)))
    mu = mono.multipliers
    if rcond < RESONANCE_TOL:
        near = mu[np.argmin(np.abs(mu - 1.0))]
        raise ResonanceError(f"exact resonance at Ω = {omega:g} rad/s: (I - Φ) is singular to working precision "
                             f"(σ_min / (1 + ‖Φ‖) = {rcond:.1e}; multiplier μ = {near.real:.12g}{near.imag:+.3g}j "
                             "at 1): the periodic response does not exist or is not unique")
    lu = la.lu_factor(I_phi)
    x0 = la.lu_solve(lu, mono.particular)
    thetas = np.asarray(thetas, dtype=float)
    path = np.r_[thetas, 2.0 * np.pi] if thetas[-1] < 2.0 * np.pi else thetas
    x = magnus.trajectory(gen, x0, path, forcing=forcing, order=order, steps=mono.steps, period=2.0 * np.pi)
    closure = float(np.linalg.norm(x[-1] - x0) / max(np.linalg.norm(x0), 1e-300))
    x = x[: thetas.size]
    n = n2 // 2
    err = max(mono.phi_error, mono.particular_error or 0.0)
    return ShootingResponse(thetas, x[:, :n], x[:, n:], mu, err, rcond, mono.steps, closure)
