"""``fkev run --np N`` starts the ranks itself, on more ranks than CPUs too (issue 12, Deliver 4)."""

import os

import h5py
import numpy as np
import pytest

from clitools import BW, fkev

GRID = ("--angles", "0:40:10", "--speeds", "0,1000", "--cases", "structure,full", "--solver", "dense", "-q")
ROOT_VARS = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}


@pytest.fixture
def no_launcher_env(monkeypatch):
    """No Open MPI setting in the environment (no oversubscription variable either)."""
    for k in list(os.environ):
        if k.startswith(("OMPI_", "PMIX_", "OPAL_")):
            monkeypatch.delenv(k)
    return monkeypatch


def test_np_more_ranks_than_cpus_equals_one_rank(tmp_path, no_launcher_env):
    n = len(os.sched_getaffinity(0)) + 1  # Open MPI alone would refuse: "not enough slots"
    for k, v in ROOT_VARS.items():  # only so that the test can run as root (never set by fkev)
        no_launcher_env.setenv(k, v)
    one, many = tmp_path / "one.h5", tmp_path / "many.h5"
    assert fkev("run", BW, *GRID, "-o", one).returncode == 0
    r = fkev("run", BW, *GRID, "-o", many, "--np", n)
    assert r.returncode == 0, r.stderr
    with h5py.File(one) as f, h5py.File(many) as g:
        assert g.attrs["n_ranks"] == n and f.attrs["n_ranks"] == 1
        assert np.array_equal(f["status"][()], g["status"][()])
        # the suite's rule across rank counts (tests/test_mpi.py): 1e-12 relative, NaN where NaN
        np.testing.assert_allclose(g["frequency_hz"][()], f["frequency_hz"][()], rtol=1e-12, atol=0)


@pytest.mark.skipif(os.geteuid() != 0, reason="Open MPI's root check applies to root only")
def test_np_as_root_without_the_open_mpi_variables_says_so(tmp_path, no_launcher_env):
    r = fkev("run", BW, *GRID, "-o", tmp_path / "x.h5", "--np", "2")
    assert r.returncode == 2
    assert r.stderr.strip() == ("fkev run: --np: Open MPI refuses to run as root; to allow it, export "
                                "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 (see docs/cli.md)")
    assert not list(tmp_path.iterdir())


def test_np_zero_is_refused(tmp_path):
    r = fkev("run", BW, *GRID, "-o", tmp_path / "x.h5", "--np", "0")
    assert r.returncode == 2 and r.stderr.strip() == "fkev run: --np: must be >= 1 (got 0)"
