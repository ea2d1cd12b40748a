"""Multi-rank sweeps: `mpiexec` spawned from the test (never `mpirun pytest`).

One 666-point sweep (Bahgat-Willmert, every 10° of crank angle, 6 elements per link, dense engine) is run
uninterrupted on 2 ranks (parallel HDF5), on 1 rank, on 2 ranks writing through rank 0
(FKEV_HDF5_MPIO=0), and on 2 ranks killed with SIGKILL at a sync midway then resumed; the archives are
compared point for point. The OpenMPI root variables are set in the subprocess env only.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from fkev_slepc.sweep.interrupt import PAUSE_VARIABLE, PAUSED

pytestmark = pytest.mark.mpi
ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "runs" / "bahgat-willmert-1976.toml"
SWEEP = ["--elements", "6", "--solver", "dense", "--angles", "0:360:10"]  # small: make test stays short
N_POINTS = 37 * 3 * 6
DATASETS = ("frequency_hz", "tracked_frequency_hz", "eigenvalue", "residual", "max_real", "status",
            "tracking/signature", "errors/index", "errors/message", "crank_angle_deg", "speed_rad_s", "case")
if shutil.which("mpiexec") is None:  # pragma: no cover - part of the stack
    pytest.skip("mpiexec not found", allow_module_level=True)


def env(**extra) -> dict:
    e = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
             OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")
    e.update(extra)
    return e


def fkev(n: int, *args: str, **extra) -> list[str]:
    return ["mpiexec", "-n", str(n), sys.executable, "-m", "fkev_slepc", *args]


def run(n: int, *args: str, extra_env=None) -> subprocess.CompletedProcess:
    return subprocess.run(fkev(n, *args), env=env(**(extra_env or {})), capture_output=True, text=True,
                          timeout=300, cwd=ROOT)


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("mpi")
    shutil.copy(SCENE, d / "bw.toml")
    return d


@pytest.fixture(scope="module")
def two_ranks(work):
    out = work / "two.h5"
    r = run(2, "run", str(work / "bw.toml"), "-o", str(out), *SWEEP)
    assert r.returncode == 0, r.stderr
    return out


def read(path) -> dict:
    with h5py.File(path, "r") as f:
        return {k: f[k][()] for k in DATASETS} | {"attrs": dict(f.attrs)}


def assert_same(a: dict, b: dict, rtol: float = 0.0) -> None:
    for k in DATASETS:
        x, y = a[k], b[k]
        assert x.shape == y.shape, k
        if rtol and x.dtype.kind in "fc":
            assert np.array_equal(np.isnan(x), np.isnan(y)), k
            ok = ~np.isnan(x)
            assert np.all(np.abs(x[ok] - y[ok]) <= rtol * np.abs(y[ok])), k
        else:
            assert np.array_equal(x, y, equal_nan=x.dtype.kind in "fc"), k


def test_one_and_two_ranks_agree(work, two_ranks):
    out = work / "one.h5"
    r = run(1, "run", str(work / "bw.toml"), "-o", str(out), *SWEEP, "--quiet")
    assert r.returncode == 0, r.stderr
    one, two = read(out), read(two_ranks)
    assert_same(one, two, rtol=1e-12)
    assert np.all(two["status"] != 0) and two["attrs"]["n_ranks"] == 2 and one["attrs"]["n_ranks"] == 1
    assert two["attrs"]["complete"] == 1


def test_writing_through_rank_0_gives_the_same_archive(work, two_ranks):
    out = work / "gather.h5"
    r = run(2, "run", str(work / "bw.toml"), "-o", str(out), *SWEEP, "--quiet", extra_env={"FKEV_HDF5_MPIO": "0"})
    assert r.returncode == 0, r.stderr
    assert_same(read(out), read(two_ranks))


def _session_pids(sid: int) -> list[int]:
    pids = []
    for p in os.listdir("/proc"):
        if p.isdigit():
            try:
                if os.getsid(int(p)) == sid:
                    pids.append(int(p))
            except ProcessLookupError:
                pass
    return pids


def test_kill_midway_then_resume_equals_uninterrupted(work, two_ranks):
    """kill -9 at a sync where points are written and left (FKEV_PAUSE_AFTER: rank 0 waits
    there for a signal, so the kill never races the sweep), then ``--resume``."""
    out = work / "killed.h5"
    part = out.with_name(out.name + ".part")
    args = ["run", str(work / "bw.toml"), "-o", str(out), *SWEEP, "--quiet"]
    proc = subprocess.Popen(fkev(2, *args), env=env(**{PAUSE_VARIABLE: "36"}), cwd=ROOT, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines = []
    try:
        for line in proc.stderr:
            lines.append(line)
            if line.startswith(PAUSED):
                break
        assert proc.poll() is None, "the run ended without pausing: " + "".join(lines)
    finally:
        # kill -9 the whole job: mpiexec's process group and the ranks (own groups, same session)
        for pid in _session_pids(proc.pid):
            os.kill(pid, signal.SIGKILL)
        proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL, "".join(lines)
    written = int(re.search(r"after (\d+) of", lines[-1]).group(1))
    assert part.exists() and not out.exists()
    with h5py.File(part, "r") as f:
        status = f["status"][()]
        assert f.attrs["complete"] == 0
    n_done = int(np.count_nonzero(status))
    print(f"killed with {n_done} of {N_POINTS} points flushed; resuming")
    assert n_done == written and 36 <= n_done < N_POINTS
    # the points marked done already hold their final data
    ref = read(two_ranks)
    with h5py.File(part, "r") as f:
        got = f["frequency_hz"][()]
    mask = status != 0
    assert np.array_equal(got[mask], ref["frequency_hz"][mask], equal_nan=True)

    r = run(2, *args[:-1], "--resume")
    assert r.returncode == 0, r.stderr
    assert f"{N_POINTS - n_done} of {N_POINTS} points to solve on 2 rank(s)" in r.stderr
    assert out.exists() and not part.exists()
    resumed = read(out)
    assert_same(resumed, ref)
    assert resumed["attrs"]["wall_time_s"] > 0


def test_xarray_reads_the_parallel_archive(two_ranks):
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(two_ranks, engine="h5netcdf") as ds:
        f = ds.frequency_hz.sel(case="full", speed_rad_s=1000)
        assert f.dims == ("crank_angle_deg", "mode") and f.shape == (37, 4)
        assert ds.status.dims == ("crank_angle_deg", "speed_rad_s", "case")
        assert np.all(np.isfinite(f.values))
        # structure frequencies do not depend on speed
        s = ds.frequency_hz.sel(case="structure")
        assert np.array_equal(s.sel(speed_rad_s=0).values, s.sel(speed_rad_s=1000).values)


def test_bad_flag_reported_once_on_two_ranks(work):
    r = run(2, "run", str(work / "bw.toml"), "--angles=0:360:0", "--quiet")
    assert r.returncode == 2
    assert r.stderr.count("--angles: STEP must be > 0 (got '0:360:0')") == 1, r.stderr


def test_slepc_engine_one_and_two_ranks_agree(work):
    """The SLEPc engine (PETSc objects on COMM_SELF in every rank) gives the same sweep on 1
    and 2 ranks: eigenvalues and frequencies to 1e-12. The residuals are round-off-level
    numbers (~1e-13) that depend on the eigenvector the solver returns, so only their size
    is compared."""
    sweep = ["--elements", "6", "--solver", "slepc", "--angles", "0:360:20", "--quiet"]
    out = {}
    for n in (1, 2):
        out[n] = work / f"slepc{n}.h5"
        r = run(n, "run", str(work / "bw.toml"), "-o", str(out[n]), *sweep)
        assert r.returncode == 0, r.stderr
    a, b = read(out[1]), read(out[2])
    assert "slepc" in b["attrs"]["solver_settings"]
    for k in ("frequency_hz", "tracked_frequency_hz", "eigenvalue", "max_real"):
        x, y = a[k], b[k]
        assert np.array_equal(np.isnan(x), np.isnan(y)), k
        ok = ~np.isnan(y)
        assert np.all(np.abs(x[ok] - y[ok]) <= 1e-12 * np.abs(y[ok])), k
    assert np.array_equal(a["status"], b["status"])
    assert np.nanmax(a["residual"]) < 1e-10 and np.nanmax(b["residual"]) < 1e-10


def test_not_converged_exit_3_then_retry_failed_completes(work):
    """SLEPc limited to one iteration by PETSc options leaves points not converged (exit 3,
    messages in /errors); --resume --retry-failed without those options solves exactly them,
    and the archive then matches a clean run."""
    base = ["run", str(work / "bw.toml"), "--elements", "6", "--solver", "slepc", "--angles", "0:40:10", "--quiet"]
    out, ref = work / "nc.h5", work / "nc_ref.h5"
    r = run(2, *base, "-o", str(out), "-fkev_pep_max_it", "1", "-fkev_eps_max_it", "1")
    assert r.returncode == 3, r.stderr
    with h5py.File(out, "r") as f:
        status = f["status"][()]
        n_bad = int(np.count_nonzero(status == 2))
        assert n_bad > 0 and f["errors/index"].shape[0] == n_bad
        assert b"DIVERGED_ITS" in f["errors/message"][0]
    info = subprocess.run([sys.executable, "-m", "fkev_slepc", "info", str(out)], capture_output=True, text=True,
                          timeout=300, cwd=ROOT)
    assert f"not_converged {n_bad}" in info.stdout and "DIVERGED_ITS" in info.stdout
    r = run(2, *base, "-o", str(out), "--resume", "--retry-failed")
    assert r.returncode == 0, r.stderr
    r2 = run(2, *base, "-o", str(ref))
    assert r2.returncode == 0, r2.stderr
    with h5py.File(out, "r") as f, h5py.File(ref, "r") as g:
        assert np.all(f["status"][()] == g["status"][()]) and f["errors/index"].shape[0] == 0
        x, y = f["eigenvalue"][()], g["eigenvalue"][()]
        assert np.all(np.abs(x - y) <= 1e-12 * np.abs(y))
