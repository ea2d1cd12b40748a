"""Critical crank speeds at a crank angle: divergence (buckling) onset and flutter onset.

At a fixed crank angle and crank acceleration (the scene's, held fixed while the speed varies)
the stiffness of every case is K(Ω) = K₀ + Ω² K₂ (:meth:`Model.stiffness_terms`): K₀ = K_s +
α(T₁ + P₁), K₂ = T₂ + N₂ + P₂ with the terms the case keeps (K₂ = 0 for ``structure``).

* **Divergence speed**: the lowest Ω with K(Ω) singular, i.e. the smallest real ν = Ω² > 0 of
  the generalized eigenproblem K₀ x = -ν K₂ x, solved as -K₂ x = η K₀ x with η = 1/ν (K₀ is
  invertible: K_s is positive definite). No bisection. Above it det K < 0 for a simple root,
  and solve/stability.py proves the point divergent.
* **Flutter speed**: where the smallest damping ratio ζ of the reported modes crosses zero on
  its way to instability. ``damping_tol`` (the threshold at which a point is classified
  ``unstable``) only decides whether there is a crossing: the first of a grid of speeds with
  min ζ < -``damping_tol``; the onset is then the root of min ζ = 0 between the last grid speed
  with min ζ > 0 and that one, refined by Brent's method to ``rtol`` relative. When min ζ is
  not positive at any grid speed below it (undamped Coriolis + tangential terms: ζ = 0 at rest,
  ± real parts as soon as Ω > 0) the onset is at rest, 0.

docs/stability.md explains what the two speeds mean.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la
import scipy.sparse.linalg as spla
from scipy.optimize import brentq

from fkev_slepc.model.plane import IN, Plane
from fkev_slepc.scene.cases import CASES
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.solve.stability import DENSE_LIMIT
from fkev_slepc.solve.thresholds import IMAG_TOL
from fkev_slepc.status import CONVERGED, json_number

FLUTTER_RTOL = 1e-8
SCAN_POINTS = 64  # speeds on which the flutter onset is bracketed
DEFAULT_MAX_FACTOR = 10.0  # no max speed, no divergence speed: flutter searched up to 10x the scene's top speed


@dataclass(frozen=True)
class CriticalSpeeds:
    """Critical speeds (rad/s; NaN when none at or below ``max_speed``) at one crank angle."""

    angle_deg: float
    divergence_speed: float
    flutter_speed: float
    max_speed: float  # upper end of the flutter search (inf: divergence unbounded, no flutter search)
    notes: tuple[str, ...] = field(default_factory=tuple)  # what limited the search, if anything
    scan_points: int = 0  # speeds of the flutter scan (spacing max_speed / scan_points); 0: not searched


def divergence_speed(model, pieces, case: str, accel: float | None = None, max_speed: float = np.inf,
                     imag_tol: float = IMAG_TOL) -> float:
    """Lowest Ω > 0 (rad/s) at which K(Ω) = K₀ + Ω² K₂ is singular; NaN if none <= ``max_speed``.

    Dense generalized eigenvalues up to :data:`~fkev_slepc.solve.stability.DENSE_LIMIT` free
    DOFs (every η); above it ARPACK's 24 largest-real η of K₀⁻¹(-K₂) (computed, not exhaustive).
    """
    if not CASES[case].motion:
        return float("nan")
    K0d, K2d, _ = model.stiffness_terms(pieces, case, accel)
    K0, K2 = model.pattern.matrix(K0d), model.pattern.matrix(K2d)
    if K2.count_nonzero() == 0:
        return float("nan")
    n = K0.shape[0]
    if n <= DENSE_LIMIT:
        eta = la.eig(-K2.toarray(), K0.toarray(), right=False)
    else:
        lu = spla.splu(K0.tocsc())
        op = spla.LinearOperator((n, n), matvec=lambda x: lu.solve(-(K2 @ x)), dtype=float)
        eta = spla.eigs(op, k=min(24, n - 2), which="LR", return_eigenvectors=False)
    eta = np.asarray(eta, dtype=complex)
    eta = eta[np.isfinite(eta)]
    real = eta.real[(np.abs(eta.imag) <= imag_tol * np.abs(eta)) & (eta.real > 0)]  # real η, as real λ
    if not real.size:
        return float("nan")
    speed = float(np.sqrt(1.0 / real.max()))
    return speed if speed <= max_speed else float("nan")


def min_damping_ratio(engine, model, pieces, case: str, omega: float, n_modes: int, accel=None) -> float:
    """Smallest damping ratio ζ of the ``n_modes`` reported modes at speed ``omega`` (NaN if
    the point did not converge); real eigenvalues by the engine's ``imag_tol``."""
    res = postprocess(engine.solve(model.qep(pieces, omega, case, accel), n_modes), n_modes)
    return res.min_damping_ratio if res.status in CONVERGED else float("nan")


def flutter_speed(engine, model, pieces, case: str, max_speed: float, n_modes: int, damping_tol: float,
                  accel=None, n_scan: int = SCAN_POINTS, rtol: float = FLUTTER_RTOL) -> tuple[float, list[str]]:
    """Lowest Ω in [0, ``max_speed``] where min ζ crosses 0 towards a point with min ζ <
    -``damping_tol``, and notes on what limited the search (none when nothing did).

    The speeds Ω_k = k·max_speed/n_scan are scanned upwards; the first k whose min ζ is below
    -damping_tol says there is a crossing; the root of min ζ = 0 is bracketed by the last scan
    speed with min ζ > 0 and refined by Brent's method to ``rtol`` (0 when there is none: min ζ
    never positive below the crossing). A dip and return between two scan speeds is not seen.
    """
    notes: list[str] = []
    if not CASES[case].motion or not np.isfinite(max_speed) or max_speed <= 0:
        return float("nan"), notes

    def zeta(w):
        return min_damping_ratio(engine, model, pieces, case, w, n_modes, accel)

    last_positive = None  # the last scan speed where every mode decays (min ζ > 0)
    for k in range(n_scan + 1):
        w = max_speed * k / n_scan
        z = zeta(w)
        if not np.isfinite(z):
            notes.append(f"not converged at {w:g} rad/s: flutter search stopped there")
            return float("nan"), notes
        if z < -damping_tol:
            if k == 0:
                notes.append("unstable already at rest")
                return 0.0, notes
            if last_positive is None:
                return 0.0, notes  # min ζ <= 0 from rest on: the onset is Ω = 0
            return _zeta_root(zeta, last_positive, w, rtol, notes), notes
        if z > 0:
            last_positive = w
    return float("nan"), notes


class _NotConverged(Exception):
    pass


def _zeta_root(zeta, lo: float, hi: float, rtol: float, notes: list[str]) -> float:
    """The root of min ζ = 0 in (lo, hi) (min ζ(lo) > 0 > min ζ(hi)) by Brent's method; NaN
    (and a note) if a point on the way does not converge."""
    def f(w):
        z = zeta(w)
        if not np.isfinite(z):
            raise _NotConverged(w)
        return z

    try:
        return float(brentq(f, lo, hi, xtol=1e-3 * rtol * hi, rtol=rtol))
    except _NotConverged as exc:
        notes.append(f"not converged at {exc.args[0]:g} rad/s while refining the flutter onset")
        return float("nan")


def critical_speeds(engine, model, angle_deg: float, case: str, n_modes: int, damping_tol: float,
                    max_speed: float | None = None, default_max: float = 0.0, accel=None,
                    n_scan: int = SCAN_POINTS) -> CriticalSpeeds:
    """Divergence and flutter speeds at one crank angle.

    ``max_speed`` bounds both; without it the divergence speed is unbounded and flutter is
    searched up to the divergence speed (beyond which the linkage buckles anyway) or, when
    there is none, up to ``default_max`` (no flutter search if that is 0).
    """
    pieces = model.pieces(np.radians(angle_deg))
    bound = np.inf if max_speed is None else float(max_speed)
    div = divergence_speed(model, pieces, case, accel, bound, engine.solve_settings.imag_tol)
    top = bound if max_speed is not None else (div if np.isfinite(div) else float(default_max))
    # out of plane K is symmetric and C absent or dissipative (docs/theory.md §19.6): no flutter
    symmetric = not Plane.parse(getattr(model, "plane", IN)).flutter
    notes, searched = [], CASES[case].motion and top > 0 and np.isfinite(top) and not symmetric
    if searched:
        flut, notes = flutter_speed(engine, model, pieces, case, top, n_modes, damping_tol, accel, n_scan)
    else:
        flut = float("nan")
        if CASES[case].motion and not symmetric:
            notes = ["flutter not searched: no divergence speed and no maximum speed given"]
    return CriticalSpeeds(float(angle_deg), div, flut, float(top), tuple(notes), n_scan if searched else 0)


@dataclass(frozen=True)
class CriticalScan:
    """Critical speeds of one case at each crank angle examined, and the lowest over them."""

    case: str
    damping_tol: float
    n_modes: int
    results: tuple[CriticalSpeeds, ...]

    def lowest(self, key: str) -> tuple[float, float]:
        """(speed, angle) of the lowest ``"divergence_speed"`` or ``"flutter_speed"`` (NaNs if none)."""
        vals = np.array([getattr(r, key) for r in self.results], dtype=float)
        if not np.any(np.isfinite(vals)):
            return float("nan"), float("nan")
        i = int(np.nanargmin(vals))
        return float(vals[i]), self.results[i].angle_deg

    def as_dict(self) -> dict:
        """JSON-ready (None for none), the keys of ``fkev critical --json``."""
        (div, a_div), (flut, a_flut) = self.lowest("divergence_speed"), self.lowest("flutter_speed")
        finite = [(v, a) for v, a in ((div, a_div), (flut, a_flut)) if np.isfinite(v)]
        first = min(finite)[1] if finite else (self.results[0].angle_deg if len(self.results) == 1 else None)
        return {
            "case": self.case, "modes": self.n_modes, "damping_tol": self.damping_tol, "angle_deg": json_number(first),
            "divergence_speed_rad_s": json_number(div), "divergence_angle_deg": json_number(a_div),
            "flutter_speed_rad_s": json_number(flut), "flutter_angle_deg": json_number(a_flut),
            "per_angle": [{"angle_deg": r.angle_deg, "divergence_speed_rad_s": json_number(r.divergence_speed),
                           "flutter_speed_rad_s": json_number(r.flutter_speed), "flutter_search_max_rad_s": json_number(r.max_speed),
                           "flutter_scan_points": r.scan_points, "notes": list(r.notes)} for r in self.results],
            "flutter_rtol": FLUTTER_RTOL,
        }  # fmt: skip


def scan(engine, model, angles_deg, case: str, n_modes: int, damping_tol: float, max_speed: float | None = None,
         default_max: float = 0.0, accel=None, n_scan: int = SCAN_POINTS) -> CriticalScan:
    """:func:`critical_speeds` at each of ``angles_deg`` (deg); the lowest is :meth:`CriticalScan.lowest`."""
    res = tuple(critical_speeds(engine, model, float(a), case, n_modes, damping_tol, max_speed, default_max, accel,
                                n_scan) for a in angles_deg)
    return CriticalScan(case, float(damping_tol), int(n_modes), res)
