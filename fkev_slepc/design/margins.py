"""Margins of the natural frequencies against the crank orders, over the whole cycle.

A linkage running at constant crank speed Ω is excited at the crank orders n·Ω/2π (n = 1, 2, …:
every periodic force of the mechanism -- inertia loads, driving torque -- repeats once per
revolution). Its natural frequencies are not constants but move with the crank angle θ: over
one revolution mode k sweeps the **band** [min_θ f_k, max_θ f_k]. An order inside the band is
crossed twice (or more) per revolution -- a resonance passage a single-angle Campbell diagram
does not show; an order outside it is at a **margin** from the band:

    margin % = 100 · (distance from n·Ω/2π to the band) / (the band edge it is closest to)

(how far the mode's frequency stays from the excitation, relative to the mode's own
frequency at its closest approach), with the crank angles where that closest approach happens.
Orders inside a band have margin 0 and their crossing angles (linear interpolation between grid
angles). Bands come from a sweep archive at one speed, over the converged points only.

Beside each mode's closest order, the table has one row per mode and chosen order (default 1×,
2×, 3×: ``per_order``) with the band and that order's margin. Modes are labelled ``tracked``
only where tracking held at that (speed, case) line; where it fell back to sorted order
(``/tracking/fallback``, fkev_slepc/sweep/tracking.py) the table says ``sorted``. The modes are
those of the archive's plane (``plane``: ``out`` for the out-of-plane problem of docs/theory.md
§19, whose tracking weighs the eigenvector entries by the mass, docs/tracking.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fkev_slepc.archive.reader import ArchiveError, SweepResults

NEAR_PERCENT = 10.0  # an order within this margin of a band is "near" it
PER_ORDER = (1, 2, 3)  # the orders of the per-order rows by default


@dataclass(frozen=True)
class Approach:
    """One order's relation to one band: margin (%; 0 inside) and the angles where it is closest."""

    order: int
    frequency_hz: float  # n·Ω/2π
    margin_percent: float
    angles_deg: tuple[float, ...]

    def as_dict(self) -> dict:
        return {"order": self.order, "frequency_hz": self.frequency_hz, "margin_percent": self.margin_percent,
                "angles_deg": list(self.angles_deg)}


@dataclass(frozen=True)
class ModeMargin:
    mode: int
    f_min_hz: float | None
    f_max_hz: float | None
    angle_min_deg: float | None
    angle_max_deg: float | None
    orders_inside: tuple[int, ...]
    orders_near: tuple[int, ...]  # outside, within NEAR_PERCENT
    closest: Approach | None  # the order with the smallest margin (the lowest n among orders inside)
    below: Approach | None  # the nearest order under the band
    above: Approach | None  # the nearest order over the band
    crossings: dict = field(default_factory=dict)  # order inside -> crossing angles (deg)
    angles_used: int = 0  # converged crank angles the band is taken over

    def as_dict(self) -> dict:
        c = self.closest
        return {"mode": self.mode, "f_min_hz": self.f_min_hz, "f_max_hz": self.f_max_hz,
                "angle_min_deg": self.angle_min_deg, "angle_max_deg": self.angle_max_deg,
                "orders_inside": list(self.orders_inside), "orders_near": list(self.orders_near),
                "closest_order": c.order if c else None, "margin_percent": c.margin_percent if c else None,
                "closest_angles_deg": list(c.angles_deg) if c else [],
                "below": self.below.as_dict() if self.below else None,
                "above": self.above.as_dict() if self.above else None,
                "crossing_angles_deg": {str(n): list(a) for n, a in self.crossings.items()},
                "angles_used": self.angles_used}


@dataclass(frozen=True)
class MarginTable:
    speed_rad_s: float
    case: str
    order: str  # "tracked" or "sorted"
    n_orders: int
    modes: tuple[ModeMargin, ...]
    n_angles: int
    per_order: tuple[tuple[ModeMargin, Approach], ...] = ()  # (mode, its approach to one chosen order)
    tracking_fell_back: bool = False  # tracked order asked, but tracking fell back to sorted at this line
    plane: str = "in"  # the archive's problem: "out" = bending out of the plane and torsion (docs/theory.md §19)

    def as_dict(self) -> dict:
        rows = [{"mode": m.mode, "f_min_hz": m.f_min_hz, "f_max_hz": m.f_max_hz, "inside": a.margin_percent == 0.0,
                 **a.as_dict()} for m, a in self.per_order]
        return {"speed_rad_s": self.speed_rad_s, "crank_order_hz": self.speed_rad_s / (2 * math.pi),
                "case": self.case, "plane": self.plane, "order": self.order,
                "tracking_fell_back": self.tracking_fell_back,
                "orders": self.n_orders, "near_percent": NEAR_PERCENT,
                "n_angles": self.n_angles, "modes": [m.as_dict() for m in self.modes], "per_order": rows}


def crossing_angles(angles: np.ndarray, f: np.ndarray, level: float) -> tuple[float, ...]:
    """Angles (deg) where the curve f(θ) passes ``level``: linear interpolation on each grid
    interval whose ends straddle it (both ends finite); a grid angle exactly on it counts once.

    Examples
    --------
    >>> crossing_angles(np.array([0., 10, 20, 30]), np.array([1., 3, 3, 0]), 2.0)
    (5.0, 23.333333333)
    """
    a, g = np.asarray(angles, float), np.asarray(f, float) - level
    lo, hi = g[:-1], g[1:]
    ok = np.isfinite(lo) & np.isfinite(hi) & (((lo < 0) & (hi >= 0)) | ((lo > 0) & (hi <= 0)))
    i = np.flatnonzero(ok)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(hi[i] == lo[i], 0.0, lo[i] / (lo[i] - hi[i]))
    out = a[i] + t * (a[i + 1] - a[i])
    if g.size and g[0] == 0:
        out = np.concatenate([[a[0]], out])
    return tuple(float(x) for x in np.unique(np.round(out, 9)))


def _approach(n: int, fn: float, angles, f, fmin, fmax) -> Approach:
    if fmin <= fn <= fmax:
        return Approach(n, fn, 0.0, crossing_angles(angles, f, fn))
    edge = fmin if fn < fmin else fmax
    at = angles[np.isfinite(f) & (f == edge)]
    return Approach(n, fn, 100.0 * abs(edge - fn) / edge, tuple(float(x) for x in at))


def margins(res: SweepResults, speed_rad_s: float, case: str | None = None, n_orders: int | None = None,
            order: str | None = None, modes=None, per_order=PER_ORDER) -> MarginTable:
    """The margin table of ``res`` at one archived crank speed (see the module docstring).

    Parameters
    ----------
    speed_rad_s : float
        An operating speed on the archive's speed grid (rad/s; > 0).
    case : str, optional
        Default ``full`` if archived, else the first case.
    n_orders : int, optional
        Orders n = 1..N considered; default one past the highest band's top.
    order : {"tracked", "sorted"}, optional
        Modes followed along θ (default when the archive has them) or the k-th lowest at each θ.
    modes : sequence of int, optional
        1-based modes (default all archived).
    per_order : sequence of int, optional
        The orders of the per-order rows (default 1, 2, 3).

    Raises
    ------
    ArchiveError
        A speed not on the grid (or not > 0), an unknown case or mode, a bad ``n_orders`` or ``per_order``.
    """
    from fkev_slepc.archive.tracks import read_tracking

    case = res.default_case if case is None else case
    ci, si = res.case_index(case), res.speed_index(speed_rad_s)
    speed = float(res.speed_rad_s[si])
    if not speed > 0:
        raise ArchiveError(f"--speed: the crank orders need a speed > 0 rad/s (got {speed:g})")
    per_order = tuple(per_order)
    if not per_order or any(isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1 for n in per_order):
        raise ArchiveError(f"--per-order: must be orders >= 1 (got {','.join(map(str, per_order)) or 'none'})")
    if order is None:
        order = "tracked" if np.isfinite(res.tracked_frequency_hz).any() else "sorted"
    fallback = read_tracking(res.path, res.table_plane)["fallback"] if order == "tracked" else None
    fell_back = bool(fallback is not None and fallback[si, ci])
    f_all = res.frequency(order=order)[:, si, ci, :]  # (angle, mode), NaN where not converged
    picked = [res.mode_index(m) for m in modes] if modes is not None else list(range(res.modes.size))
    angles = np.asarray(res.crank_angle_deg, float)
    base = speed / (2 * math.pi)
    top = np.nanmax(f_all[:, picked]) if np.isfinite(f_all[:, picked]).any() else base
    if n_orders is None:
        n_orders = max(1, int(math.floor(top / base)) + 1)
    elif n_orders < 1:
        raise ArchiveError(f"--orders: must be >= 1 (got {n_orders})")
    orders = np.arange(1, n_orders + 1)
    rows = [mode_margin(int(res.modes[k]), angles, f_all[:, k], orders, base) for k in picked]
    chosen = tuple((m, _approach(n, n * base, angles, f_all[:, k], m.f_min_hz, m.f_max_hz))
                   for m, k in zip(rows, picked) if m.f_min_hz is not None for n in per_order)
    return MarginTable(speed, res.cases[ci], "sorted" if fell_back else order, int(n_orders), tuple(rows),
                       angles.size, chosen, fell_back, res.plane)


def mode_margin(mode: int, angles: np.ndarray, f: np.ndarray, orders: np.ndarray, base: float) -> ModeMargin:
    """The :class:`ModeMargin` of one mode's curve ``f`` (Hz, NaN where not converged) over
    ``angles`` (deg) against the crank ``orders`` n at ``base`` = Ω/2π (module docstring); its
    ``closest`` is None for no orders."""
    ok = np.isfinite(f)
    if not ok.any():
        return ModeMargin(mode, None, None, None, None, (), (), None, None, None)
    fmin, fmax = float(np.nanmin(f)), float(np.nanmax(f))
    fn = orders * base
    approaches = [_approach(int(n), float(x), angles, f, fmin, fmax) for n, x in zip(orders, fn)]
    inside = tuple(a.order for a in approaches if a.margin_percent == 0.0)
    near = tuple(a.order for a in approaches if 0.0 < a.margin_percent <= NEAR_PERCENT)
    below = [a for a in approaches if a.frequency_hz < fmin]
    above = [a for a in approaches if a.frequency_hz > fmax]
    closest = min(approaches, key=lambda a: (a.margin_percent, a.order)) if approaches else None
    return ModeMargin(mode, fmin, fmax, float(angles[ok][np.argmin(f[ok])]), float(angles[ok][np.argmax(f[ok])]),
                      inside, near, closest, below[-1] if below else None, above[0] if above else None,
                      {a.order: a.angles_deg for a in approaches if a.margin_percent == 0.0}, int(ok.sum()))


def bands(res: SweepResults, case: str, order: str) -> tuple[np.ndarray, np.ndarray]:
    """(f_min, f_max) over crank angle, each (speed, mode), NaN where no angle converged."""
    f = res.frequency(order=order)[:, :, res.case_index(case), :]
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns stay NaN
            return np.nanmin(f, axis=0), np.nanmax(f, axis=0)
