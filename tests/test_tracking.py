"""Mode tracking (docs/tracking.md): MAC links, ambiguity, refinement, fall-back, closed loops.

Synthetic two-DOF systems with known eigenvectors test the ambiguity logic; the Bahgat-Willmert
sweep on a 10° grid tests the physics: the linkage at 360° is the linkage at 0°, so tracked mode
k must come back to the frequency it started from, and the tracked curves must be the
continuous ones (those of a grid four times finer).
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from fkev_slepc.cli import main
from fkev_slepc.status import Status
from fkev_slepc.sweep.tracking_angles import Samples, refine_angles, track_angles
from fkev_slepc.sweep.tracking import Criteria, chain_order, link_check, match_cases, track_speeds, tracking_dofs

SCENE = "runs/bahgat-willmert-1976.toml"
OK = Status.OK.code


def test_tracking_dofs():
    assert tracking_dofs(15, 1) is None
    assert np.array_equal(tracking_dofs(15, 1, 3), np.arange(15))  # one angle, several speeds: Campbell
    assert np.array_equal(tracking_dofs(15, 5), np.arange(15))
    big = tracking_dofs(1000, 5)
    assert len(big) == 64 and big[0] == 0 and big[-1] == 999 and set(np.diff(big)) <= {15, 16}


@pytest.mark.parametrize("angles, walk, closed", [
    (np.arange(0, 361, 30.0), np.arange(0, 361, 30.0), True),
    (np.arange(0, 331, 30.0), np.arange(0, 331, 30.0), True),
    ([0.0, 30.0, 300.0, 330.0], [300.0, 330.0, 0.0, 30.0], False),  # walk across 360 -> 0
    ([90.0, 0.0, 45.0], [0.0, 45.0, 90.0], False),
    ([10.0], [10.0], False),
])
def test_chain_order_wraps(angles, walk, closed):
    order, is_closed = chain_order(angles)
    assert np.array_equal(np.asarray(angles)[order], walk) and is_closed == closed


# ------------------------------------------------------------------ two DOFs, known answers
def two_dof(theta_deg, coupling, slope=1.0, k0=10.0, centre=180.0):
    """M = I, K = [[k0 + s, c], [c, k0 - s]] with s = slope·(θ - centre)/100: ω² = k0 ± √(s² + c²).

    The eigenvectors are known in closed form: the rotation by φ = ½·atan2(2c, 2s). With c = 0
    the two frequencies cross at θ = centre and each mode keeps its shape (e1 or e2); with
    c > 0 they veer: the shapes exchange over an angle range of about 100·c/slope degrees."""
    s = slope * (np.asarray(theta_deg, float) - centre) / 100.0
    r = np.hypot(s, coupling)
    w = np.sqrt(np.stack([k0 - r, k0 + r], axis=-1))  # sorted: lower, upper
    phi = 0.5 * np.arctan2(2 * coupling, 2 * s)
    upper = np.stack([np.cos(phi), np.sin(phi)], axis=-1)  # eigenvector of k0 + r
    lower = np.stack([-np.sin(phi), np.cos(phi)], axis=-1)
    if coupling == 0:  # a true crossing: e1 belongs to k0 + s wherever it is, e2 to k0 - s
        e1, e2 = np.array([1.0, 0.0]), np.array([0.0, 1.0])
        upper = np.where((s >= 0)[..., None], e1, e2)
        lower = np.where((s >= 0)[..., None], e2, e1)
    return w / (2 * np.pi), np.stack([lower, upper], axis=-1)


def samples(angles, coupling, **kw):
    f, v = two_dof(angles, coupling, **kw)
    n = len(angles)
    return Samples(np.asarray(angles, float), f[:, None, None, :], np.full((n, 1, 1), OK, np.uint8),
                   v[:, None, None].astype(complex), None)


def exact_solver(coupling, calls, **kw):
    def solve(angle, mask):
        calls.append(angle)
        s = samples([angle], coupling, **kw)
        s.status[0][~mask] = 0
        return s
    return solve


def test_a_crossing_is_confirmed_by_refinement_then_followed_by_shape():
    angles = np.arange(0.0, 301.0, 30.0)  # not a revolution: the synthetic K is not periodic
    f, _ = two_dof(angles, 0.0, centre=172.0)  # not on a grid angle: no exact degeneracy
    _, requests = track_angles(samples(angles, 0.0, centre=172.0))
    assert list(requests) == [165.0]  # the crossing link (150, 180] must be confirmed
    calls = []
    res = refine_angles(samples(angles, 0.0, centre=172.0), exact_solver(0.0, calls, centre=172.0), MPI.COMM_SELF)
    assert res.unresolved == 0 and res.crossings == 1 and not res.fallback.any()
    assert len(calls) == res.crit.max_halvings  # halved down to 30°/64, one angle per level
    k = 10.0 - (angles - 172.0) / 100.0  # ω² of the e2 mode, the upper one at 0°
    np.testing.assert_allclose(res.tracked[:, 0, 0, 1] ** 2 * (2 * np.pi) ** 2, k, rtol=1e-12)
    assert not np.allclose(res.tracked[..., 1], f[:, None, None, 1])  # sorted order switches at 180°


def test_refinement_stops_at_its_budget_and_says_so():
    """Issue 20: a 481-point sweep solved 693 extra points and still fell back to sorted order.
    Refinement solves at most Criteria.budget(grid points) extra points (the grid's count, at
    least 100), the earliest requests first, and records the budget and whether it ran out."""
    angles = np.arange(0.0, 301.0, 30.0)
    assert Criteria().budget(481) == 481 and Criteria().budget(20) == 100
    calls = []
    tight = Criteria(refine_budget=0.0, refine_budget_min=3)
    res = refine_angles(samples(angles, 0.0, centre=172.0), exact_solver(0.0, calls, centre=172.0), MPI.COMM_SELF, tight)
    assert len(calls) == 3 < Criteria().max_halvings  # the crossing needs 6 halvings: cut at 3
    assert res.refined_points == 3 and res.budget_exhausted and res.attrs()["refine_budget_points"] == 3
    calls.clear()
    res = refine_angles(samples(angles, 0.0, centre=172.0), exact_solver(0.0, calls, centre=172.0), MPI.COMM_SELF)
    assert len(calls) == 6 and not res.budget_exhausted and res.attrs()["refine_budget_exhausted"] == 0


def test_veering_ambiguity_criterion():
    """Across a veering the MAC of a continuation is cos²(Δφ), Δφ the turn of the shapes."""
    c = 0.02  # shapes exchange within about ±2° of 180°
    v = {x: two_dof(np.array([x]), c)[1].astype(complex)
         for x in (170.0, 171.0, 179.25, 180.75, 178.75, 181.25, 175.0, 185.0)}

    def turn(a, b):  # Δφ = 90° - atan(2c/|2s|) for a link symmetric about the centre (s = ±(b - a)/200)
        return np.pi / 2 - np.arctan(2 * c / ((b - a) / 100.0))

    assert not link_check(v[170.0], v[171.0])[1][0]  # Δφ ≈ 0.3°: clear
    # Both sides of MAC_MIN = 0.8, each far from it (not at cos²(26.57°) = 0.8000 itself, where
    # the last bits of the shapes decided), the margin 2·MAC - 1 above MAC_MARGIN = 0.3 on both,
    # so the MAC threshold alone decides:
    for (a, b), mac_expected, ambiguous in (((179.25, 180.75), 0.8767, False),  # Δφ 20.6°: 0.08 above
                                            ((178.75, 181.25), 0.7191, True)):  # Δφ 32.0°: 0.08 below
        got = np.abs(v[a][0].conj().T @ v[b][0]) ** 2  # unit vectors: MAC = |x·y|²
        assert got[0, 0] == pytest.approx(np.cos(turn(a, b)) ** 2, abs=1e-12) == pytest.approx(mac_expected, abs=1e-4)
        assert 2 * got[0, 0] - 1 > 0.3 + 0.1
        assert link_check(v[a], v[b])[1][0] == ambiguous
    perm, amb = link_check(v[175.0], v[185.0])  # Δφ ≈ 68°: looks like a clean crossing...
    assert not amb[0] and perm[0].tolist() == [1, 0]
    _, requests = track_angles(samples([150.0, 175.0, 185.0, 210.0], c))
    assert 180.0 in requests  # ... so the order change asks for confirmation


def test_refinement_resolves_a_veering_and_follows_the_continuous_branch():
    """The veering: the continuous branches never cross, so the lower mode stays the lower
    one; a 30° grid jumps over it (shape exchange looks like a crossing), refinement does not."""
    c = 0.02
    angles = np.arange(0.0, 301.0, 30.0)  # not a revolution: the synthetic K is not periodic
    coarse, _ = track_angles(samples(angles, c, centre=172.0), crit=Criteria(max_halvings=0))
    f, _ = two_dof(angles, c, centre=172.0)
    assert coarse.crossings == 1 and coarse.unresolved == 0  # unrefined: a false crossing
    calls = []
    res = refine_angles(samples(angles, c, centre=172.0), exact_solver(c, calls, centre=172.0), MPI.COMM_SELF)
    assert res.ambiguous_main >= 1 and res.unresolved == 0 and res.crossings == 0 and not res.fallback.any()
    assert calls and all(150.0 < x < 210.0 for x in calls)  # only around the veering
    np.testing.assert_allclose(res.tracked[:, 0, 0], f, rtol=1e-12)  # the branch, not the shape
    assert res.open_loops == 0


def test_ambiguity_left_after_refinement_falls_back_to_sorted_order():
    c = 0.02
    angles = np.arange(0.0, 301.0, 30.0)  # not a revolution: the synthetic K is not periodic
    f, _ = two_dof(angles, c)  # at 180° the shapes are half-way (45°) through the veering
    res, _ = track_angles(samples(angles, c), crit=Criteria(max_halvings=0))  # no refinement allowed
    assert res.unresolved == 2 and res.fallback.all()
    np.testing.assert_array_equal(res.tracked[:, 0, 0], f)


def test_open_loop_falls_back_to_sorted_order():
    """Shapes that turn by 90° over a revolution while the frequencies cross: the modes come
    back permuted. Every link is clear, but the line must not be shown as tracked."""
    n = 13
    angles = np.linspace(0, 360, n)
    t = angles / 360.0
    fa, fb = 100.0 + 50.0 * t, 140.0 - 30.0 * t
    phi = 0.5 * np.pi * t
    a = np.stack([np.cos(phi), np.sin(phi)], axis=1)
    b = np.stack([-np.sin(phi), np.cos(phi)], axis=1)
    lo = fa < fb
    freq = np.stack([np.minimum(fa, fb), np.maximum(fa, fb)], axis=-1)[:, None, None, :]
    sig = np.stack([np.where(lo[:, None], a, b), np.where(lo[:, None], b, a)], axis=-1)[:, None, None] + 0j
    s = Samples(angles, freq, np.full((n, 1, 1), OK, np.uint8), sig)
    res, _ = track_angles(s, crit=Criteria(mac_min=0.5, mac_margin=0.0))
    assert res.open_loops == 1 and res.fallback.all()
    np.testing.assert_array_equal(res.tracked, freq)
    arc, _ = track_angles(Samples(angles[:7], freq[:7], s.status[:7], sig[:7]), crit=Criteria(mac_min=0.5, mac_margin=0.0))
    assert arc.open_loops == 0 and not arc.fallback.any()  # half a revolution: nothing to close


def test_unconverged_points_are_skipped():
    angles = np.arange(0.0, 301.0, 30.0)  # not a revolution: the synthetic K is not periodic
    s = samples(angles, 0.0)
    s.status[6] = Status.FAILED.code
    res, _ = track_angles(s, crit=Criteria(max_halvings=0))
    assert np.all(np.isnan(res.tracked[6])) and np.all(np.isfinite(res.tracked[7:]))
    np.testing.assert_allclose(res.tracked[7:, 0, 0, 1] ** 2 * (2 * np.pi) ** 2, 10.0 - (angles[7:] - 180) / 100)


def test_speed_tracking_and_case_matching():
    speeds = np.arange(0.0, 361.0, 30.0)  # the same two-DOF crossing, along speed
    f, v = two_dof(speeds, 0.0)
    freq, sig = f[None, :, None, :], v[None, :, None].astype(complex)
    st = np.full((1, len(speeds), 1), OK, np.uint8)
    tracked, fb = track_speeds(freq[:, :6], st[:, :6], sig[:, :6])  # up to the crossing
    assert not fb.any()
    np.testing.assert_allclose(tracked[0, :, 0, 1] ** 2 * (2 * np.pi) ** 2, 10.0 - (speeds[:6] - 180) / 100)
    assert track_speeds(freq, st, sig)[1].all()  # a crossing cannot be confirmed along speed
    _, fb_veer = track_speeds(*(lambda f, v: (f[None, :, None], st, v[None, :, None].astype(complex)))(
        *two_dof(speeds, 0.02)))
    assert fb_veer.all()  # ambiguous along speed: left in sorted order
    perm, ok = match_cases(v[:1].astype(complex), v[-1:].astype(complex))  # e1/e2 swapped between ends
    assert perm.tolist() == [[1, 0]] and ok.all()
    _, ok45 = match_cases(v[:1].astype(complex), (v[:1] @ np.array([[1, 1], [-1, 1]]) / np.sqrt(2)).astype(complex))
    assert not ok45.any()  # 45°: no match exists


# ------------------------------------------------------------------ Bahgat-Willmert sweep
@pytest.fixture(scope="module")
def bw10(tmp_path_factory):
    d = tmp_path_factory.mktemp("bw10")
    out = d / "bw10.h5"
    assert main(["run", SCENE, "--angles", "0:360:10", "-o", str(out), "--quiet"]) == 0
    return out


def test_tracked_mode_k_comes_back_to_itself_after_a_revolution(bw10, capsys):
    with h5py.File(bw10, "r") as f:
        tr, srt = f["tracked_frequency_hz"][()], f["frequency_hz"][()]
        t = dict(f["tracking"].attrs)
        fallback = f["tracking/fallback"][()]
        ref_angles = f["tracking/refined/crank_angle_deg"][()]
    assert not fallback.any() and t["open_loops"] == 0 and t["unresolved_links"] == 0
    np.testing.assert_allclose(tr[-1], tr[0], rtol=1e-9)  # 360° is 0°: same position, same frequency
    np.testing.assert_allclose(srt[-1], srt[0], rtol=1e-9)
    assert t["ambiguous_links"] > 0 and t["refined_angles"] == len(ref_angles) > 0
    assert np.all(ref_angles % 10.0 != 0)  # only off-grid angles were added
    import xarray as xr  # the refined angles open as their own labelled dataset

    with xr.open_dataset(bw10, group="tracking/refined", engine="h5netcdf") as ds:
        assert ds.frequency_hz.dims == ("crank_angle_deg", "speed_rad_s", "case", "mode")
        np.testing.assert_array_equal(ds.crank_angle_deg.values, ref_angles)
    main(["info", str(bw10)])
    out = capsys.readouterr().out
    assert "0 open loops" in out and "all 18 (speed, case) lines tracked" in out


@pytest.mark.slow
def test_tracked_curves_are_those_of_a_four_times_finer_grid(bw10, tmp_path):
    """Continuity: the 10° grid with refinement picks the same branches as a 2.5° grid."""
    fine = tmp_path / "bw2.h5"
    assert main(["run", SCENE, "--angles", "0:360:2.5", "--speeds", "1000", "--cases", "full,no_normal",
                 "-o", str(fine), "--quiet"]) == 0
    with h5py.File(bw10, "r") as f, h5py.File(fine, "r") as g:
        coarse = f["tracked_frequency_hz"][:, 2, [1, 4]]  # 1000 rad/s; full, no_normal
        ref = g["tracked_frequency_hz"][::4, 0]
        assert not g["tracking/fallback"][()].any()
    np.testing.assert_allclose(coarse, ref, rtol=1e-9)
