"""The HDF5 archive contract: layout, xarray access, serial writer, resume checks, finalize.

Real files with real data: every test writes an archive with h5py and reads it back.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from fkev_slepc.archive import store as A
from fkev_slepc.archive import writer as W
from fkev_slepc.status import Status

GRID = A.Grid(np.array([0.0, 90.0, 180.0, 270.0, 360.0]), np.array([0.0, 500.0, 1000.0]),
              ("structure", "full"), 3)
MESH = dict(node_link=np.array([0, 0, 1, 1]), node_s=np.array([0.0, 0.1, 0.0, 0.2]),
            node_dofs=np.array([[-1, -1, 0], [1, 2, 3], [-1, -1, 4], [5, 6, 7]]),
            elem_nodes=np.array([[0, 1], [2, 3]]), link_names=["crank", "coupler"])
N_FREE = 8
SCENE = 'title = "t"\n# é\n'


def values(ia):
    """Distinct, recognisable data for crank angle ``ia``: f = 1000 a + 100 s + 10 c + m."""
    ns, nc, nm = len(GRID.speeds), len(GRID.cases), GRID.n_modes
    s, c, m = np.meshgrid(np.arange(ns), np.arange(nc), np.arange(1, nm + 1), indexing="ij")
    f = 1000.0 * ia + 100 * s + 10 * c + m
    return f, -0.01 * f + 2j * np.pi * f


def block(ia, mask=None, status=Status.OK, failed_at=()):
    f, lam = values(ia)
    ns, nc = GRID.shape[1:]
    mask = np.ones((ns, nc), bool) if mask is None else mask
    st = np.full((ns, nc), Status(status).code, np.uint8)
    errors = []
    for js, jc in failed_at:
        st[js, jc] = Status.FAILED.code
        errors.append(((ia, js, jc), Status.FAILED.code, f"LinAlgError: point {ia},{js},{jc} ∞"))
    sig = np.broadcast_to(np.eye(N_FREE, GRID.n_modes), (ns, nc, N_FREE, GRID.n_modes)) * (1 + ia)
    data = {"frequency_hz": f, "eigenvalue": lam, "residual": np.full(f.shape, 1e-15),
            "max_real": -0.01 * f[..., 0], "tracking/signature": sig,
            "modes/shape": sig + 1j}
    xy = np.full((len(MESH["node_link"]), 2), float(ia))
    return W.Block(ia, mask, data, st, errors, xy)


def new_archive(tmp_path, mode_shapes=True):
    part = A.partial_path(tmp_path / "a.h5")
    attrs = dict(scene_toml=SCENE, elements=np.array([1, 1], "i4"), n_free=N_FREE, mode_shapes=int(mode_shapes),
                 solver_settings={"engine": "dense"}, imag_tol=1e-9, damping_tol=1e-9)
    A.create(part, GRID, attrs, MESH, N_FREE, mode_shapes, np.arange(N_FREE))
    return part


def write_all(part, comm=MPI.COMM_SELF):
    w = W.Writer(part, comm, parallel=False)
    for ia in range(GRID.shape[0]):
        w.write_block(block(ia, failed_at=[(1, 1)] if ia == 2 else ()))
        if w.end_round():
            w.sync()
    w.close()


def test_partial_name_and_fresh_archive_is_pending_nan(tmp_path):
    part = new_archive(tmp_path)
    assert part.name == "a.h5.part"
    with h5py.File(part, "r") as f:
        assert f["status"].shape == GRID.shape and np.all(f["status"][()] == 0)
        assert np.all(np.isnan(f["frequency_hz"][()])) and f["frequency_hz"].shape == GRID.shape + (3,)
        assert np.all(np.isnan(f["eigenvalue"][()].real))
        assert h5py.check_enum_dtype(f["status"].dtype) == {s.value: s.code for s in Status}
        assert f.attrs["format"] == "fkev-archive" and f.attrs["format_version"] == 1
        assert f.attrs["complete"] == 0
        for name in ("frequency_hz", "tracked_frequency_hz", "eigenvalue", "residual", "status", "max_real"):
            assert f[name].attrs["units"] and f[name].attrs["long_name"], name
            dims = [f[name].dims[i][0].name for i in range(f[name].ndim)]
            assert dims == ["/crank_angle_deg", "/speed_rad_s", "/case", "/mode"][: f[name].ndim], name
        assert [c.decode() for c in f["case"][()]] == list(GRID.cases)
        assert list(f["mode"][()]) == [1, 2, 3]
        assert np.array_equal(f["mesh/node_dofs"][()], MESH["node_dofs"])


def test_serial_writer_round_trip_and_errors(tmp_path):
    part = new_archive(tmp_path)
    write_all(part)
    with h5py.File(part, "r") as f:
        for ia in range(GRID.shape[0]):
            fr, lam = values(ia)
            assert np.array_equal(f["frequency_hz"][ia], fr)
            assert np.array_equal(f["eigenvalue"][ia], lam)
            assert np.array_equal(f["modes/node_xy"][ia], np.full((4, 2), float(ia)))
        st = f["status"][()]
        assert st[2, 1, 1] == Status.FAILED.code and np.count_nonzero(st == Status.OK.code) == GRID.n_points - 1
        assert f["errors/index"][()].tolist() == [[2, 1, 1]]
        assert f["errors/message"][0].decode() == "LinAlgError: point 2,1,1 ∞"


def test_status_is_written_only_at_sync(tmp_path):
    """A point counts as done once a sync has put its data and then its status on disk."""
    part = new_archive(tmp_path)
    w = W.Writer(part, MPI.COMM_SELF, parallel=False)
    w.write_block(block(0))
    with h5py.File(part, "r") as f:
        assert np.all(f["status"][0] == Status.PENDING.code)
    assert w.sync() == 6
    with h5py.File(part, "r") as f:
        assert np.all(f["status"][0] == Status.OK.code) and np.all(f["status"][1:] == Status.PENDING.code)
    w.close()


def test_partial_block_writes_only_its_points(tmp_path):
    part = new_archive(tmp_path)
    mask = np.zeros(GRID.shape[1:], bool)
    mask[1, 0] = mask[2, 1] = True
    w = W.Writer(part, MPI.COMM_SELF, parallel=False)
    w.write_block(block(3, mask))
    w.close()
    f, _ = values(3)
    with h5py.File(part, "r") as h:
        assert np.array_equal(np.argwhere(h["status"][3] == Status.OK.code), [[1, 0], [2, 1]])
        got = h["frequency_hz"][3]
        assert np.array_equal(got[mask], f[mask]) and np.all(np.isnan(got[~mask]))


def test_xarray_opens_with_labels(tmp_path):
    xr = pytest.importorskip("xarray")
    part = new_archive(tmp_path)
    write_all(part)
    out = A.finalize(part, tmp_path / "a.h5", {"n_ranks": 1})
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert set(ds.frequency_hz.dims) == {"crank_angle_deg", "speed_rad_s", "case", "mode"}
        sel = ds.frequency_hz.sel(case="full", speed_rad_s=1000)
        assert sel.dims == ("crank_angle_deg", "mode")
        expected = np.stack([values(ia)[0][2, 1] for ia in range(5)])
        assert np.array_equal(sel.values, expected)
        assert ds.eigenvalue.dtype == np.complex128
        assert ds.frequency_hz.attrs["units"] == "Hz"
        assert float(ds.frequency_hz.sel(crank_angle_deg=90.0, speed_rad_s=500, case="structure", mode=2)) == 1102.0


def test_finalize_keeps_newest_error_of_points_still_failed(tmp_path):
    part = new_archive(tmp_path)
    write_all(part)  # (2, 1, 1) failed
    w = W.Writer(part, MPI.COMM_SELF, parallel=False)  # a retry: (2,1,1) now ok, (4,0,1) fails twice
    mask = np.zeros(GRID.shape[1:], bool)
    mask[1, 1] = True
    w.write_block(block(2, mask))
    mask2 = np.zeros(GRID.shape[1:], bool)
    mask2[0, 1] = True
    w.write_block(block(4, mask2, failed_at=[(0, 1)]))
    w.sync()
    b = block(4, mask2, failed_at=[(0, 1)])
    b.errors[0] = ((4, 0, 1), Status.FAILED.code, "second try")
    w.write_block(b)
    w.close()
    out = A.finalize(part, tmp_path / "a.h5", {}, add_wall_time=2.5)
    assert not part.exists() and out.exists()
    with h5py.File(out, "r") as f:
        assert f["errors/index"][()].tolist() == [[4, 0, 1]]
        assert f["errors/message"][0] == b"second try"
        assert f.attrs["complete"] == 1 and f.attrs["wall_time_s"] == 2.5


def test_read_state_and_todo(tmp_path):
    part = new_archive(tmp_path)
    w = W.Writer(part, MPI.COMM_SELF, parallel=False)
    b = block(0, failed_at=[(0, 0)])
    b.status[2, 1] = Status.NOT_CONVERGED.code
    b.status[1, 1] = Status.UNSTABLE.code
    w.write_block(b)
    w.close()
    state = A.read_state(part)
    assert state.todo().sum() == GRID.n_points - 6
    again = state.todo(retry_failed=True)
    assert again.sum() == GRID.n_points - 4 and again[0, 0, 0] and again[0, 2, 1] and not again[0, 1, 1]
    _, lam = values(0)
    assert state.lam1[0, 0, 1] == A.modulus(lam[0, 1, 0]) == np.sqrt(lam[0, 1, 0].real ** 2 + lam[0, 1, 0].imag ** 2)
    assert np.isnan(state.lam1[0, 0, 0]) and np.isnan(state.lam1[0, 2, 1]) and np.all(np.isnan(state.lam1[1:]))
    assert state.lam1[0, 1, 1] > 0  # unstable points converged: their |λ1| is a hint


def test_resume_refuses_changed_scene_and_grid(tmp_path):
    part = new_archive(tmp_path)
    out = tmp_path / "a.h5"
    expect = dict(scene_toml=SCENE, elements=np.array([1, 1]), n_free=N_FREE, mode_shapes=1)
    assert A.open_for_resume(out, GRID, expect) == part
    with pytest.raises(A.ArchiveMismatch, match="scene changed since the archive was written: x: added to the scene"):
        A.open_for_resume(out, GRID, dict(expect, scene_toml=SCENE + "x = 1\n"))
    assert A.open_for_resume(out, GRID, dict(expect, scene_toml="# a comment\n" + SCENE)) == part  # parsed, not text
    with pytest.raises(A.ArchiveMismatch, match="elements: archive has 1,1, this run 2,1"):
        A.open_for_resume(out, GRID, dict(expect, elements=np.array([2, 1])))
    other = A.Grid(GRID.angles_deg[:4], GRID.speeds, GRID.cases, 3)
    with pytest.raises(A.ArchiveMismatch, match="angles_deg: archive has 0,90,180,270,360, this run 0,90,180,270"):
        A.open_for_resume(out, other, expect)
    with pytest.raises(A.ArchiveMismatch, match="cases: archive has structure,full, this run full"):
        A.open_for_resume(out, A.Grid(GRID.angles_deg, GRID.speeds, ("full",), 3), expect)
    with pytest.raises(FileNotFoundError, match="nothing to resume"):
        A.open_for_resume(tmp_path / "b.h5", GRID, expect)


def test_finished_archive_is_copied_back_to_partial_for_more_points(tmp_path):
    part = new_archive(tmp_path)
    out = A.finalize(part, tmp_path / "a.h5", {})
    expect = dict(scene_toml=SCENE, elements=np.array([1, 1]), n_free=N_FREE, mode_shapes=1)
    assert A.open_for_resume(out, GRID, expect) == out
    before = out.read_bytes()
    assert A.reopen_finished(out) == part and part.exists()
    assert out.read_bytes() == before  # untouched until the resumed run completes (issue 10)


def test_clip_cuts_utf8_at_a_character_boundary():
    msg = "é" * 2000
    raw = W._clip(msg)
    assert len(raw) <= A.MESSAGE_BYTES and raw.endswith(b"...")
    assert raw[:-3].decode("utf-8") == "é" * ((A.MESSAGE_BYTES - 3) // 2)
    assert W._clip("short") == b"short"


def test_status_counts():
    st = np.array([[0, 1, 1], [3, 5, 1]], np.uint8)
    assert A.status_counts(st) == {"pending": 1, "ok": 3, "not_converged": 0, "unstable": 1,
                                   "divergent": 0, "failed": 1}
