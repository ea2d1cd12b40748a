"""``fkev run --plane both`` / ``Study.sweep(plane="both")``: both planes of a linkage in one archive.

1. **In-plane sweep** (the root product, :func:`fkev_slepc.sweep.session.run_sweep`): the archive as
   ``fkev run --plane in`` writes it, bit for bit (the out-of-plane sweep neither reads nor changes it).
2. **Out-of-plane sweep** (``/planes/out``, :data:`fkev_slepc.archive.products.PLANE_OUT`, docs/theory.md
   §19): the same crank angles, speeds, cases and modes on the out-of-plane model, added through
   :mod:`fkev_slepc.sweep.product_run` like every product of a finished sweep: one crank angle per unit of
   work (its (speed, case) points solved by :class:`~fkev_slepc.sweep.runner.Sweep` with the same
   continuation hints, so results do not depend on the rank count), units dealt to the MPI ranks,
   resumable (``resume``: only pending points; ``retry_failed``: failed ones too), checksummed on finish.
   The cases keep their Table 3.1 names; out of plane the Coriolis and tangential terms are identically
   zero (``absent_terms`` of :data:`fkev_slepc.model.plane.OUT`), so ``no_coriolis`` and ``no_tangential``
   pose the same problem as ``full`` there: each problem is solved once per point and its results are
   stored under every case that poses it (:func:`_solved_once`).
3. **Tracking** (collective): modes followed along crank angle and along speed by MAC, as in plane
   (:func:`fkev_slepc.sweep.tracking_angles.track_archive`: extra angles solved where the MAC is
   ambiguous, in ``/planes/out/tracking/refined``; a line left ambiguous stays in sorted order, flagged).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.writer import Block
from fkev_slepc.status import RETRYABLE
from fkev_slepc.scene.validity import OUT_OF_PLANE_THESIS, in_plane_only

PLANE_CHOICES = ("in", "out", "both")


@dataclass(frozen=True)
class PlaneOutcome:
    """What the out-of-plane product holds after the run (the same on every rank)."""

    output: Path
    n_points: int
    n_solved: int  # points solved by this run
    counts: dict  # points of each status, by status name
    exit_code: int
    already_complete: bool = False  # resume of a finished two-plane archive: nothing was solved


def both_planes_possible(scene) -> bool:
    """Whether every link of ``scene`` gives its out-of-plane section data (the default of ``--plane``
    is then ``both``, else ``in``)."""
    from fkev_slepc.model.mechanism import build_mechanism
    from fkev_slepc.model.out_of_plane import has_section

    return has_section(build_mechanism(scene))


def default_plane(scene, plane: str | None, rel_error: float | None = None) -> str:
    """``plane`` as asked, or the default: ``both`` when the scene gives every link's out-of-plane
    section data and no accuracy plan is asked (``rel_error``: in plane only) nor the in-plane-only
    Timoshenko element (scene/validity.py), else ``in``."""
    if plane is not None:
        return plane
    planned = rel_error is not None or scene.analysis.rel_error is not None
    in_only = in_plane_only(scene, OUT_OF_PLANE_THESIS) is not None
    return "both" if not planned and not in_only and both_planes_possible(scene) else "in"


def run_out_of_plane(request, comm=None, notify=None, progress: bool = False, model=None) -> PlaneOutcome:
    """Collective over ``comm``: add (or resume) the out-of-plane sweep of the finished in-plane archive
    ``request.output`` (a :class:`~fkev_slepc.sweep.session.SweepRequest` whose in-plane sweep ran).
    ``model``: the out-of-plane model of ``request.scene`` for its cases (a Study: its pool's; default a new one).
    Raises :class:`~fkev_slepc.sweep.interrupt.SweepInterrupted` on every rank after Ctrl-C/SIGTERM."""
    from fkev_slepc.archive.products import Grid
    from fkev_slepc.archive.store import status_counts
    from fkev_slepc.model.operators import Model
    from fkev_slepc.solve.engines import make_engine
    from fkev_slepc.solve.thresholds import SolveSettings
    from fkev_slepc.sweep.parallel import local
    from fkev_slepc.sweep.product_run import finish, open_product, solve_pending
    from fkev_slepc.sweep.progress import Progress
    from fkev_slepc.sweep.runner import Sweep, SweepOptions
    from fkev_slepc.sweep.session import exit_code
    from fkev_slepc.sweep.tracking import tracking_dofs
    from fkev_slepc.sweep.tracking_angles import track_archive
    from fkev_slepc.sweep.units import pending

    comm = local(comm)
    t0 = time.monotonic()
    scene, out = request.scene, Path(request.output)
    an = scene.analysis
    grid = Grid(np.asarray(an.crank_angles_deg, float), np.asarray(scene.driver.speeds, float), tuple(an.cases),
                int(an.modes))
    model = Model(scene, cases=grid.cases, plane="out") if model is None else model
    engine = make_engine(request.solver or scene.solver.method, model.n_free, scene.solver.petsc,
                         settings=SolveSettings.from_scene(scene))
    track = tracking_dofs(model.n_free, len(grid.angles_deg), len(grid.speeds))
    values, needs = {P.on_plane(P.find(P.NODE), "out").path: np.arange(model.mechanism.node_link.size)}, {"mechanism"}
    if track is not None:
        needs.add("signatures")
        values[P.on_plane(P.TRACKING[0], "out").path] = np.asarray(track, "i4")
    if an.mode_shapes:
        needs.add("shapes")
        values[P.on_plane(P.MODES[0], "out").path] = np.arange(model.n_free)
    settings = {"n_free": model.n_free, "mode_shapes": int(an.mode_shapes), "n_signature_dofs": 0 if track is None
                else len(track), "solver_settings": json.dumps(engine.settings(), sort_keys=True, default=str)}
    node_dofs = P.on_plane(P.NODE_DOFS, "out").path
    retry = RETRYABLE if request.retry_failed else ()
    have = comm.bcast(_finished(out, settings, retry) if comm.rank == 0 and (request.resume or request.retry_failed)
                      else None, root=0)
    if have is not None:  # a resume of a finished two-plane archive: nothing to solve, the file left alone
        engine.close()
        if notify is not None and comm.rank == 0:
            notify(f"{out}: the out-of-plane sweep (/{P.PLANE_OUT.name}) is complete; nothing to do")
        return PlaneOutcome(out, grid.n_points, 0, status_counts(have), exit_code(have), already_complete=True)
    try:
        part, status = open_product(out, P.PLANE_OUT, values, settings, request.resume or request.retry_failed, comm,
                                    data={node_dofs: np.asarray(model.mechanism.node_dofs)}, needs=needs,
                                    same=lambda p: _same(p, settings))
        todo = pending(status, retry)
        lam1 = comm.bcast(_hints(part) if comm.rank == 0 else None, root=0)
        sweep = Sweep(model, grid, engine, None, SweepOptions(grid.n_modes, an.imag_tol, an.damping_tol,
                                                               an.mode_shapes, track), lam1)
        bar = Progress(int(todo.sum()), label="fkev run (out of plane)") if progress and comm.rank == 0 else None
        if progress and notify is not None and comm.rank == 0:
            notify(f"out of plane: {int(todo.sum())} of {todo.size} points to solve on {comm.size} rank(s) "
                   f"-> {part} (/{P.PLANE_OUT.name})")
        try:
            twins = _twins(model, grid.cases)
            n_solved = solve_pending(part, out, P.PLANE_OUT, todo, lambda unit, mask: _moved(_solved_once(
                sweep, unit[0], mask, twins)), comm, n_unit_axes=1, notify=notify, label="points", progress=bar)
        finally:
            if bar is not None:
                bar.close()
        track_archive(part, sweep, comm, plane="out")  # may solve extra angles (collective)
    finally:
        engine.close()
    final = comm.bcast(status_counts(_status(part)) if comm.rank == 0 else None, root=0)
    codes = comm.bcast(_status(part) if comm.rank == 0 else None, root=0)
    finish(part, out, request.command_line, t0, comm)
    return PlaneOutcome(out, grid.n_points, n_solved, final, exit_code(codes))


def _twins(model, cases) -> np.ndarray:
    """For each case, the first case of ``cases`` that poses the same problem on ``model`` (the same
    term flags out of plane, Table 3.1 with §19.6); itself when none before it does."""
    terms = [model.case_terms(c) for c in cases]
    return np.array([terms.index(t) for t in terms], dtype=int)


def _solved_once(sweep, ia: int, mask: np.ndarray, twins: np.ndarray) -> Block:
    """The points ``mask`` (speed, case) of crank angle ``ia``: each problem solved once, on the first case
    that poses it (:func:`_twins`), and copied to the other cases of ``mask`` that pose it."""
    own = twins == np.arange(twins.size)
    need = np.zeros_like(mask)
    np.logical_or.at(need.T, twins, mask.T)  # a case asked: its twin is solved
    b = sweep.solve_angle(ia, need & own[None, :])
    copy = np.flatnonzero(~own)
    data, status = {k: v.copy() for k, v in b.data.items()}, b.status.copy()
    for arr in (*data.values(), status):
        arr[:, copy] = arr[:, twins[copy]]
    errors = b.errors + [((ia, js, int(j)), code, msg) for (_, js, jc), code, msg in b.errors for j in copy
                         if twins[j] == jc and mask[js, j]]
    return Block(b.ia, need | mask, data, status, errors)


def _moved(block: Block) -> Block:
    """An in-plane :class:`Block` of the sweep's rows as one of ``/planes/out`` (node positions: the root's)."""
    data = {P.PLANE_OUT_PATHS[k]: v for k, v in block.data.items() if k in P.PLANE_OUT_PATHS}
    return Block(block.ia, block.mask, data, block.status, block.errors)


def _same(part, settings: dict) -> bool:
    """The archived out-of-plane product has this run's model size, mode shapes and tracked DOFs."""
    with h5py.File(part, "r") as f:
        have = f[P.PLANE_OUT.name].attrs
        return all(k in have and int(have[k]) == int(settings[k]) for k in ("n_free", "mode_shapes",
                                                                              "n_signature_dofs"))


def _finished(out: Path, settings: dict, retry) -> np.ndarray | None:
    """The statuses of the out-of-plane sweep of the finished archive ``out`` when it has this run's
    settings and no point to solve (``retry``: also none of these statuses), else None."""
    from fkev_slepc.archive.store import partial_path
    from fkev_slepc.sweep.units import pending

    if not out.exists() or partial_path(out).exists():
        return None
    with h5py.File(out, "r") as f:
        if P.PLANE_OUT.status not in f:
            return None
    status = _status(out)
    return status if _same(out, settings) and not pending(status, retry).any() else None


def _status(part) -> np.ndarray:
    with h5py.File(part, "r") as f:
        return np.asarray(f[P.PLANE_OUT.status][()], dtype=np.uint8)


def _hints(part) -> np.ndarray:
    """|λ1| of the out-of-plane points already archived (the continuation hints of a resume)."""
    from fkev_slepc.archive.store import read_state

    return read_state(part, plane="out").lam1
