"""Margins over the whole cycle (design/margins.py, fkev margins, plots/bands.py) on the flexible
slider-crank benchmark at 150 rad/s: 2Ω stays below mode 1's band, 3Ω is crossed every revolution."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import fkev_slepc as fk
from fkev_slepc.archive.reader import ArchiveError
from fkev_slepc.design.margins import crossing_angles, margins
from fkev_slepc.cli import main

SC = Path(__file__).resolve().parents[1] / "runs" / "slider-crank-benchmark.toml"
W = 150.0
ORDER_HZ = W / (2 * math.pi)


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    out = tmp_path_factory.mktemp("margins") / "sc.h5"
    fk.load(SC).sweep("0:360:10", [0, W], ["full"], out)
    return out


def test_two_omega_below_the_band_three_omega_crossed(archive):
    res = fk.open(archive)
    m1 = margins(res, W).modes[0]
    f1 = res.frequency("full", W)[:, 0]
    assert (m1.f_min_hz, m1.f_max_hz) == (np.nanmin(f1), np.nanmax(f1))
    assert 2 * ORDER_HZ < m1.f_min_hz < 3 * ORDER_HZ < m1.f_max_hz < 4 * ORDER_HZ
    assert m1.orders_inside == (3,) and m1.closest.order == 3 and m1.closest.margin_percent == 0.0
    assert m1.below.order == 2 and m1.below.margin_percent == pytest.approx(100 * (1 - 2 * ORDER_HZ / m1.f_min_hz))
    assert 15 < m1.below.margin_percent < 25 and m1.above.order == 4
    # the one-angle Campbell hides it: at θ = 0 mode 1 is far from 3Ω (at its band top, nearest 4Ω)
    assert abs(f1[0] - 3 * ORDER_HZ) / f1[0] > 0.2
    # each crossing angle is where mode 1 really is at 3Ω: solved there, within the 10° grid's interpolation
    crossings = m1.crossings[3]
    assert len(crossings) == 4  # twice in each half-cycle (the in-line slider-crank is symmetric)
    study = fk.load(SC)
    for a in crossings:
        assert study.point(a, W, "full", modes=1).frequency_hz[0] == pytest.approx(3 * ORDER_HZ, rel=5e-3)
    higher = margins(res, W).modes[1]
    assert higher.orders_inside and min(higher.orders_inside) > 3


def test_crossing_angles_interpolate_each_straddled_interval():
    a = np.array([0.0, 10, 20, 30, 40])
    assert crossing_angles(a, np.array([1.0, 3, np.nan, 3, 1]), 2.0) == (5.0, 35.0)  # NaN intervals skipped
    assert crossing_angles(a, np.array([2.0, 3, 3, 3, 3]), 2.0) == (0.0,)


def test_cli_margins_json_and_band_campbell(archive, tmp_path, capsys):
    png = tmp_path / "bands.png"
    assert main(["margins", str(archive), "--speed", "150", "--json", "--plot", str(png)]) == 0
    got = json.loads(capsys.readouterr().out)
    m1 = got["modes"][0]
    assert {"mode", "f_min_hz", "f_max_hz", "orders_inside", "closest_order", "margin_percent"} <= set(m1)
    assert m1["mode"] == 1 and m1["orders_inside"] == [3] and m1["closest_order"] == 3 and m1["margin_percent"] == 0
    assert png.stat().st_size > 10_000
    assert main(["margins", str(archive), "--speed", "150"]) == 0
    assert "2Ω 20." in capsys.readouterr().out.splitlines()[2]
    assert main(["margins", str(archive), "--speed", "100"]) == 2
    assert "--speed: 100 rad/s is not on the archive's speed grid" in capsys.readouterr().err
    assert main(["margins", str(archive), "--speed-rpm", str(W * 60 / (2 * math.pi)), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["modes"][0]["orders_inside"] == [3]
    assert main(["margins", str(archive), "--speed", "0"]) == 2
    assert "speed > 0" in capsys.readouterr().err


def test_band_bars_span_each_band(archive):
    from fkev_slepc.plots.bands import band_campbell

    res = fk.open(archive)
    fig = band_campbell(res, modes=[1, 2], speed=W)
    bars = [p for p in fig.axes[0].patches]
    lo = np.nanmin(res.frequency("full")[..., :2], axis=0)  # (speed, mode)
    hi = np.nanmax(res.frequency("full")[..., :2], axis=0)
    heights = sorted(round(b.get_height(), 6) for b in bars)
    assert heights == sorted(np.round((hi - lo).ravel(), 6))
    with pytest.raises(ArchiveError):
        band_campbell(res, case="no_normal")


def test_per_order_rows_and_tracking_label(archive, tmp_path, capsys):
    """One row per mode and order (default 1×, 2×, 3×): mode 1 has 3Ω inside its band (margin 0,
    the crossing angles) and 2Ω below it at the closest-order table's margin; a chosen order set
    gives those rows only. The modes are 'tracked' only where /tracking/fallback is 0 at that line:
    the same archive with the flag set says 'sorted' (and is reported as changed since the run)."""
    import shutil

    import h5py

    from fkev_slepc.archive.reader import DamagedArchiveWarning

    res = fk.open(archive)
    table = margins(res, W)
    rows = {(m.mode, a.order): a for m, a in table.per_order}
    assert sorted({o for _, o in rows}) == [1, 2, 3] and len(rows) == 3 * len(table.modes)
    m1 = table.modes[0]
    assert rows[(1, 3)].margin_percent == 0.0 and rows[(1, 3)].angles_deg == m1.crossings[3]
    assert rows[(1, 2)].margin_percent == pytest.approx(m1.below.margin_percent, rel=1e-15)
    assert rows[(1, 1)].frequency_hz == pytest.approx(ORDER_HZ, rel=1e-15)
    assert [a.order for _, a in margins(res, W, per_order=(4,)).per_order] == [4] * len(table.modes)
    assert table.order == "tracked" and not table.tracking_fell_back
    copy = tmp_path / "fallback.h5"
    shutil.copy(archive, copy)
    with h5py.File(copy, "r+") as f:
        f["tracking/fallback"][...] = 1
    with pytest.warns(DamagedArchiveWarning, match="tracking/fallback"):
        fell = margins(fk.open(copy), W)
    assert fell.order == "sorted" and fell.tracking_fell_back
    with pytest.warns(DamagedArchiveWarning):
        assert main(["margins", str(copy), "--speed", "150", "--per-order", "2,3", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["tracking_fell_back"] and {r["order"] for r in got["per_order"]} == {2, 3}
    with pytest.raises(ArchiveError, match="--per-order"):
        margins(res, W, per_order=(0,))
