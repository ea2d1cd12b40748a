"""Mode tracking and crank-order margins of out-of-plane sweeps (docs/tracking.md "Out of plane",
docs/theory.md §19): the tracked modes of ``fkev run --plane out`` are the sorted ones permuted,
continuous in θ, on every line of the flat-rod slider-crank and of the Bahgat-Willmert four-bar;
``fkev margins`` labels the plane and its margins are the hand computation from the archive."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from fkev_slepc.cli import main
from fkev_slepc import open as open_archive
from fkev_slepc.archive.store import read_tracking_inputs
from fkev_slepc.archive.tracks import read_tracking
from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene
from fkev_slepc.scene.model import with_elements
from fkev_slepc.solve.modes import mac
from fkev_slepc.sweep.tracking_angles import Samples, track_angles

ROOT = Path(__file__).resolve().parents[1]
FLAT = ROOT / "runs/flat-rod-slider-crank.toml"
# Bahgat-Willmert's 0.25 in x 1 in steel bars, 1 in in the plane (as tests/test_out_of_plane_point.py)
BW_OUT = "second_moment_out_of_plane_m4 = 5.42e-10\ntorsion_constant_m4 = 1.826e-9\nshear_modulus_pa = 7.96e10\n"
RUNS = {"flat": ("--modes", "3", "--angles", "0:355:15"),
        "bw": ("--modes", "4", "--cases", "full", "--speeds", "0,150,300", "--angles", "0:355:15")}


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("oop-tracking")
    bw = tmp / "bw.toml"
    bw.write_text((ROOT / "runs/bahgat-willmert-1976.toml").read_text().replace(
        "[link_defaults]\n", "[link_defaults]\n" + BW_OUT, 1))
    out = {}
    for name, scene in (("flat", FLAT), ("bw", bw)):
        path = tmp / f"{name}-out.h5"
        assert main(["run", str(scene), "--plane", "out", "--elements", "1", *RUNS[name], "-q", "-o", str(path)]) == 0
        out[name] = (scene, path)
    return out


@pytest.mark.parametrize("name", ["flat", "bw"])
def test_tracked_modes_are_the_sorted_ones_followed_continuously(archives, name):
    """Every line is tracked (no fallback, nothing left ambiguous); at every angle the tracked
    frequencies are the sorted ones permuted; along θ (around the revolution) no tracked curve
    jumps further between neighbouring angles than the sorted curves do."""
    _, path = archives[name]
    res = open_archive(path)
    assert res.plane == "out"
    tr = read_tracking(path)
    assert not tr["fallback"].any() and tr["attrs"]["unresolved_links"] == 0 and tr["attrs"]["open_loops"] == 0
    s, t = res.frequency(order="sorted"), res.frequency(order="tracked")
    assert np.isfinite(s).all()
    np.testing.assert_array_equal(np.sort(t, axis=-1), s)
    step = lambda f: np.abs(np.roll(f, -1, axis=0) - f).max(axis=0)  # noqa: E731 (around the closed revolution)
    assert np.all(step(t) <= step(s).max(axis=-1, keepdims=True) * (1 + 1e-12))


def test_raw_out_of_plane_entries_cannot_tell_the_modes_apart(archives):
    """Why the signatures are mass-weighted out of plane (sweep/tracking.py signature_weight): the
    archived entries are √M_ii·x; divided back to raw entries two different modes of the flat rod
    at the same angle have a MAC of 0.99 somewhere on the cycle and the same walk falls back on
    every line, while the weighted entries keep different modes below 0.6 (0.53 measured with one
    element per link, 0.12 with two: docs/tracking.md)."""
    scene, path = archives["flat"]
    freq, status, sig = read_tracking_inputs(path)
    res = open_archive(path)
    model = Model(with_elements(load_scene(scene), 1), ("full",), plane="out")
    assert sig.shape[3] == model.n_free  # every DOF is kept
    w = np.stack([np.sqrt(model.pieces(math.radians(a)).mass_matrix.diagonal()) for a in res.crank_angle_deg])
    raw = sig / w[:, None, None, :, None]
    off = ~np.eye(sig.shape[-1], dtype=bool)
    assert mac(sig, sig)[..., off].max() < 0.6 and mac(raw, raw)[..., off].max() > 0.99
    angles = np.asarray(res.crank_angle_deg, float)
    weighted, _ = track_angles(Samples(angles, freq, status, sig))
    unweighted, _ = track_angles(Samples(angles, freq, status, raw))
    assert weighted.unresolved < unweighted.unresolved and unweighted.fallback.all()


def test_margins_out_of_plane_are_labelled_and_hand_computed(archives, capsys):
    """``fkev margins`` on the out-of-plane archive: ``plane`` "out" in the JSON, "out of plane"
    in the header; each mode's band and closest crank order are those computed here from the
    archived tracked frequencies by the rule of docs/design.md (distance of n·Ω/2π from the band
    over the band edge it approaches)."""
    _, path = archives["flat"]
    res = open_archive(path)
    speed = float(res.speed_rad_s[1])
    assert main(["margins", str(path), "--speed", repr(speed), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["plane"] == "out" and out["order"] == "tracked"
    f = res.frequency(order="tracked")[:, 1, 0, :]
    base = speed / (2 * math.pi)
    for k, m in enumerate(out["modes"]):
        lo, hi = f[:, k].min(), f[:, k].max()
        assert (m["f_min_hz"], m["f_max_hz"]) == (lo, hi)
        orders = np.arange(1, out["orders"] + 1) * base
        edge = np.where(orders < lo, lo, hi)
        margin = np.where((orders >= lo) & (orders <= hi), 0.0, 100 * np.abs(edge - orders) / edge)
        n = int(np.argmin(margin))
        assert m["closest_order"] == n + 1 and m["margin_percent"] == pytest.approx(margin[n], rel=1e-12)
    assert main(["margins", str(path), "--speed", repr(speed)]) == 0
    assert "out of plane" in capsys.readouterr().out.splitlines()[0]
