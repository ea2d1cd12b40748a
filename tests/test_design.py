"""Design studies (design/study.py, Study.design, fkev design): each design point is the sweep of
the scene with those key values, the base sweep is the scene as written, the archive resumes,
and two MPI ranks give the same archive as one."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from clitools import edited

import fkev_slepc as fk
from fkev_slepc.archive import products as P
from fkev_slepc.design.results import open_design
from fkev_slepc.scene import SceneError
from fkev_slepc.status import Status
from fkev_slepc.sweep.session import RunRefused
from fkev_slepc.cli import main

ROOT = Path(__file__).resolve().parents[1]
SC = ROOT / "runs" / "slider-crank-benchmark.toml"
ROD = "links[rod].length_m"
GRID = dict(speeds=[0, 150], cases=["full"], angles="0:180:90")  # 3 angles: lean


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("design") / "sc-design.h5"
    ds = fk.load(SC).design({ROD: "0.25:0.35:0.05", "links[crank].length_m": [0.15, 0.16]}, output=out, **GRID)
    return out, ds


def test_each_design_point_is_the_sweep_of_the_replaced_scene(study):
    out, ds = study
    assert ds.attrs["design_keys"] == [ROD, "links[crank].length_m"]
    assert ds.sizes[ROD] == 3 and ds.sizes["links[crank].length_m"] == 2
    np.testing.assert_allclose(ds[ROD].values, [0.25, 0.3, 0.35])
    base = fk.load(SC)
    for rod, crank in [(0.25, 0.16), (0.35, 0.15)]:
        sub = ds.sel({ROD: rod, "links[crank].length_m": crank})
        edited = base.replace({ROD: rod, "links[crank].length_m": crank})
        for angle in (0.0, 90.0):
            r = edited.point(angle, 150, "full")
            np.testing.assert_allclose(sub.frequency_hz.sel(crank_angle_deg=angle, speed_rad_s=150, case="full"),
                                       r.frequency_hz, rtol=1e-10)
        f = sub.frequency_hz.sel(speed_rad_s=150, case="full")
        np.testing.assert_array_equal(sub.frequency_min_hz.sel(speed_rad_s=150, case="full"), f.min("crank_angle_deg"))
        # the lowest divergence speed over the angles is Study.critical's, angle by angle
        lows = [edited.critical("full", angle_deg=a).lowest("divergence_speed")[0] for a in (0, 90, 180)]
        assert float(sub.divergence_speed_rad_s.sel(case="full")) == pytest.approx(min(lows), rel=1e-9)
    # the root sweep is the scene as written, as fkev run would make it
    res = fk.open(out)
    ref = base.point(90, 150, "full").frequency_hz
    np.testing.assert_allclose(res.frequency("full", 150)[res.angle_index(90)], ref, rtol=1e-10)
    # a longer rod: its bending mode (mode 2) lower over the whole cycle, buckling at a lower speed
    m2 = ds.frequency_min_hz.sel(speed_rad_s=150, case="full", mode=2, **{"links[crank].length_m": 0.15})
    div = ds.divergence_speed_rad_s.sel(case="full", **{"links[crank].length_m": 0.15})
    assert np.all(np.diff(m2.values) < 0) and np.all(np.diff(div.values) < 0)


def test_resume_solves_only_the_pending_design_points(study, tmp_path):
    out, ds = study
    copy = tmp_path / "copy.h5"
    shutil.copy(out, copy)
    with edited(copy) as f:  # as if the run had stopped before design points 1 and 4
        for ip in (1, 4):
            f[P.D_STATUS.path][ip] = Status.PENDING.code
            f[P.D_FREQUENCY.path][ip] = np.nan
    again = fk.load(SC).design({ROD: "0.25:0.35:0.05", "links[crank].length_m": [0.15, 0.16]}, output=copy,
                               resume=True, **GRID)
    np.testing.assert_allclose(again.frequency_hz.values, ds.frequency_hz.values, rtol=1e-12)
    assert (again.status.values == "ok").sum() == (ds.status.values == "ok").sum()
    with pytest.raises(RunRefused, match="design study over other values"):
        fk.load(SC).design({ROD: "0.25,0.3"}, output=copy, resume=True, **GRID)
    with pytest.raises(RunRefused):  # an existing archive is not overwritten without force
        fk.load(SC).design({ROD: "0.25,0.3"}, output=copy, **GRID)


def test_ctrl_c_stops_at_a_sync_and_resume_completes_the_same_study(study, tmp_path, monkeypatch):
    """A SIGINT raised while the first design point is solved (no race: the process signals
    itself) stops the run at the next sync with that point in the .part; --resume finishes."""
    import signal

    from fkev_slepc.design import study as design_study
    from fkev_slepc.sweep.interrupt import SweepInterrupted

    out, ds = study
    params = {ROD: "0.25:0.35:0.05", "links[crank].length_m": [0.15, 0.16]}
    real = design_study.DesignSolver.solve

    def solve_then_interrupt(self, unit, mask):
        block = real(self, unit, mask)
        if unit == (0,):
            signal.raise_signal(signal.SIGINT)
        return block

    monkeypatch.setattr(design_study.DesignSolver, "solve", solve_then_interrupt)
    target = tmp_path / "stopped.h5"
    with pytest.raises(SweepInterrupted):
        fk.load(SC).design(params, output=target, **GRID)
    part = target.with_name(target.name + ".part")
    with h5py.File(part, "r") as f:
        done = f[P.D_STATUS.path][()] != Status.PENDING.code
    assert done[0].all() and not done[1:].any()  # exactly the first design point was kept
    monkeypatch.setattr(design_study.DesignSolver, "solve", real)
    again = fk.load(SC).design(params, output=target, resume=True, **GRID)
    np.testing.assert_allclose(again.frequency_hz.values, ds.frequency_hz.values, rtol=1e-12)
    np.testing.assert_allclose(again.divergence_speed_rad_s.values, ds.divergence_speed_rad_s.values, rtol=1e-12)


def test_bad_design_values_are_refused_before_anything_is_solved(tmp_path):
    out = tmp_path / "bad.h5"
    with pytest.raises(SceneError) as exc:
        fk.load(SC).design({ROD: "-0.1,0.3"}, output=out, **GRID)
    assert "design point 0 (links[rod].length_m = -0.1): links[1].length_m: must be > 0 (got -0.1)" in str(exc.value)
    with pytest.raises(SceneError, match="lenght_m"):
        fk.load(SC).design({"links[rod].lenght_m": 0.3}, output=out, **GRID)
    assert not out.exists()
    assert main(["design", str(SC), "--set", "links[rod].length_m", "-o", str(out)]) == 2


@pytest.mark.mpi
def test_two_ranks_write_the_archive_of_one(study, tmp_path):
    if shutil.which("mpiexec") is None:  # pragma: no cover - part of the stack
        pytest.skip("mpiexec not found")
    out, _ = study
    two = tmp_path / "two.h5"
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
    r = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-m", "fkev_slepc", "design", str(SC),
                        "--set", f"{ROD}=0.25:0.35:0.05", "--set", "links[crank].length_m=0.15,0.16",
                        "--speeds", "0,150", "--cases", "full", "--angles", "0:180:90", "-o", str(two)],
                       env=env, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("design points") == 1  # one summary, from rank 0
    a, b = open_design(out), open_design(two)
    for name in ("frequency_hz", "divergence_speed_rad_s"):
        np.testing.assert_allclose(b[name].values, a[name].values, rtol=1e-12)
    assert (a.status.values == b.status.values).all()
