"""Ctrl-C during ``fkev run`` (issue 12, Deliver 1): every rank stops cleanly, the partial
archive stays resumable, the ``--resume`` command is printed, and resuming gives the archive an
uninterrupted run gives.

No test races the sweep: the interrupted run has ``FKEV_PAUSE_AFTER`` set, so rank 0 stops at
its first sync with points written and points left (:mod:`fkev_slepc.sweep.interrupt`), says so
on stderr and waits there for the signal; the archive then holds exactly the points it said."""

import os
import shlex
import signal
import subprocess
import re
import sys

import h5py
import numpy as np
import pytest

from clitools import BW, ROOT, fkev
from fkev_slepc.sweep.interrupt import PAUSE_VARIABLE, PAUSED

pytestmark = pytest.mark.slow
# 36 angles x 3 speeds x 2 cases: 18 rounds on 2 ranks, so points are left at the first sync
GRID = ("--angles", "0:350:10", "--cases", "structure,full", "--solver", "dense", "--modes", "3")
PAUSE = {PAUSE_VARIABLE: "6"}  # pause once one angle's 6 points are written (the first sync)
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}  # only so that the tests run as root on 2 cores


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.h5"
    r = fkev("run", BW, *GRID, "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    return out


def start(argv, env_extra=None):
    """Start an interrupted-to-be run: paused at its first sync (``PAUSE``)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), **PAUSE, **(env_extra or {})}
    return subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def interrupt_when_paused(proc, pid=None, sig=signal.SIGINT):
    """Read stderr until rank 0 says it is paused (points written, points left), signal
    ``pid`` (default the process started). Returns (exit code, stderr, points written)."""
    lines = []
    while True:
        line = proc.stderr.readline()
        assert line, "the run ended without pausing: " + "".join(lines)
        lines.append(line)
        if line.startswith(PAUSED):
            break
    written = int(re.search(r"after (\d+) of (\d+) points", line).group(1))
    assert proc.poll() is None  # paused: it cannot have finished
    os.kill(pid or proc.pid, sig)
    out, err = proc.communicate(timeout=300)
    return proc.returncode, "".join(lines) + err, written


def resume_command(stderr: str) -> list[str]:
    line = next(ln for ln in stderr.splitlines() if "continue with: " in ln)
    cmd = shlex.split(line.split("continue with: ", 1)[1])
    assert cmd[0] == "fkev" and "--resume" in cmd
    return cmd[1:]


def assert_same_archive(got, ref, rtol=0.0):
    """Bit for bit on one rank; on several ranks to ``rtol`` (LAPACK on another process may
    round differently in the last bits, as between any 1- and 2-rank runs: tests/test_mpi.py)."""
    with h5py.File(got) as f, h5py.File(ref) as g:
        assert f.attrs["complete"] == 1
        assert np.array_equal(f["status"][()], g["status"][()])
        for name in ("frequency_hz", "tracked_frequency_hz", "eigenvalue"):
            x, y = f[name][()], g[name][()]
            assert np.array_equal(np.isnan(x), np.isnan(y))
            assert np.all(np.abs(x - y)[~np.isnan(y)] <= rtol * np.abs(y)[~np.isnan(y)]), name


def points_written(part) -> int:
    with h5py.File(part) as f:
        assert f.attrs["complete"] == 0
        done = int(np.count_nonzero(f["status"][()]))
        assert 0 < done < f["status"].size  # stopped early: something is left for --resume
    return done


def check_interrupted(code, stderr, out, written):
    part = out.with_name(out.name + ".part")
    assert code == 130, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr
    assert part.exists() and not out.exists()
    assert points_written(part) == written  # stopped at the sync it paused at
    return resume_command(stderr)


def test_ctrl_c_one_process_then_resume_equals_uninterrupted(tmp_path, reference):
    out = tmp_path / "bw.h5"
    proc = start([sys.executable, "-m", "fkev_slepc", "run", str(BW), *GRID, "-o", str(out)])
    code, stderr, written = interrupt_when_paused(proc)
    args = check_interrupted(code, stderr, out, written)
    assert "interrupted by Ctrl-C (SIGINT)" in stderr
    r = fkev(*args)
    assert r.returncode == 0, r.stderr
    assert_same_archive(out, reference)


def test_ctrl_c_with_np_2_stops_both_ranks_cleanly(tmp_path, reference):
    """``fkev run --np 2``: Ctrl-C on the launcher reaches both ranks (as SIGUSR1 through
    mpiexec); they stop at the same sync, the launcher exits 130 with the resume command."""
    out = tmp_path / "bw.h5"
    proc = start([sys.executable, "-m", "fkev_slepc", "run", str(BW), *GRID, "-o", str(out), "--np", "2"],
                 MPI_ENV)
    code, stderr, written = interrupt_when_paused(proc)
    args = check_interrupted(code, stderr, out, written)
    assert "interrupted by Ctrl-C or SIGTERM (passed on by fkev run --np as SIGUSR1)" in stderr  # not "by SIGUSR1"
    assert args[-2:] == ["--np", "2"]  # resumes on 2 ranks too
    r = fkev(*args, env_extra=MPI_ENV)
    assert r.returncode == 0, r.stderr
    assert_same_archive(out, reference, rtol=1e-12)


def test_sigint_under_mpirun_keeps_the_archive_resumable(tmp_path, reference):
    """Under a bare ``mpirun -n 2`` Open MPI turns Ctrl-C into SIGTERM for the ranks and kills
    them a second later; rank 0 prints the resume command at once and the archive (consistent
    as after kill -9) resumes to the uninterrupted result."""
    out = tmp_path / "bw.h5"
    proc = start(["mpirun", "-n", "2", sys.executable, "-m", "fkev_slepc", "run", str(BW), *GRID, "-o", str(out)],
                 MPI_ENV)
    code, stderr, written = interrupt_when_paused(proc)
    assert code != 0 and "continue with: fkev run" in stderr
    part = out.with_name(out.name + ".part")
    assert part.exists() and not out.exists()
    assert points_written(part) == written
    r = fkev(*resume_command(stderr))
    assert r.returncode == 0, r.stderr
    assert_same_archive(out, reference, rtol=1e-12)
