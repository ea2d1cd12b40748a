"""Sweep logic: indexing, distribution, continuation hints, failure capture, `fkev run` (tracking: test_tracking.py).

In-process on one rank (``COMM_SELF``) with the real model, the dense engine and real HDF5
files; the multi-rank behaviour is in test_mpi.py.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from builders import bahgat_willmert
from fkev_slepc.archive import store as A
from fkev_slepc.archive import writer as W
from fkev_slepc.cli import main
from fkev_slepc.sweep.progress import Progress
from fkev_slepc.sweep.session import default_output
from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.status import Status
from fkev_slepc.model.operators import Model
from fkev_slepc.sweep.runner import Sweep, SweepOptions, assign
from fkev_slepc.sweep.tracking import tracking_dofs

SCENE_TOML = "runs/bahgat-willmert-1976.toml"


# --------------------------------------------------------------------------- distribution
def test_grid_index_is_c_order_case_fastest():
    g = A.Grid(np.arange(4.0), np.arange(3.0), ("structure", "full"), 2)
    a, s, c = g.index(np.arange(g.n_points))
    assert g.n_points == 24
    assert list(zip(a[:4], s[:4], c[:4])) == [(0, 0, 0), (0, 0, 1), (0, 1, 0), (0, 1, 1)]
    assert (a[23], s[23], c[23]) == (3, 2, 1)


@pytest.mark.parametrize("size", [1, 2, 3, 5])
def test_assign_is_cyclic_complete_and_in_equal_rounds(size):
    todo = np.ones((73, 3, 6), bool)
    todo[10:20] = False  # already done (resume): not dealt out
    todo[30, 1, 2] = False  # partly done: still dealt out
    parts = [assign(todo, r, size) for r in range(size)]
    rounds = {n for _, n in parts}
    assert len(rounds) == 1  # every rank takes part in the same number of rounds
    got = np.sort(np.concatenate([p for p, _ in parts]))
    assert np.array_equal(got, np.setdiff1d(np.arange(73), np.arange(10, 20)))
    assert max(len(p) for p, _ in parts) - min(len(p) for p, _ in parts) <= 1
    assert rounds.pop() == -(-63 // size)
    assert np.array_equal(parts[0][0][:3], got[[0, size, 2 * size]])  # cyclic


# ------------------------------------------------------------------------- the sweep itself
class RecordingEngine(DenseEngine):
    """The dense engine, recording the hint of every problem solved; raises LinAlgError on
    request (fault injection for the failure path; a batch holding such a problem fails whole,
    before anything is recorded) or a KeyError (a bug)."""

    def __init__(self, fail_kind=None, bug=False):
        super().__init__()
        self.calls, self.fail_kind, self.bug = [], fail_kind, bug

    def solve(self, qep, n_modes=0, want_vectors=False, hint=None):
        self.calls.append((qep.kind, hint))
        if self.bug:
            raise KeyError("a bug")
        if qep.kind == self.fail_kind:
            raise np.linalg.LinAlgError("injected: QZ failed")
        return super().solve(qep, n_modes, want_vectors, hint)

    def solve_many(self, qeps, n_modes=0, want_vectors=False, hints=None):
        if self.bug:
            raise KeyError("a bug")
        if any(q.kind == self.fail_kind for q in qeps):  # the sweep retries point by point
            raise np.linalg.LinAlgError("injected: batch failed")
        self.calls.extend((q.kind, h) for q, h in zip(qeps, hints))
        return super().solve_many(qeps, n_modes, want_vectors, hints)


def _run(tmp_path, engine, angles=(0.0, 40.0, 80.0), speeds=(0.0, 500.0, 1000.0),
         cases=("structure", "full", "no_tangential"), mode_shapes=False):
    scene = bahgat_willmert(speeds=speeds, angles=angles, cases=cases)
    model = Model(scene)
    grid = A.Grid(np.array(angles), np.array(speeds), cases, 4)
    dofs = tracking_dofs(model.n_free, len(angles))
    part = A.partial_path(tmp_path / "s.h5")
    m = model.mechanism
    mesh = {"node_link": m.node_link, "node_s": m.node_s, "node_dofs": m.node_dofs,
            "elem_nodes": m.elem_nodes, "link_names": list(m.link_names)}
    A.create(part, grid, {"scene_toml": "x"}, mesh, model.n_free, mode_shapes, dofs)
    w = W.Writer(part, MPI.COMM_SELF, parallel=False)
    sweep = Sweep(model, grid, engine, w, SweepOptions(4, mode_shapes=mode_shapes, tracking_dofs=dofs),
                  np.full(grid.shape, np.nan))
    done = sweep.run(np.ones(grid.shape, bool), MPI.COMM_SELF)
    w.close()
    return scene, model, grid, part, done


def test_sweep_matches_direct_solves_and_solves_structure_once_per_angle(tmp_path):
    eng = RecordingEngine()
    scene, model, grid, part, done = _run(tmp_path, eng)
    assert done == grid.n_points
    # structure once per angle (3) + full and no_tangential at the 2 moving speeds (12); at
    # Ω = 0 (no crank acceleration) every case is the structure: copied, not solved again
    assert len(eng.calls) == 3 + 3 * 2 * 2
    with h5py.File(part, "r") as f:
        freq, lam, st = f["frequency_hz"][()], f["eigenvalue"][()], f["status"][()]
        assert f["tracking/signature"].shape == grid.shape + (model.n_free, 4)
    assert np.all(st != Status.PENDING.code)
    assert np.array_equal(freq[:, 0, 0], freq[:, 2, 0])  # structure copied to every speed
    assert np.array_equal(freq[:, 0, 1], freq[:, 0, 0]) and np.array_equal(freq[:, 0, 2], freq[:, 0, 0])
    for ia, js, jc in [(1, 2, 1), (2, 1, 2), (0, 0, 0), (1, 0, 1), (2, 0, 2)]:
        p = model.pieces(np.radians(grid.angles_deg[ia]))
        ref = postprocess(DenseEngine().solve(model.qep(p, grid.speeds[js], grid.cases[jc]), 4), 4)
        assert np.allclose(freq[ia, js, jc], ref.frequency_hz, rtol=1e-12)
        assert np.allclose(lam[ia, js, jc], ref.eigenvalue, rtol=1e-12)


def test_continuation_hint_is_previous_speed_then_structure(tmp_path):
    eng = RecordingEngine()
    _, _, grid, part, _ = _run(tmp_path, eng, angles=(30.0,))
    with h5py.File(part, "r") as f:
        lam1 = A.modulus(f["eigenvalue"][0, :, :, 0])
    hints = [h for _, h in eng.calls]
    # order at one angle: structure (no hint); speed 0: every case is the structure (copied);
    # speed j > 0: each case <- its own |λ1| at speed j-1
    assert len(hints) == 5 and hints[0] is None
    assert hints[1:3] == [lam1[0, 1], lam1[0, 2]] == [lam1[0, 0], lam1[0, 0]]
    assert hints[3:5] == [lam1[1, 1], lam1[1, 2]]


def test_solver_errors_mark_points_failed_and_the_sweep_goes_on(tmp_path):
    eng = RecordingEngine(fail_kind="general")  # the full case with speed > 0 is GENERAL
    _, _, grid, part, done = _run(tmp_path, eng)
    with h5py.File(part, "r") as f:
        st = f["status"][()]
        idx, msg = f["errors/index"][()], f["errors/message"][()]
    failed = st == Status.FAILED.code
    assert np.array_equal(np.argwhere(failed), [[a, s, 1] for a in range(3) for s in (1, 2)])
    assert np.all(st[~failed] != Status.PENDING.code) and done == grid.n_points
    assert sorted(map(tuple, idx)) == sorted(map(tuple, np.argwhere(failed)))
    assert all(m == b"LinAlgError: injected: QZ failed" for m in msg)


def test_other_exceptions_propagate(tmp_path):
    with pytest.raises(KeyError, match="a bug"):
        _run(tmp_path, RecordingEngine(bug=True))


def test_mode_shapes_are_archived_with_node_positions(tmp_path):
    _, model, grid, part, _ = _run(tmp_path, DenseEngine(), angles=(0.0, 90.0), speeds=(0.0, 800.0),
                                   cases=("full",), mode_shapes=True)
    with h5py.File(part, "r") as f:
        shape = f["modes/shape"][1, 1, 0]
        xy = f["modes/node_xy"][1]
    assert shape.shape == (model.n_free, 4)
    assert np.allclose(np.abs(shape).max(axis=0), 1.0)  # normalised: max |entry| = 1
    assert np.allclose(xy, model.node_positions(np.radians(90.0)))


# ------------------------------------------------------------------------------ fkev run
@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "bw.toml"
    path.write_text(open(SCENE_TOML).read())
    return path


def test_default_output_is_next_to_the_scene(scene_file):
    assert default_output(scene_file) == scene_file.parent / "out" / "bw.h5"


@pytest.mark.parametrize("flag, value, message", [
    ("--angles", "0:360:-5", "--angles: STEP must be > 0 (got '0:360:-5')"),
    ("--angles", "0:x:5", "--angles: 'x' is not a number (got '0:x:5')"),
    ("--angles", "10,20,10", "--angles: a value is listed twice (got '10,20,10')"),
    ("--speeds", "0,-5", "--speeds: speeds must be >= 0 rad/s (got '0,-5')"),
    ("--speeds", "1,nan", "--speeds: values must be finite (got '1,nan')"),
    ("--cases", "full,bogus", "--cases: unknown case 'bogus'"),
    ("--cases", "9", "--cases: case number must be 0..5"),
    ("--modes", "0", "--modes: must be >= 1 (got 0)"),
])
def test_bad_flags_exit_2_naming_flag_and_value(scene_file, capsys, flag, value, message):
    assert main(["run", str(scene_file), f"{flag}={value}", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (scene_file.parent / "out").exists()


def test_run_info_resume_in_process(scene_file, capsys):
    args = ["run", str(scene_file), "--angles", "0:20:10", "--speeds", "0,1000", "--solver", "dense"]
    assert main(args) == 0
    out = scene_file.parent / "out" / "bw.h5"
    assert out.exists() and not A.partial_path(out).exists()
    assert "wrote" in capsys.readouterr().out
    assert main(args + ["--resume"]) == 0
    assert "complete; nothing to do" in capsys.readouterr().err
    assert main(["run", str(scene_file), "--angles", "0:30:10", "--speeds", "0,1000", "--resume"]) == 2
    assert "--angles: archive has 0,10,20, this run 0,10,20,30" in capsys.readouterr().err
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "points      36 = 3 x 2 x 6 (all accounted for)" in text
    assert "crank angle 0, 10, 20 deg" in text and "speed       0, 1000 rad/s" in text


def test_progress_line():
    assert Progress.line(50, 200, 10.0) == "fkev run: 50/200 points (25%), 5.0 points/s, ETA 00:00:30"
