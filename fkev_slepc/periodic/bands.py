"""Unstable crank-speed bands from Floquet multipliers, and the resonance each band is.

A crank speed Ω is **unstable** over the cycle when its largest Floquet multiplier exceeds 1 by
more than the tolerance and the engine's own error estimate can explain:

    margin(Ω) = max|μ|(Ω) - 1 - (tol + SAFETY · error(Ω))  > 0.

Undamped and stable, max|μ| = 1 to round-off (the multipliers sit on the unit circle); at a band
edge two multipliers collide (at ±1 for a parametric resonance 2ω/n, elsewhere on the circle for
a combination resonance) and leave it, max|μ| - 1 growing like the square root of the distance
into the band. The margin is therefore a continuous function with a sign change at each edge:

1. the margin on a speed grid (the caller's evaluations, e.g. spread over MPI ranks:
   fkev_slepc/sweep/floquet_run.py);
2. :func:`brackets`: consecutive grid speeds whose margins differ in sign bracket an edge;
3. :func:`fkev_slepc.periodic.edges.edge`: the sign change of the margin inside a bracket, to
   ``rtol`` relative, by interpolation of an indicator linear through the edge, safeguarded by
   bisection (the edge is where max|μ| - 1 reaches tol + SAFETY·error, inside the band by about
   ((tol + SAFETY·error)/c)² for max|μ| - 1 ≈ c·√(relative distance): 1e-12 relative for
   tol = 1e-6, c = 1); :func:`fkev_slepc.periodic.edges.refine_edges` refines every bracket at
   once, in rounds, from the speeds already known (resumable);
4. :func:`bands_from`: runs of unstable grid speeds between refined edges; a band reaching the end
   of the grid is open there (``lower_open``/``upper_open``). A band is known unstable at its own
   grid speeds only: between two of them nothing is sampled, and stable speeds can lie there.

A band narrower than the grid spacing, between two stable grid speeds, is not seen: the
resonance candidates of low order that fall in such gaps (:func:`unsampled`) are where it would
be, and the places to add samples.

**Labels.** A band is labelled with the resonance whose predicted speed is nearest its centre,
from the cycle-mean frozen frequencies ω̄ₖ (rad/s) at the band's speed: parametric resonances
Ω = 2ω̄ₖ/n and combination resonances Ω = (ω̄ⱼ + ω̄ₖ)/n, Ω = (ω̄ⱼ - ω̄ₖ)/n (j > k), n = 1, 2, ...
The frequencies depend on the speed; the caller computes them at the band's centre
(:func:`label`). For a Mathieu oscillator ẍ + ω₀²(1 - 2ε cos Ωt)x = 0 the bands are the
instability tongues a = 4ω₀²/Ω² ≈ n², i.e. Ω ≈ 2ω̄/n (tests/test_floquet_bands.py checks their
edges against scipy.special.mathieu_a/b).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from fkev_slepc.periodic import verdict
from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.status import json_number

DEFAULT_TOL = DEFAULTS.verdict_tol  # max|μ| - 1 above which (and above SAFETY·error) a speed is unstable
EDGE_RTOL = DEFAULTS.edge_rtol  # band edges to this relative accuracy
MAX_ORDER = 8  # resonance orders n = 1..MAX_ORDER are candidate labels


@dataclass(frozen=True)
class SpeedPoint:
    """The Floquet verdict at one crank speed: multipliers sorted by decreasing |μ|."""

    speed: float  # rad/s
    multipliers: np.ndarray  # complex
    error: float  # the engine's estimate of the absolute multiplier error
    converged: bool = True

    @property
    def max_abs(self) -> float:
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else float("nan")

    @classmethod
    def of(cls, speed: float, result) -> SpeedPoint:
        """From anything with ``multipliers`` and ``error`` (a :class:`~fkev_slepc.periodic.magnus.Monodromy`,
        a linkage's Floquet result); ``converged`` from it or its ``monodromy`` when present."""
        mono = getattr(result, "monodromy", result)
        mu = np.asarray(result.multipliers, dtype=complex)
        mu = mu[np.argsort(-np.abs(mu), kind="stable")]
        return cls(float(speed), mu, float(result.error), bool(getattr(mono, "converged", True)))


def margin(point: SpeedPoint, tol: float = DEFAULT_TOL) -> float:
    """max|μ| - 1 - (tol + SAFETY·error): > 0 unstable, NaN if the monodromy did not converge (the one
    rule of fkev_slepc/periodic/verdict.py)."""
    return verdict.margin(point.max_abs, point.error, tol) if point.converged else float("nan")


@dataclass(frozen=True)
class Band:
    """An unstable speed band [lower, upper] (rad/s) and what it is."""

    lower: float
    upper: float
    lower_open: bool = False  # the band starts at (or below) the lowest speed examined
    upper_open: bool = False  # ... ends at (or above) the highest
    peak_speed: float = float("nan")  # the grid speed of largest max|μ| inside the band
    peak_max_abs: float = float("nan")
    resonance: str = ""  # e.g. "2ω̄1/1", "(ω̄1+ω̄2)/3"
    predicted_speed: float = float("nan")  # the labelled resonance's speed, rad/s
    mean_frequencies: tuple[float, ...] = field(default_factory=tuple)  # ω̄ₖ at the band centre, rad/s
    suppressing_damping: float = float("nan")  # ζ* of :func:`suppressing_damping` at the peak (NaN: not labelled)

    @property
    def centre(self) -> float:
        return 0.5 * (self.lower + self.upper)

    @property
    def growth_rate(self) -> float:
        """Re s = ln(max|μ|)·Ω/2π at the band's peak grid speed, 1/s: the amplitude grows like e^(Re s·t)."""
        return growth_rate(self.peak_max_abs, self.peak_speed)

    def as_dict(self) -> dict:
        """JSON: an edge that was not located is null: open (the band reaches the end of the
        speeds examined, ``lower_open``/``upper_open``, which end: ``unstable_down_to_rad_s`` /
        ``unstable_up_to_rad_s``) or not refined (a monodromy inside did not converge)."""
        num = json_number
        return {"lower_rad_s": None if self.lower_open else num(self.lower),
                "upper_rad_s": None if self.upper_open else num(self.upper), "resonance": self.resonance or None,
                "lower_open": self.lower_open, "upper_open": self.upper_open,
                "unstable_down_to_rad_s": num(self.lower) if self.lower_open else None,
                "unstable_up_to_rad_s": num(self.upper) if self.upper_open else None,
                "predicted_rad_s": num(self.predicted_speed), "peak_rad_s": num(self.peak_speed),
                "peak_max_abs_multiplier": num(self.peak_max_abs), "growth_rate_1_s": num(self.growth_rate),
                "suppressing_damping_ratio": num(self.suppressing_damping)}


def growth_rate(max_abs: float, speed: float) -> float:
    """The largest Floquet exponent's real part, 1/s, from max|μ| over one revolution at ``speed`` rad/s."""
    return float(np.log(max_abs) * abs(speed) / (2.0 * np.pi)) if max_abs > 0 and np.isfinite(speed) else float("nan")


def suppressing_damping(rate: float, modes: Sequence[int], mean_freq: Sequence[float]) -> float:
    """ζ*, the modal damping ratio that suppresses a band growing at ``rate`` (1/s) (docs/stability.md,
    "What damping a band needs"): light modal damping ζ on modes j, k shifts the Floquet exponents of
    their resonance by -ζ(ω̄ⱼ + ω̄ₖ)/2 (-ζω̄ₖ for a parametric one), to first order in ζ, so the band closes
    at its peak for ζ >= ζ* = 2 Re s/(ω̄ⱼ + ω̄ₖ). NaN when the modes are unknown."""
    w = [float(mean_freq[m - 1]) for m in modes if 0 < m <= len(mean_freq)]
    if not w or not np.isfinite(rate):
        return float("nan")
    w = w * 2 if len(w) == 1 else w
    return float(2.0 * rate / (w[0] + w[1]))


def survives_damping(band: Band, scene_damped: bool, zeta_floor: float) -> bool | None:
    """The one rule of which bands a real, damped machine keeps (docs/stability.md, "The damping a
    verdict answers for"): a damped scene's monodromies include its damping, so every band found
    survives it (True); an undamped scene's band survives the reporting floor ``zeta_floor`` where the
    damping that closes it, ζ* (:func:`suppressing_damping`), exceeds the floor; None where ζ* is not
    known (an unlabelled band: counted as surviving, never dropped)."""
    if scene_damped:
        return True
    zeta = band.suppressing_damping
    return None if not np.isfinite(zeta) else bool(zeta > zeta_floor)


def brackets(points: Sequence[SpeedPoint], tol: float = DEFAULT_TOL) -> list[tuple[int, int]]:
    """Index pairs (i, i+1) of neighbouring grid speeds (sorted) whose margins differ in sign;
    a speed that did not converge breaks the grid (no bracket across it)."""
    m = np.array([margin(p, tol) for p in points])
    ok = np.isfinite(m[:-1]) & np.isfinite(m[1:])
    hit = np.flatnonzero(ok & ((m[:-1] > 0) != (m[1:] > 0)))
    return [(int(i), int(i) + 1) for i in hit]


def bands_from(points: Sequence[SpeedPoint], edges: dict[tuple[int, int], float],
               tol: float = DEFAULT_TOL) -> list[Band]:
    """The bands of a scanned, sorted grid: runs of unstable speeds, closed by the refined edges
    of their brackets (``edges[(i, i+1)]``), open where they reach the grid's ends."""
    m = np.array([margin(p, tol) for p in points])
    bad = m > 0
    out = []
    i, n = 0, len(points)
    while i < n:
        if not bad[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and bad[j + 1]:
            j += 1
        lower = edges.get((i - 1, i), float("nan")) if i > 0 else points[0].speed
        upper = edges.get((j, j + 1), float("nan")) if j + 1 < n else points[-1].speed
        inside = points[i:j + 1]
        k = int(np.argmax([p.max_abs for p in inside]))
        out.append(Band(lower, upper, i == 0, j == n - 1, inside[k].speed, inside[k].max_abs))
        i = j + 1
    return out


# ------------------------------------------------------------------------------ labels
@dataclass(frozen=True)
class Resonance:
    """A candidate resonance: its label, speed (rad/s), kind, modes (1-based) and order n."""

    label: str
    speed: float
    kind: str  # "parametric" (2ω̄ₖ/n), "sum" ((ω̄ⱼ + ω̄ₖ)/n), "difference" ((ω̄ⱼ - ω̄ₖ)/n)
    modes: tuple[int, ...]
    order: int


def resonance_speeds(mean_freq: Sequence[float], max_order: int = MAX_ORDER) -> list[Resonance]:
    """Every 2ω̄ₖ/n and (ω̄ⱼ ± ω̄ₖ)/n (j > k, n = 1..max_order) of the mean frequencies (rad/s)."""
    w = np.asarray(mean_freq, dtype=float)
    out = []
    for n in range(1, max_order + 1):
        for k in range(w.size):
            out.append(Resonance(f"2ω̄{k + 1}/{n}", 2.0 * w[k] / n, "parametric", (k + 1,), n))
            for j in range(k + 1, w.size):
                out.append(Resonance(f"(ω̄{k + 1}+ω̄{j + 1})/{n}", (w[j] + w[k]) / n, "sum", (k + 1, j + 1), n))
                out.append(Resonance(f"(ω̄{j + 1}-ω̄{k + 1})/{n}", (w[j] - w[k]) / n, "difference", (j + 1, k + 1), n))
    return [r for r in out if np.isfinite(r.speed) and r.speed > 0]


def nearest_resonance(band: Band, mean_freq: Sequence[float], max_order: int = MAX_ORDER) -> Resonance | None:
    """The candidate whose speed is nearest the band (0 inside it), ties to the lowest order,
    then parametric before sum before difference."""
    cands = resonance_speeds(mean_freq, max_order)
    if not cands:
        return None
    rank = {"parametric": 0, "sum": 1, "difference": 2}

    def distance(r):
        d = 0.0 if band.lower <= r.speed <= band.upper else min(abs(r.speed - band.lower), abs(r.speed - band.upper))
        return (round(d / max(band.centre, 1e-300), 9), r.order, rank[r.kind])

    return min(cands, key=distance)


def label(bands: Sequence[Band], mean_frequencies: Callable[[float], Sequence[float]],
          max_order: int = MAX_ORDER) -> list[Band]:
    """Each band with the resonance nearest it, from ``mean_frequencies(speed)`` (the cycle-mean
    frozen frequencies ω̄ₖ, rad/s, at the band's centre speed)."""
    from dataclasses import replace

    out = []
    for b in bands:
        w = tuple(float(x) for x in mean_frequencies(b.centre))
        r = nearest_resonance(b, w, max_order)
        out.append(replace(b, resonance=r.label if r else "", predicted_speed=r.speed if r else float("nan"),
                           mean_frequencies=w,
                           suppressing_damping=suppressing_damping(b.growth_rate, r.modes, w) if r else float("nan")))
    return out


@dataclass(frozen=True)
class Gap:
    """A resonance candidate between two neighbouring stable speeds, where no speed was examined."""

    resonance: Resonance  # its speed: where the candidate 2ω̄ₖ(Ω)/n (...) equals Ω, interpolated
    between: tuple[float, float]  # the stable speeds either side, rad/s
    probe_status: str = ""  # the verdict of a monodromy solved at the candidate's speed ("": none)
    probe_max_abs: float = float("nan")

    def as_dict(self) -> dict:
        r = self.resonance
        return {"resonance": r.label, "predicted_rad_s": r.speed, "order": r.order, "kind": r.kind,
                "between_rad_s": [float(w) for w in self.between], "probe_status": self.probe_status or None,
                "probe_max_abs_multiplier": json_number(self.probe_max_abs)}


def unsampled(points: Sequence[SpeedPoint], mean_frequencies: Callable[[float], Sequence[float]],
              max_order: int, tol: float = DEFAULT_TOL) -> list[Gap]:
    """The resonance candidates of order n <= ``max_order`` that lie strictly between two
    neighbouring stable speeds of ``points``: the speed Ω where a candidate c(Ω) = 2ω̄ₖ(Ω)/n or
    (ω̄ⱼ(Ω) ± ω̄ₖ(Ω))/n (``mean_frequencies(Ω)``, rad/s) crosses Ω, linear between the two
    speeds. A band there, narrower than the spacing, would not have been seen."""
    pts = sorted(points, key=lambda p: p.speed)
    if len(pts) < 2 or max_order < 1:
        return []
    freq = [np.asarray(mean_frequencies(p.speed), dtype=float) for p in pts]
    n_modes = min(w.size for w in freq)
    fams = [resonance_speeds(w[:n_modes], max_order) for w in freq]
    keep = set.intersection(*(set(r.label for r in f) for f in fams))  # candidates defined at every speed
    fams = [[r for r in f if r.label in keep] for f in fams]
    if not fams[0]:
        return []
    s = np.array([p.speed for p in pts])
    g = np.array([[r.speed for r in f] for f in fams]) - s[:, None]  # (speed, candidate)
    m = np.array([margin(p, tol) for p in pts])
    stable = np.isfinite(m) & (m <= 0)
    out = []
    for i in np.flatnonzero(stable[:-1] & stable[1:]):
        for k in np.flatnonzero(g[i] * g[i + 1] < 0):
            w = s[i] - g[i, k] * (s[i + 1] - s[i]) / (g[i + 1, k] - g[i, k])
            r = fams[i][k]
            out.append(Gap(Resonance(r.label, float(w), r.kind, r.modes, r.order), (float(s[i]), float(s[i + 1]))))
    return sorted(out, key=lambda c: (c.resonance.speed, c.resonance.order))
