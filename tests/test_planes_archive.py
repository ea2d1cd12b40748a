"""Both planes in one archive (issue 26, item 3): ``fkev run --plane both`` (the default when every link
gives its out-of-plane section data) keeps the in-plane sweep where every archive has it and adds the
out-of-plane sweep of the same grid as the product ``/planes/out`` (docs/archive.md,
fkev_slepc/sweep/plane_run.py): its frequencies are those of ``fkev point --plane out``, its in-plane
part is bit for bit an in-plane-only run, it resumes after an interruption, ``fkev verify`` flags a
flipped byte of it and ``--resume`` refuses it, xarray gets a ``plane`` dimension, 2 ranks write the
same numbers as 1."""

import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from clitools import BW, ROOT, digest, fkev
from test_reliability import _changed_byte
from fkev_slepc import load, open as open_archive
from fkev_slepc.archive import products as P
from fkev_slepc.cli import main
from fkev_slepc.scene import SceneError

FLAT = ROOT / "runs/flat-rod-slider-crank.toml"
ANGLES, RPM = (0.0, 90.0, 180.0), (1200.0, 1600.0)
GRID = ("--elements", "2", "--angles", "0,90,180", "--speeds-rpm", "1200,1600", "--modes", "3", "--solver", "dense")
ROOT_ROWS = (P.FREQUENCY, P.TRACKED, P.EIGENVALUE, P.RESIDUAL, P.DAMPING, P.MAX_REAL, P.STATUS_VAR, P.SIGNATURE)
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def cli(capsys, *args):
    """``fkev ARGS`` in this process: (exit code, stdout, stderr)."""
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The flat-rod scene (out-of-plane data on every link) run with the default plane and in plane only."""
    d = tmp_path_factory.mktemp("planes")
    scene = d / FLAT.name
    shutil.copy(FLAT, scene)
    both, inplane = d / "both.h5", d / "in.h5"
    for out, extra in ((both, ()), (inplane, ("--plane", "in"))):
        r = fkev("run", scene, *GRID, "-q", "-o", out, *extra)
        assert r.returncode == 0, r.stderr
    return scene, both, inplane


def test_default_is_both_planes_out_of_plane_equals_fkev_point_in_plane_bit_for_bit(runs, capsys):
    scene, both, inplane = runs
    res = open_archive(both)
    assert res.planes == ("in", "out") and res.plane == "in" and open_archive(inplane).planes == ("in",)
    out = res.on_plane("out")
    assert out.plane == "out" and out.attrs["n_free"] == 9 and out.mesh.n_free == 9 and res.attrs["n_free"] == 12
    assert np.all(out.status == 1)  # every out-of-plane point converged (ok)
    code, text, err = cli(capsys, "point", scene, "--elements", "2", "--angle", "90", "--speed-rpm", "1200", "--plane",
                          "out", "--modes", "3", "--solver", "dense", "--json")
    assert code == 0, err
    np.testing.assert_allclose(out.frequency()[1, 0, 0], json.loads(text)["frequency_hz"], rtol=1e-10)
    study = load(scene, elements=2)
    for a, angle in enumerate(ANGLES):
        for s, rpm in enumerate(RPM):
            pt = study.point(angle, rpm * np.pi / 30, "full", modes=3, solver="dense", plane="out")
            np.testing.assert_allclose(out.frequency()[a, s, 0], pt.frequency_hz, rtol=1e-10)
    with h5py.File(both) as f, h5py.File(inplane) as g:  # the in-plane sweep: identical, bit for bit
        for v in ROOT_ROWS + tuple(P.MESH_ARRAYS):
            assert f[v.path][()].tobytes() == g[v.path][()].tobytes(), v.path
        assert f.attrs["plane"] == "in" and P.PLANE_OUT.status not in g


def test_xarray_has_the_plane_dimension_and_info_lists_the_planes(runs, capsys):
    _scene, both, inplane = runs
    res = open_archive(both)
    ds = res.to_xarray()
    assert list(ds["plane"].values) == ["in", "out"] and ds["frequency_hz"].dims[0] == "plane"
    np.testing.assert_array_equal(ds["frequency_hz"].sel(plane="in").values, open_archive(inplane).frequency())
    np.testing.assert_array_equal(ds["frequency_hz"].sel(plane="out").values, res.on_plane("out").frequency())
    assert "plane" not in res.on_plane("out").to_xarray().dims and "plane" not in open_archive(inplane).to_xarray().dims
    import xarray as xr

    for group in ("planes/out", "planes/out/mesh", "planes/out/tracking"):  # each group opens on its own
        with xr.open_dataset(both, group=group, engine="h5netcdf") as g:
            assert g.sizes, group
    code, text, err = cli(capsys, "info", both)
    assert code == 0 and "planes      in (root group) and out (/planes/out" in text, err
    code, text, err = cli(capsys, "info", both, "--plane", "out")
    assert code == 0 and "9 free DOFs" in text and "; out of plane (bending out of the plane" in text, err
    code, text, err = cli(capsys, "export", both, "--plane", "out")
    assert code == 0 and f"{res.on_plane('out').frequency()[0, 0, 0, 0]!r}" in text.splitlines()[1], err
    code, text, err = cli(capsys, "export", inplane, "--plane", "out")
    assert code == 2 and "--plane: 'out' is not in" in err


def test_flipped_byte_of_the_out_of_plane_data_is_flagged_and_refused(runs, tmp_path, capsys):
    scene, both, _ = runs
    path = P.on_plane(P.FREQUENCY, "out").path
    bad = _changed_byte(both, tmp_path / "bad.h5", path)
    code, text, err = cli(capsys, "verify", bad)
    assert code != 0 and f"/{path}" in text + err
    r = fkev("run", scene, *GRID, "-q", "-o", bad, "--resume")
    assert r.returncode == 2 and "damaged, not resumed" in r.stderr


def test_interrupted_out_of_plane_product_resumes_to_the_uninterrupted_archive(runs, tmp_path, capsys):
    """An in-plane archive, then ``--resume`` with the default plane (both): the out-of-plane product
    paused at its first sync (FKEV_PAUSE_AFTER) and stopped by Ctrl-C; ``fkev info`` shows what is
    pending with the command, ``--resume`` finishes it with the numbers of an uninterrupted run."""
    from test_cli_interrupt import interrupt_when_paused, start

    scene, both, inplane = runs
    out = tmp_path / "r.h5"
    shutil.copy(inplane, out)
    proc = start([sys.executable, "-m", "fkev_slepc", "run", str(scene), *GRID, "-o", str(out), "--resume"],
                 {"FKEV_PAUSE_AFTER": "2"})
    code, stderr, written = interrupt_when_paused(proc)
    part = out.with_name(out.name + ".part")
    assert code == 130 and part.exists() and "Traceback" not in stderr, stderr
    with h5py.File(part) as f:
        done = int(np.count_nonzero(f[P.PLANE_OUT.status][()]))
    assert done == written == 2
    code, text, err = cli(capsys, "info", part)
    assert code == 0 and "out       4 of 6 points pending: fkev run" in text and "--resume" in text, err
    r = fkev("run", scene, *GRID, "-q", "-o", out, "--resume")
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f, h5py.File(both) as g:
        assert f.attrs["complete"] == 1
        for v in ROOT_ROWS:
            for p in {v.path, P.on_plane(v, "out").path}:
                assert np.array_equal(f[p][()], g[p][()], equal_nan=v.dtype != P.STATUS), p
    assert cli(capsys, "verify", out)[0] == 0
    before = digest(out)  # a resume of the finished two-plane archive: nothing to do, the file left alone
    r = fkev("run", scene, *GRID, "-o", out, "--resume")
    assert r.returncode == 0 and digest(out) == before and "(/planes/out) is complete; nothing to do" in r.stderr


@pytest.mark.mpi
def test_two_ranks_write_the_same_archive_as_one(runs, tmp_path, capsys):
    if shutil.which("mpiexec") is None:  # pragma: no cover - part of the stack
        pytest.skip("mpiexec not found")
    scene, both, _ = runs
    out = tmp_path / "two.h5"
    r = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-m", "fkev_slepc", "run", str(scene), *GRID, "-q",
                        "-o", str(out)], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "PYTHONPATH": str(ROOT), **MPI_ENV})
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f, h5py.File(both) as g:
        assert f.attrs["n_ranks"] == 2
        for v in ROOT_ROWS:
            for p in (v.path, P.on_plane(v, "out").path):
                x, y = f[p][()], g[p][()]
                if v.dtype in (P.STATUS, "i4"):
                    assert np.array_equal(x, y), p
                else:
                    np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-9 if v is P.SIGNATURE else 0, err_msg=p)
    assert cli(capsys, "verify", out)[0] == 0


def test_study_sweep_mirrors_the_cli_and_one_plane_archives_still_open(runs, tmp_path):
    scene, both, _ = runs
    study = load(scene, elements=2)
    res = study.sweep([90], [0.0, 125.0], ["full", "no_coriolis"], tmp_path / "s.h5", modes=2, solver="dense",
                      mode_shapes=True)
    assert res.planes == ("in", "out")  # the default: every link gives its out-of-plane section
    out = res.on_plane("out")
    # no Coriolis term out of plane (§19.6): no_coriolis is the full problem there, stored for both cases;
    # in plane it is another problem
    assert out.frequency_hz[..., 1, :].tobytes() == out.frequency_hz[..., 0, :].tobytes()
    assert np.all(out.status == 1) and res.frequency()[0, 1, 0].tobytes() != res.frequency()[0, 1, 1].tobytes()
    assert out.mode_shape(0, 1, 0).shape == (9, 2) and res.mode_shape(0, 1, 0).shape == (12, 2)
    np.testing.assert_allclose(out.frequency()[0, 1, 0],
                               study.point(90, 125.0, "full", modes=2, solver="dense", plane="out").frequency_hz,
                               rtol=1e-10)
    assert out.on_plane("in").frequency().tobytes() == res.frequency().tobytes()
    one = study.sweep([90], [125.0], ["full"], tmp_path / "o.h5", modes=2, solver="dense", plane="out")
    assert one.planes == ("out",) and open_archive(tmp_path / "o.h5", plane="out").plane == "out"
    with pytest.raises(SceneError, match="plane: must be one of in, out, both"):
        study.sweep([0], [0], ["full"], tmp_path / "x.h5", plane="sideways")
    assert load(BW).sweep([0], [0], ["structure"], tmp_path / "bw.h5", modes=2).planes == ("in",)  # no section data


def test_both_planes_refused_before_any_work_naming_the_flag(tmp_path):
    """``--plane both`` needs every link's out-of-plane section and no accuracy plan: one line naming
    the flag and the value given, exit 2, nothing written."""
    r = fkev("run", BW, "--plane", "both", "--angles", "0", "--speeds", "0", "-q", "-o", tmp_path / "x.h5")
    assert r.returncode == 2 and "--plane: out-of-plane analysis needs every link's" in r.stderr
    assert "(got 'both')" in r.stderr and not (tmp_path / "x.h5").exists()
    r = fkev("run", FLAT, "--plane", "both", "--rel-error", "0.01", "--angles", "0", "--speeds", "0", "-q", "-o",
             tmp_path / "y.h5")
    assert r.returncode == 2 and "--rel-error: the accuracy plan is in plane only" in r.stderr
