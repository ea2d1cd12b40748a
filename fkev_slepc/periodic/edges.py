"""Band edges: the sign change of the verdict margin inside a bracket, by safeguarded interpolation.

A bracket (lo, hi) of two grid speeds whose margins (:func:`fkev_slepc.periodic.bands.margin`)
differ in sign holds a band edge; :func:`edge` locates it to ``rtol`` relative: the result is the
midpoint of a bracket of the margin's sign change narrower than 2·rtol·lo, as bisection gives,
in fewer monodromies.

**Why the margin itself is a poor function to interpolate.** On the stable side the margin is a
constant -(tol + SAFETY·error); on the unstable side max|μ| - 1 grows like the square root of the
distance into the band, so secant or inverse-quadratic steps on it crawl from the flat side
(Brent's method needed about twice bisection's evaluations).

**The indicator** (:func:`indicator`). At a band edge Ωc two Floquet exponents collide:
s₁,₂ = s₀ ± δ with δ² ≈ κ(Ω - Ωc) analytic through the edge (docs/theory.md §18; the
Mathieu tongues of tests/test_floquet_bands.py are the model case). For the colliding pair of
multipliers μᵢ, μⱼ the half log-ratio z = ln(μᵢ/μⱼ)/2 = δT is real on the unstable side (the pair
has left the circle at one angle: z = σ, max|μ| = e^(σ - a)) and imaginary on the stable side (the
pair on the circle, half its angular gap: z = iφ), so Re z² = σ² or -φ² is about linear in Ω
through the collision. Shifted by the verdict's threshold, h = Re z² - (a + ln(1 + tol +
SAFETY·error))² (a = -ln|μᵢμⱼ|/2: 0 undamped, the pair's mean decay damped) has its zero where
the margin has, and the margin's sign. The pair: on the unstable side the largest multiplier and
its partner at the same angle; on the stable side the two multipliers nearest in angle to where
the bracket's unstable end has its largest one (without that end: the two closest in ln μ). A
point whose indicator disagrees in sign with its margin is left out of the interpolation. Only a
2 x 2 system has one pair to choose: on a linkage of many modes the stable side's nearest pair is
not always the colliding one, and a margin can jump (slivers; and 582.7007 rad/s of the thesis mesh
was once called stable beside an unstable 582.7005 by a step count since fixed: docs/engine.md
"Step count"), so the indicator is an accelerator, never the bracket: the bracket is the margin's sign.

**The search** (:func:`edge`) is stateless: the speeds it asks next are a function of the points
known inside the bracket only (archived values, the ``rtol`` asked and the speeds per round), so an
interrupted refinement, replayed on its archived points, asks for the same speeds and ends with the
uninterrupted edges exactly; a resume with a smaller ``rtol`` starts from every point archived (any
point tightens the bracket). From the known points:

1. the **bracket** is the sign change of the margin nearest the grid bracket's unstable end (every
   point between them unstable, so the brackets nest; the edge is that of the band holding the
   unstable grid speed, as far as the points show; bisection's points have one sign change, so a
   refinement archived by bisection is read back as its own last bracket); a point inside it that
   did not converge makes the edge NaN;
2. the **estimate** x* is the zero of the inverse quadratic interpolation of h through the three
   known points nearest the bracket (its two ends first), its **error** ε the distance to the zero
   of the line through the two nearest (regula falsi: inside the bracket when both ends have an
   indicator, and x* itself when the quadratic one is not);
3. **bracket closing**: with one speed per round the next speed is x* moved by 2ε towards the
   bracket's farther end, so that it lands past the root and the far end comes in too; with two
   (fewer brackets left than ranks: :func:`refine_edges`) x* - 2ε and x* + 2ε (x* ± W/8 without
   ε), closing from both sides in one round;
4. the **safeguard**: the midpoint (with two per round the thirds) instead, when there is no
   estimate inside the bracket, when two known points crowd one side within the bracket's width W
   of it (CROWD; the estimates have been landing on one side: regula falsi's stagnation), or when
   W > W₀·2^(-(n-2)/2) after n points inside the grid bracket of width W₀ (slower than half of
   bisection's rate). A margin that jumps (an indicator of no use) still converges, in at most
   about twice bisection's evaluations.

Why it converges fast: h is linear to first order through the edge, so the interpolation's error
is of the order of the curvature times the product of the nodes' distances to the edge (superlinear,
as the secant), and ε, the change that the third node makes, measures it: x* ± 2ε then brackets
the edge, and each round shrinks the bracket to about 4ε.

Measured (``interpolate=False`` is bisection; tests/test_floquet_bands.py): the four edges of the
first two Mathieu tongues (ε = 0.2) on the grid 0.8:2.6:0.02 rad/s to rtol 1e-6 take 19 monodromies
in 6 rounds on one rank against bisection's 54 in 14 (28 in 4 rounds with two per bracket, eight
ranks); 23 against 58 on a 0.05 rad/s grid; 19 against 54 damped (ζ = 0.01). The Bahgat–Willmert
thesis mesh, speeds 300:700:10 rad/s: 103 edge-refinement speeds for 14 edges against 190, the
early steps (to a bracket as narrow as the region where h is linear) being bisection-like there
(docs/stability.md, "How the edges are refined").
"""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from fkev_slepc.periodic.bands import DEFAULT_TOL, EDGE_RTOL, SpeedPoint, margin
from fkev_slepc.periodic.verdict import allowance

CLOSE = 2.0  # the closing step, in estimated errors ε of the estimate
CROWD = 1.0  # two known points within this many bracket widths of one side: the estimates stagnate
LAG = 2  # the bracket may lag this many evaluations behind half of bisection's rate


class NeedSpeed(Exception):
    """Raised by :func:`edge` when the speeds it asks next are not among the speeds known."""

    def __init__(self, speeds: Sequence[float]):
        super().__init__(list(speeds))
        self.speeds = [float(w) for w in speeds]


def indicator(point: SpeedPoint, tol: float = DEFAULT_TOL, toward: complex | None = None) -> float:
    """h = Re z² - (a + ln(1 + tol + SAFETY·error))² of the colliding pair (module docstring), about
    linear in the speed through a band edge, with the margin's sign; NaN when the margin is NaN,
    there is no pair, or the sign disagrees with the margin's."""
    m = margin(point, tol)
    mu = point.multipliers
    if not np.isfinite(m) or mu.size < 2 or not np.all(np.abs(mu) > 0):
        return float("nan")
    if m > 0:  # the largest multiplier and its partner at the same angle
        turn = np.abs(np.angle(mu[1:] / mu[0]))
        i, j = 0, 1 + int(np.argmin(turn))
    elif toward is not None:  # the two nearest in angle to where the pair leaves the circle
        i, j = np.argsort(np.abs(np.angle(mu / toward)), kind="stable")[:2]
    else:  # the two closest in ln μ: half their gap is the φ about to close
        gap = np.abs(np.log(mu[:, None] / mu[None, :]))
        gap[np.tril_indices(mu.size)] = np.inf
        i, j = np.unravel_index(int(np.argmin(gap)), gap.shape)
    z = np.log(mu[i] / mu[j]) / 2.0
    a = -0.5 * (np.log(abs(mu[i])) + np.log(abs(mu[j])))
    h = float((z * z).real - (a + np.log1p(allowance(point.error, tol))) ** 2)
    return h if np.isfinite(h) and (h > 0) == (m > 0) else float("nan")


def _estimate(x: np.ndarray, h: np.ndarray, a: float, b: float) -> tuple[float, float]:
    """(x*, ε): the zero of the inverse interpolation through the (up to 3) nodes nearest [a, b],
    and its distance to the zero of the line through the two nearest; NaN where not defined."""
    far = np.maximum(a - x, x - b).clip(min=0.0)
    order = np.argsort(far, kind="stable")[:3]
    x, h = x[order], h[order]
    if x.size < 2 or h[0] == h[1]:
        return float("nan"), float("nan")
    line = x[0] - h[0] * (x[1] - x[0]) / (h[1] - h[0])
    if x.size < 3 or len(set(h)) < 3:
        return line, float("nan")
    weights = [np.prod([h[j] / (h[j] - h[i]) for j in range(3) if j != i]) for i in range(3)]
    quad = float(np.dot(weights, x))
    if not a < quad < b:
        return line, float("nan")
    return quad, abs(quad - line)


def edge(lo: SpeedPoint, hi: SpeedPoint, known: Mapping[float, SpeedPoint], tol: float = DEFAULT_TOL,
         rtol: float = EDGE_RTOL, per_round: int = 1, interpolate: bool = True) -> float:
    """The speed in [lo, hi] (lo.speed < hi.speed, margins of different sign) where the margin changes
    sign, to ``rtol`` relative (the midpoint of a bracket narrower than 2·rtol·lo.speed), from the
    points ``known`` by speed (those strictly between lo and hi are used); raises :class:`NeedSpeed`
    with the ``per_round`` speeds (1 or 2) to evaluate next when the bracket is wider. NaN if a point
    inside the bracket did not converge. ``interpolate=False``: plain bisection (k-section), the
    reference of the tests. Module docstring: the method and why it converges."""
    inside = sorted(w for w in known if lo.speed < w < hi.speed)
    pts = [lo] + [known[w] for w in inside] + [hi]
    m = np.array([margin(p, tol) for p in pts])
    finite = np.isfinite(m)
    if m[0] > 0:  # the sign change nearest the unstable end: lo's, or hi's
        ib = int(np.flatnonzero(finite & (m <= 0))[0])
        ia = int(np.flatnonzero(finite[:ib])[-1])
    else:
        ia = int(np.flatnonzero(finite & (m <= 0))[-1])
        ib = ia + 1 + int(np.flatnonzero(finite[ia + 1:])[0])
    if ib - ia > 1:  # a point between the bracket's ends did not converge
        return float("nan")
    a, b = pts[ia].speed, pts[ib].speed
    width = b - a
    if width <= 2.0 * rtol * abs(lo.speed) or np.nextafter(a, b) >= b:
        return 0.5 * (a + b)
    n = int(np.sum(np.isfinite(m[1:-1])))
    speeds = np.array([p.speed for p in pts])
    crowd = max(np.sum((speeds >= a - CROWD * width) & (speeds < a)),
                np.sum((speeds > b) & (speeds <= b + CROWD * width)))
    x_star, eps = float("nan"), float("nan")
    if interpolate and crowd < 2 and width <= (hi.speed - lo.speed) * 2.0 ** (-max(n - LAG, 0) / 2.0):
        unstable = pts[ia] if m[ia] > 0 else pts[ib]
        toward = unstable.multipliers[0] / abs(unstable.multipliers[0])
        h = np.array([indicator(p, tol, toward) for p in pts])
        ok = np.isfinite(h)
        x_star, eps = _estimate(speeds[ok], h[ok], a, b)
    if not a < x_star < b:
        ws = a + width * np.arange(1, per_round + 1) / (per_round + 1)  # bisection (k-section)
    else:
        step = CLOSE * eps if np.isfinite(eps) else 0.0
        if per_round == 1:
            ws = [x_star + (step if b - x_star > x_star - a else -step)]
        else:
            step = step if step > 0 else width / 8.0
            ws = [x_star - step, x_star + step]
        ws = [w if a < w < b else 0.5 * (x_star + (b if w >= b else a)) for w in ws]
    ws = [w for w in dict.fromkeys(float(w) for w in ws) if a < w < b]
    raise NeedSpeed(ws)  # inside (a, b), so none is known


def refine_edges(points: Sequence[SpeedPoint], pairs: Sequence[tuple[int, int]],
                 evaluate_many: Callable[[list[float]], Sequence[SpeedPoint]], known: dict[float, SpeedPoint],
                 tol: float = DEFAULT_TOL, rtol: float = EDGE_RTOL, ranks: int = 1,
                 interpolate: bool = True) -> dict[tuple[int, int], float]:
    """The edge in every bracket ``pairs`` of ``points``, all brackets refined together in rounds:
    each round asks ``evaluate_many`` for the next speeds of every bracket not yet converged (one
    list, e.g. dealt to the MPI ranks and archived; two speeds per bracket when fewer brackets than
    ``ranks`` are left, one otherwise) and adds the points to ``known`` (updated in place; points
    already there, e.g. from an interrupted run, are not evaluated again)."""
    edges: dict[tuple[int, int], float] = {}
    todo = list(pairs)
    while todo:
        per_round = 2 if len(todo) < ranks else 1
        need: dict[tuple[int, int], list[float]] = {}
        for pair in todo:
            try:
                edges[pair] = edge(points[pair[0]], points[pair[1]], known, tol, rtol, per_round, interpolate)
            except NeedSpeed as n:
                need[pair] = n.speeds
        todo = list(need)
        if need:
            speeds = list(dict.fromkeys(w for ws in need.values() for w in ws))
            known.update(zip(speeds, evaluate_many(speeds)))
    return edges
