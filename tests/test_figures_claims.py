"""scripts/figures_claims.py (the claims table printed by `make figures`) on small archives made
here with Study.sweep: every row is produced, and the rows that have a physical answer give it."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

import fkev_slepc as fk

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "runs"
BW, TM = RUNS / "bahgat-willmert-1976.toml", RUNS / "turcic-midha-1984.toml"


def _script():
    spec = importlib.util.spec_from_file_location("figures_claims", ROOT / "scripts" / "figures_claims.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    """The archives scripts/figures.sh writes, on small grids (4 angles; 4 speeds at 10°)."""
    out = tmp_path_factory.mktemp("figures")
    angles = [0, 10, 20, 360]  # 360°: the position of 0° again (see test_peaks_name_each_position_once)
    fk.load(BW).sweep(angles, output=out / "bw.h5", solver="dense")
    fk.load(BW, elements=2).sweep(angles, output=out / "bw-refined.h5", solver="dense")
    fk.load(RUNS / "bahgat-willmert-speed-sweep.toml").sweep(speeds_rad_s=[0, 25, 500, 1000], mode_shapes=True,
                                                              output=out / "bw-speed.h5", solver="dense")
    fk.load(BW).sweep([0, 180], [0, 500, 1000], ["full"], output=out / "bw-stability.h5", solver="dense")
    for n in (1, 2, 3, 12):
        fk.load(TM, elements=n).sweep([0, 90], output=out / f"tm-{3 * n}.h5", solver="dense")
    fk.load(TM).sweep([0, 180], [0, 100, 200], ["full"], output=out / "tm-stability.h5", solver="dense")
    return out


def test_every_claim_row_is_produced(archives, capsys):
    mod = _script()
    assert mod.main([str(archives)]) == 0
    table = capsys.readouterr().out
    claims = {line.split("|")[1].strip() for line in table.splitlines() if line.startswith("| C")}
    assert claims == {f"C{i}" for i in range(1, 13)}
    assert table.count("| stability |") == 2
    assert mod.main([]) == 2


def test_claim_numbers_follow_the_physics(archives):
    rows = _script().claims(archives)
    text = {c: [t for k, t in rows if k == c] for c in dict(rows)}
    # C3: the structure case does not depend on speed (round-off only)
    assert float(re.search(r"= ([0-9.e+-]+)$", text["C3"][0]).group(1)) < 1e-9
    # C2: consistent-mass Euler-Bernoulli elements converge from above, monotonically: the
    # 3-, 6- and 9-element meshes are ever closer to 36 elements, mode by mode
    gaps = np.array([[float(v) for v in re.search(r"max Δf = ([0-9. /]+) %", t).group(1).split(" / ")]
                     for t in text["C2"]])
    assert gaps.shape == (3, 3) and np.all(gaps > 0) and np.all(np.diff(gaps, axis=0) < 0)
    # the stability rows account for every point of their grids
    for t, n_points in zip(text["stability"], (2 * 3, 2 * 3)):
        counts = {k: int(v) for k, v in re.findall(r"'(\w+)': (\d+)", t)}
        assert sum(counts.values()) == n_points and counts["failed"] == 0


def test_peaks_name_each_position_once(archives):
    """0° and 360° are one crank position with the same frequencies up to round-off: where a cycle's
    peak or minimum lies is reported once (0°), so that a regenerated table does not flip 0 <-> 360."""
    mod = _script()
    np.testing.assert_array_equal(mod.one_turn([0, 90, 180, 270, 360]), [True, True, True, True, False])
    np.testing.assert_array_equal(mod.one_turn([0, 120, 240]), [True, True, True])
    np.testing.assert_array_equal(mod.one_turn([90, 360]), [True, True])  # 360° alone is a position of its own
    rows = mod.claims(archives)
    where = [t.split("θ = ")[1] for c, t in rows if c in ("C8", "C9", "C12") and "θ = " in t]
    assert len(where) == 2 * 2 + 1 + 3 and not any("360" in w for w in where)
