"""The archived response vs speed (docs/response.md §5, docs/archive.md "Units of work"): one speed per
unit of work of the /response product over MPI ranks, equal to the in-process scan, resumable, verified,
xarray-readable. Lean: one element per link, three speeds, eight output angles."""

import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest
from clitools import ROOT, edited, fkev

from fkev_slepc.api import Study
from fkev_slepc.archive import products as P
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.sweep.grid import configure
from fkev_slepc.api.response_archive import read_response, read_status

BENCH = ROOT / "runs" / "slider-crank-benchmark-stiff-crank.toml"
SPEEDS = [50.0, 150.0, 250.0]
OPTS = dict(harmonics=12, angles_deg=np.arange(0, 360, 45.0), shoot=False)
FIELDS = ("peak_transverse", "peak_chord", "peak_moment", "peak_stress", "mean_frequencies")


def _same(a, b, name):
    """Equal to 1e-12 of the field's largest value: a tip's bending moment is ~1e-5 of the root's and
    carries the round-off of the root's size (3e-14 N m seen between a 2-rank and an in-process scan)."""
    b = np.asarray(b)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.nanmax(np.abs(b)), err_msg=name)


def _study():
    return Study(configure(with_elements(load_scene(BENCH), (1, 1)), angles="0:360:90"))


@pytest.fixture(scope="module")
def serial():
    return _study().response_vs_speed(SPEEDS, **OPTS)


def test_two_ranks_equal_the_serial_scan_verify_and_open_in_xarray(tmp_path, serial):
    """mpiexec -n 2 fkev response --speeds -o: the speeds dealt to two ranks give the in-process
    scan's peaks and cycle-mean frequencies to 1e-12; fkev verify passes; xarray opens the root
    (the frozen sweep of the same speeds) and the /response group."""
    if shutil.which("mpiexec") is None:  # pragma: no cover - part of the stack
        pytest.skip("mpiexec not found")
    import xarray as xr

    out = tmp_path / "p.h5"
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PYTHONPATH=str(ROOT),
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
    r = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-m", "fkev_slepc", "response", str(BENCH),
                        "--elements", "1", "--speeds", "50,150,250", "--harmonics", "12", "--angles", "0:315:45",
                        "--no-shooting", "-o", str(out)], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("peak response over the cycle vs speed") == 1  # rank 0 prints, once
    par = read_response(out)
    for name in FIELDS:
        _same(getattr(par, name), getattr(serial, name), name)
    assert par.station_labels == serial.station_labels and par.resonances == serial.resonances
    assert read_status(out).tolist() == [1, 1, 1]
    with h5py.File(out, "r") as f:
        assert int(f.attrs["n_ranks"]) == 2 and int(f.attrs["complete"]) == 1
    v = fkev("verify", out)
    assert v.returncode == 0 and ": ok" in v.stdout, v.stdout + v.stderr
    ds = xr.open_dataset(out, group="response", engine="h5netcdf")
    np.testing.assert_array_equal(ds["peak_transverse_chord_m"].values[:, 0, :], par.peak_chord)
    assert ds["peak_stress_pa"].attrs["units"] == "Pa" and list(ds["station_link"].values[:3]) == ["crank"] * 3
    root = xr.open_dataset(out, engine="h5netcdf")
    assert root["frequency_hz"].shape[1:3] == (3, 1) and root["speed_rad_s"].values.tolist() == SPEEDS


def test_resume_solves_only_the_pending_speeds(tmp_path, serial, monkeypatch):
    """A finished archive with one speed set back to pending: the resume solves that speed alone and
    gives the same numbers; other periodic settings (here harmonics) are refused before any work, the
    archive left byte-identical (issue 24: the settings compared whole)."""
    from clitools import digest

    from fkev_slepc.sweep.session import OutputError
    from fkev_slepc.api import response_speeds as rs

    out = tmp_path / "s.h5"
    first = _study().response_vs_speed(SPEEDS, output=out, **OPTS)
    for name in FIELDS:
        _same(getattr(first, name), getattr(serial, name), name)
    with edited(out) as f:
        f[P.R_STATUS.path][1, 0] = 0
    calls = []
    real = rs.speed_peaks

    def counting(scene, speed, *a, **k):
        calls.append(speed)
        return real(scene, speed, *a, **k)

    monkeypatch.setattr(rs, "speed_peaks", counting)
    again = _study().response_vs_speed(SPEEDS, output=out, resume=True, **OPTS)
    assert calls == [150.0]
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(again, name), getattr(first, name), err_msg=name)
    assert read_status(out).tolist() == [1, 1, 1] and fkev("verify", out).returncode == 0
    calls.clear()
    before = digest(out)
    with pytest.raises(OutputError, match=r"cannot resume: the periodic settings differ from the archive's: "
                                          r"harmonics: archive has 12, this run 8$"):
        _study().response_vs_speed(SPEEDS, output=out, resume=True, **{**OPTS, "harmonics": 8})
    assert calls == [] and digest(out) == before


def test_ctrl_c_stops_at_a_sync_and_resume_finishes(tmp_path):
    """Ctrl-C during the speeds (paused at the first sync by FKEV_PAUSE_AFTER, no race): exit 130,
    the .part keeps the speed written and the other two pending; --resume solves those two and gives
    the uninterrupted archive's numbers."""
    from test_cli_interrupt import interrupt_when_paused

    from fkev_slepc.sweep.interrupt import PAUSE_VARIABLE

    out = tmp_path / "c.h5"
    args = ["response", BENCH, "--elements", "1", "--speeds", "50,150,250", "--harmonics", "12", "--angles",
            "0:315:45", "--no-shooting", "-o", out]
    assert fkev(*args, "--json").returncode == 0
    done = read_response(out)
    with edited(out) as f:  # every speed pending again: the frozen sweep has nothing left to do
        f[P.R_STATUS.path][:, 0] = 0
    env = {**os.environ, "PYTHONPATH": str(ROOT), PAUSE_VARIABLE: "1", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "fkev_slepc", *map(str, args), "--resume", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    code, err, written = interrupt_when_paused(proc)
    assert code == 130 and written == 1, err
    part = out.with_name(out.name + ".part")
    assert part.exists() and "resume" in err
    assert sorted(read_status(part).tolist()) == [0, 0, 1]
    r = fkev(*args, "--resume")
    assert r.returncode == 0, r.stderr
    assert "response: 2 of 3 speed(s) to solve" in r.stderr
    again = read_response(out)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(again, name), getattr(done, name), err_msg=name)


def test_a_speed_that_raises_is_flagged_not_filled(tmp_path, monkeypatch):
    """A solver failure at one speed: status failed, its message in /response/errors, NaN peaks; the
    other speeds archived; the archive verifies."""
    from fkev_slepc.api import response_speeds as rs

    real = rs.speed_peaks

    def failing(scene, speed, *a, **k):
        if speed == 150.0:
            raise np.linalg.LinAlgError("singular matrix (injected)")
        return real(scene, speed, *a, **k)

    monkeypatch.setattr(rs, "speed_peaks", failing)
    out = tmp_path / "f.h5"
    res = _study().response_vs_speed(SPEEDS, output=out, **OPTS)
    assert read_status(out).tolist() == [1, 5, 1]
    assert np.isnan(res.peak_chord[1]).all() and np.isfinite(res.peak_chord[[0, 2]]).all()
    with h5py.File(out, "r") as f:
        assert f[P.R_ERRORS.index.path][()].tolist() == [[1, 0]]
        assert b"singular matrix (injected)" in bytes(f[P.R_ERRORS.message.path][0])
    assert fkev("verify", out).returncode == 0
