"""``fkev run``'s output (issue 12, Deliver 1): an existing archive is never replaced without
--force, --retry-failed continues the archive, and every path problem is one line naming the
path, exit 2, before anything is solved, leaving every existing file bit-identical."""

import h5py
import numpy as np
import pytest

from clitools import BW, SMALL, digest, fkev, small_archive


@pytest.fixture
def archive(tmp_path):
    return small_archive(tmp_path / "bw.h5")


def listing(d):
    return sorted((p.name, digest(p)) for p in d.iterdir() if p.is_file())


def test_existing_archive_is_not_replaced_without_force(archive):
    before = listing(archive.parent)
    r = fkev("run", BW, "--angles", "90", "--speeds", "0", "--cases", "full", "-o", archive)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == (f"fkev run: -o {archive}: an archive already exists (2 points, 2 done); continue it with "
                        "--resume (with --retry-failed to solve its failed points again) or replace it with --force\n")
    assert listing(archive.parent) == before
    r = fkev("run", BW, "--angles", "90", "--speeds", "0", "--cases", "full", "-q", "-o", archive, "--force")
    assert r.returncode == 0, r.stderr
    with h5py.File(archive) as f:
        assert f["crank_angle_deg"][()].tolist() == [90.0] and list(f["case"].asstr()[()]) == ["full"]


def test_unfinished_run_is_not_started_over_without_force(archive):
    part = archive.with_name(archive.name + ".part")
    part.write_bytes(archive.read_bytes())  # stands for an interrupted run's file
    archive.unlink()
    before = listing(part.parent)
    r = fkev("run", BW, *SMALL, "-o", archive)
    assert r.returncode == 2
    assert r.stderr.strip() == (f"fkev run: -o {archive}: an unfinished run exists (bw.h5.part, 2 points, 2 done); "
                                "continue it with --resume or start over with --force")
    assert listing(part.parent) == before


def test_retry_failed_continues_the_archive_instead_of_solving_everything(archive):
    """--retry-failed without --resume used to re-solve every point; now it continues."""
    before = digest(archive)
    r = fkev("run", BW, *SMALL, "-o", archive, "--retry-failed")
    assert r.returncode == 0, r.stderr
    assert r.stderr.strip() == f"fkev run: {archive} is complete; nothing to do"
    assert digest(archive) == before


@pytest.mark.parametrize("target,reason", [
    ("/proc/fkev.h5", "-o /proc/fkev.h5: directory /proc is not writable (No such file or directory)"),
    ("{d}/missing/out.h5", "-o {d}/missing/out.h5: directory {d}/missing does not exist (create it first)"),
    ("{d}", "-o {d}: is a directory (give a file name ending in .h5)"),
    ("{d}/fig.png", "-o {d}/fig.png: unsupported format '.png' (use .h5)"),
])
def test_bad_output_paths_are_one_line_before_solving(archive, target, reason):
    d = archive.parent
    before = listing(d)
    r = fkev("run", BW, *SMALL, "-o", target.format(d=d))
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.splitlines() == [f"fkev run: {reason.format(d=d)}"]
    assert listing(d) == before and not (d / "missing").exists()


def test_bad_output_path_under_mpirun_is_one_line(archive):
    import os

    env = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", **{k: v for k, v in os.environ.items() if k == "PATH"}}
    r = fkev("run", BW, *SMALL, "-o", "/proc/x.h5", "--np", "2", env_extra=env)
    assert r.returncode == 2
    assert r.stderr.strip() == "fkev run: -o /proc/x.h5: directory /proc is not writable (No such file or directory)"
    assert "MPI_ABORT" not in r.stderr


def test_default_output_directory_is_created(tmp_path):
    scene = tmp_path / "bw.toml"
    scene.write_text(BW.read_text())
    r = fkev("run", scene, *SMALL, "-q")
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "out" / "bw.h5") as f:
        assert np.all(f["status"][()] == 1)
