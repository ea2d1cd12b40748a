"""Unstable speed bands and their labels (fkev_slepc/periodic/bands.py) on the Mathieu oscillator
ẍ + ω₀²(1 - 2ε cos Ωt) x = 0, whose bands are known exactly: in the crank angle θ = Ωt it is
x'' + (ω₀/Ω)²(1 - 2ε cos θ) x = 0, i.e. Mathieu's y'' + (a - 2q cos 2τ) y = 0 with τ = θ/2,
a = 4ω₀²/Ω², q = εa; the n-th instability tongue lies between b_n(q) and a_n(q)
(scipy.special.mathieu_b/mathieu_a), around Ω = 2ω̄/n. The monodromies come from
fkev_slepc/periodic/magnus.py's routine."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

from fkev_slepc.periodic.magnus import monodromy
from fkev_slepc.periodic.bands import (
    DEFAULT_TOL, EDGE_RTOL, Band, SpeedPoint, bands_from, brackets, label, margin, nearest_resonance, resonance_speeds,
)
from fkev_slepc.periodic.edges import refine_edges


def find_bands(speeds, evaluate, tol=DEFAULT_TOL, rtol=EDGE_RTOL, points=None):
    """Scan (unless ``points`` are given: the grid already evaluated), bracket and refine, as
    fkev_slepc/sweep/floquet_run.py does over MPI ranks: (grid points sorted by speed, bands
    unlabelled, the extra points the refinement evaluated)."""
    pts = sorted(points if points is not None else [evaluate(float(w)) for w in speeds], key=lambda p: p.speed)
    known = {}
    edges = refine_edges(pts, brackets(pts, tol), lambda ws: [evaluate(w) for w in ws], known, tol, rtol)
    return pts, bands_from(pts, edges, tol), list(known.values())

OMEGA0, EPS = 1.0, 0.2


def mathieu_point(speed: float, eps: float = EPS, damping: float = 0.0) -> SpeedPoint:
    """Monodromy over one period of θ of x'' + 2ζ(ω₀/Ω) x' + (ω₀/Ω)²(1 - 2ε cos θ) x = 0."""
    r = (OMEGA0 / speed) ** 2

    def generator(theta):
        A = np.zeros((theta.size, 2, 2))
        A[:, 0, 1] = 1.0
        A[:, 1, 0] = -r * (1.0 - 2.0 * eps * np.cos(theta))
        A[:, 1, 1] = -2.0 * damping * OMEGA0 / speed
        return A

    return SpeedPoint.of(speed, monodromy(generator, 2.0 * np.pi, tol=1e-12))


def exact_edges(n: int, eps: float = EPS) -> tuple[float, float]:
    """(lower, upper) crank speed of the n-th tongue: a = mathieu_a(n, εa) and a = mathieu_b(n, εa)."""
    def speed(char):
        a = brentq(lambda a: a - char(n, eps * a), 0.5 * n * n, 2.0 * n * n + 1.0, xtol=1e-14)
        return 2.0 * OMEGA0 / np.sqrt(a)

    return tuple(sorted((speed(mathieu_a), speed(mathieu_b))))


def mean_frequency(eps: float = EPS) -> float:
    """Cycle mean of the frozen frequency ω₀√(1 - 2ε cos θ) (rad/s)."""
    theta = np.linspace(0.0, 2.0 * np.pi, 4096, endpoint=False)
    return float(OMEGA0 * np.mean(np.sqrt(1.0 - 2.0 * eps * np.cos(theta))))


def test_mathieu_bands_edges_to_1e6_and_labels():
    """The first two tongues on a grid of 0.02 rad/s: both found, edges within 1e-6 relative of
    the closed form, labelled 2ω̄1/1 and 2ω̄1/2; stable speeds between them have |μ| = 1."""
    speeds = np.arange(0.8, 2.6 + 1e-9, 0.02)
    pts, bands, extra = find_bands(speeds, mathieu_point)
    assert len(pts) == speeds.size and len(bands) == 2 and not any(b.lower_open or b.upper_open for b in bands)
    for band, n in zip(bands, (2, 1)):
        lo, hi = exact_edges(n)
        assert abs(band.lower / lo - 1) < 1e-6 and abs(band.upper / hi - 1) < 1e-6, (band, lo, hi)
        assert lo <= band.peak_speed <= hi and band.peak_max_abs > 1.0 + 1e-3
    stable = [p for p in pts if margin(p) <= 0]
    assert max(abs(p.max_abs - 1.0) for p in stable) < 1e-8
    labelled = label(bands, lambda w: [mean_frequency()])
    assert [b.resonance for b in labelled] == ["2ω̄1/2", "2ω̄1/1"]
    assert all(b.lower <= b.predicted_speed <= b.upper for b in labelled)


def test_damping_closes_the_narrow_tongue():
    """Damping ζ = 0.05 lifts the second tongue (width ~ q²) off the grid but not the first."""
    speeds = np.arange(0.8, 2.6 + 1e-9, 0.05)
    pts, bands, _ = find_bands(speeds, lambda w: mathieu_point(w, damping=0.05))
    assert len(bands) == 1 and bands[0].lower > 1.5
    assert all(p.max_abs < 1.0 for p in pts if not bands[0].lower <= p.speed <= bands[0].upper)


def test_open_band_and_unconverged_speed():
    """A band running past the grid's end is open there; a speed that did not converge brackets
    nothing (no edge is invented across it)."""
    pts = [SpeedPoint(w, np.array([m, 1 / m]), 1e-14) for w, m in ((1.0, 1.2), (1.1, 1.1), (1.2, 1.0), (1.3, 1.0))]
    assert brackets(pts) == [(1, 2)]
    broken = pts[:2] + [SpeedPoint(1.2, np.array([1.0, 1.0]), 1e-14, converged=False)] + pts[3:]
    assert brackets(broken) == []
    from fkev_slepc.periodic.bands import bands_from

    (band,) = bands_from(pts, {(1, 2): 1.15})
    assert band.lower_open and not band.upper_open and (band.lower, band.upper) == (1.0, 1.15)


def test_resonance_candidates_and_nearest():
    """2ω̄ₖ/n, (ω̄ⱼ ± ω̄ₖ)/n of ω̄ = (100, 250): the candidate inside a band wins, lowest order first."""
    cands = {r.label: r.speed for r in resonance_speeds([100.0, 250.0], max_order=2)}
    assert cands == pytest.approx({"2ω̄1/1": 200.0, "(ω̄1+ω̄2)/1": 350.0, "(ω̄2-ω̄1)/1": 150.0, "2ω̄2/1": 500.0,
                                   "2ω̄1/2": 100.0, "(ω̄1+ω̄2)/2": 175.0, "(ω̄2-ω̄1)/2": 75.0, "2ω̄2/2": 250.0})
    assert nearest_resonance(Band(340.0, 352.0), [100.0, 250.0]).label == "(ω̄1+ω̄2)/1"
    assert nearest_resonance(Band(248.0, 251.0), [100.0, 250.0]).label == "2ω̄2/2"
    assert nearest_resonance(Band(480.0, 490.0), [100.0, 250.0]).label == "2ω̄2/1"


def test_a_band_between_two_stable_grid_speeds_is_flagged_then_found_by_a_probe():
    """A 0.15 rad/s grid steps over the second tongue (0.967-1.007 rad/s: between 0.95 and 1.1,
    both stable): the scan sees one band, but the gap holding the resonance candidate 2ω̄1/2 is
    listed (its speed inside the exact tongue); one probe there finds the tongue, whose edges are
    then refined to 1e-6 of the closed form."""
    from fkev_slepc.periodic.bands import unsampled

    speeds = np.arange(0.8, 2.6 + 1e-9, 0.15)
    pts, bands, _ = find_bands(speeds, mathieu_point)
    assert len(bands) == 1 and bands[0].lower > 1.7
    gaps = unsampled(pts, lambda w: [mean_frequency()], max_order=3)
    assert [(g.resonance.label, g.between) for g in gaps] == [("2ω̄1/2", (pytest.approx(0.95), pytest.approx(1.1)))]
    lo, hi = exact_edges(2)
    assert lo < gaps[0].resonance.speed < hi
    probe = mathieu_point(gaps[0].resonance.speed)
    pts2, bands2, _ = find_bands(speeds, mathieu_point, points=pts + [probe])
    assert len(bands2) == 2
    assert abs(bands2[0].lower / lo - 1) < 1e-6 and abs(bands2[0].upper / hi - 1) < 1e-6, (bands2[0], lo, hi)
    assert unsampled(pts, lambda w: [mean_frequency()], max_order=1) == []  # order 2 is not asked


def test_unsampled_candidate_crosses_the_speed_where_it_equals_it():
    """ω̄(Ω) = 0.5 + 0.25 Ω: 2ω̄/1 = 1 + 0.5 Ω equals Ω at Ω = 2 (linear, so exactly), in the
    gap (1.5, 2.5) of two stable speeds; an unstable end or a failed speed makes no gap."""
    from fkev_slepc.periodic.bands import unsampled

    stable = [SpeedPoint(w, np.array([1.0, 1.0]), 1e-14) for w in (1.5, 2.5, 3.5)]
    (gap,) = unsampled(stable, lambda w: [0.5 + 0.25 * w], max_order=1)
    assert gap.resonance.label == "2ω̄1/1" and gap.resonance.speed == pytest.approx(2.0, rel=1e-14)
    assert gap.between == (1.5, 2.5)
    unstable = [stable[0], SpeedPoint(2.5, np.array([1.1, 1 / 1.1]), 1e-14), stable[2]]
    assert unsampled(unstable, lambda w: [0.5 + 0.25 * w], max_order=1) == []
    failed = [stable[0], SpeedPoint(2.5, np.zeros(0, complex), float("nan"), False), stable[2]]
    assert unsampled(failed, lambda w: [0.5 + 0.25 * w], max_order=1) == []


def test_suppressing_damping_closes_the_band_at_its_peak():
    """ζ* of the first tongue's label (2 Re s/(2ω̄), from the undamped peak) is the damping that closes
    the band there: with 0.9 ζ* the peak speed is still unstable, with 1.1 ζ* it is stable (the damped
    multipliers are e^(-ζω₀P) times the undamped ones up to O(ζ²), and ω̄ = 0.99 ω₀ at ε = 0.2)."""
    pts, bands, _ = find_bands(np.arange(1.90, 2.10 + 1e-9, 0.02), mathieu_point)
    (band,) = label(bands, lambda w: [mean_frequency()])
    assert band.resonance == "2ω̄1/1"
    rate = np.log(band.peak_max_abs) * band.peak_speed / (2 * np.pi)
    assert band.growth_rate == pytest.approx(rate, rel=1e-14) and rate > 0
    zeta = band.suppressing_damping
    assert zeta == pytest.approx(rate / mean_frequency(), rel=1e-12)
    assert zeta == pytest.approx(EPS / 2, rel=0.05)  # σ ≈ εω₀/2 at the tongue's centre (first order in ε)
    assert margin(mathieu_point(band.peak_speed, damping=0.9 * zeta)) > 0
    assert margin(mathieu_point(band.peak_speed, damping=1.1 * zeta)) < 0
    d = band.as_dict()
    assert d["growth_rate_1_s"] == pytest.approx(rate) and d["suppressing_damping_ratio"] == pytest.approx(zeta)


# ------------------------------------------------------------------ edge search (fkev_slepc/periodic/edges.py)
def _grid(speeds=np.arange(0.8, 2.6 + 1e-9, 0.02)):
    pts = sorted((mathieu_point(float(w)) for w in speeds), key=lambda p: p.speed)
    return pts, brackets(pts)


def test_edges_by_interpolation_agree_with_bisection_in_under_half_the_monodromies():
    """The four edges of the first two tongues (grid 0.02 rad/s) by the safeguarded interpolation
    and by bisection (``interpolate=False``): all within 1e-6 of the closed form, the two methods
    within rtol·speed of each other (the same sign change, narrower brackets), the interpolation in
    at most half of bisection's monodromies (19 against 54 measured); with two speeds per bracket per
    round (eight ranks: the ranks would idle) in fewer rounds still (4 against 6 and 14), with
    more monodromies than one per round but fewer than bisection (28)."""
    pts, pairs = _grid()
    exact = sorted(exact_edges(1) + exact_edges(2))
    runs = {}
    for name, kw in (("bisection", dict(interpolate=False)), ("one per round", {}), ("two per round", dict(ranks=8))):
        known, rounds = {}, []
        edges = refine_edges(pts, pairs, lambda ws: rounds.append(ws) or [mathieu_point(w) for w in ws], known, **kw)
        got = np.array([edges[p] for p in pairs])
        assert len(got) == 4 and np.all(np.abs(got / exact - 1) < 1e-6), (name, got, exact)
        runs[name] = (got, len(known), len(rounds))
    bisected, n_bisection, rounds_bisection = runs["bisection"]
    for name in ("one per round", "two per round"):
        got, n, _ = runs[name]
        assert (2 if name == "one per round" else 1) * n <= n_bisection, (name, n, n_bisection)
        assert np.all(np.abs(got - bisected) <= EDGE_RTOL * np.array([pts[i].speed for i, _ in pairs])), name
    assert runs["two per round"][2] < runs["one per round"][2] < rounds_bisection


def test_an_interrupted_edge_search_resumes_to_the_same_edges():
    """The search is a function of the points known: stopped after two rounds and run again on the
    points it had, it asks only speeds it had not and ends with the uninterrupted edges and points,
    bit for bit (to rtol 1e-6 and 1e-10); a finished search continued to a smaller rtol (a resume
    with a tighter --rtol) solves no speed twice and tightens every edge to the closed form."""

    class Stop(Exception):
        pass

    pts, pairs = _grid(np.arange(0.9, 1.1 + 1e-9, 0.02))
    for rtol in (1e-6, 1e-10):
        ref_known = {}
        ref = refine_edges(pts, pairs, lambda ws: [mathieu_point(w) for w in ws], ref_known, rtol=rtol)
        known, rounds = {}, []

        def stopping(ws):
            rounds.append(ws)
            if len(rounds) > 2:
                raise Stop
            return [mathieu_point(w) for w in ws]

        with pytest.raises(Stop):
            refine_edges(pts, pairs, stopping, known, rtol=rtol)
        kept, asked = set(known), []
        again = refine_edges(pts, pairs, lambda ws: asked.extend(ws) or [mathieu_point(w) for w in ws], known, rtol=rtol)
        assert again == ref and sorted(known) == sorted(ref_known) and asked and not set(asked) & kept
    finished, asked = dict(ref_known), []
    coarse = refine_edges(pts, pairs, lambda ws: [mathieu_point(w) for w in ws], {}, rtol=1e-6)
    finer = refine_edges(pts, pairs, lambda ws: asked.extend(ws) or [mathieu_point(w) for w in ws], finished,
                         rtol=1e-12)
    assert asked and not set(asked) & set(ref_known)
    for pair, exact in zip(pairs, exact_edges(2)):
        assert abs(finer[pair] / exact - 1) < 1e-11 and abs(finer[pair] - coarse[pair]) <= 1e-6 * pts[pair[0]].speed


def test_the_safeguard_converges_where_the_margin_jumps():
    """A margin that jumps at 1.2345678 rad/s (unstable above, max|μ| from 1.3, stable below with the
    pair 0.3 rad apart: an indicator whose zero is elsewhere): the edge is found to rtol, in at most
    twice bisection's monodromies plus two; a speed that did not converge, met inside the bracket,
    makes the edge NaN."""
    jump = 1.2345678

    def point(w, broken=(0.0, 0.0)):
        if broken[0] < w < broken[1]:
            return SpeedPoint(w, np.zeros(0, complex), float("nan"), False)
        r = 1.3 + 5.0 * (w - jump)
        mu = np.array([r, 1 / r]) if w > jump else np.exp([0.3j, -0.3j])
        return SpeedPoint(w, mu, 1e-14)

    ends = [point(1.2), point(1.3)]
    counts = {}
    for interpolate in (False, True):
        known = {}
        (found,) = refine_edges(ends, [(0, 1)], lambda ws: [point(w) for w in ws], known,
                                interpolate=interpolate).values()
        assert abs(found - jump) <= EDGE_RTOL * 1.2, (interpolate, found)
        counts[interpolate] = len(known)
    assert counts[True] <= 2 * counts[False] + 2, counts
    broken = lambda w: point(w, (jump - 0.01, jump + 0.01))  # noqa: E731
    (nan,) = refine_edges(ends, [(0, 1)], lambda ws: [broken(w) for w in ws], {}).values()
    assert np.isnan(nan)
