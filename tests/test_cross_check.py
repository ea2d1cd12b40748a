"""`--cross-check`: every point solved by both engines, the largest difference reported and archived."""

import json
from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_run_cross_check_compares_every_solved_point(tmp_path, capsys):
    out = tmp_path / "bw.h5"
    code = main(["run", str(ROOT / "runs/bahgat-willmert-1976.toml"), "-o", str(out), "--angles", "0:90:45",
                 "--speeds", "0,1000", "--cases", "all", "--quiet", "--cross-check"])
    err = capsys.readouterr().err
    assert code == 0, err
    with h5py.File(out, "r") as f:
        cc = json.loads(f.attrs["last_solver_settings"])["cross_check"]
        st = f["tracking/refined/status"][()] if "tracking/refined" in f else np.zeros((0, 2, 6))
    # 3 angles x (structure once + 5 cases at 1000 rad/s): structure is not re-solved per speed, and
    # at 0 rad/s every case is the structure; plus the extra angles mode tracking solved
    # (docs/tracking.md), counted the same way
    extra = int(np.count_nonzero(st[:, 1, 1:]) + np.count_nonzero(st[:, :, 0].any(axis=1) | st[:, 0].any(axis=1)))
    assert cc["points"] == 3 * (1 + 5) + extra and cc["skipped"] == 0
    assert cc["other_engine"] == "slepc"  # 15 DOFs: auto picks dense, checked against SLEPc
    assert cc["max_rel_diff"] < 1e-9
    assert "cross-check dense vs slepc" in err
