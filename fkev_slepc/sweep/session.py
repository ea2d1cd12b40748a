"""One sweep from a checked scene to a finished archive: the code path of ``fkev run`` and of
``Study.sweep``.

A :class:`SweepSession` is collective over an MPI communicator (every rank builds it and calls
its methods in the same order) and runs in three steps:

1. :meth:`~SweepSession.open_output` -- before any solve: rank 0 checks the output (a resume
   against the archive's scene and grid, or a new ``<name>.h5.part``) and tells the other ranks
   what to solve, or raises :class:`RunRefused` on every rank;
2. :meth:`~SweepSession.solve` -- every rank solves its share of the crank angles and writes them
   (:meth:`~fkev_slepc.sweep.runner.Sweep.solve_angle`), then modes are tracked;
3. :meth:`~SweepSession.finalise` -- rank 0 writes the run attributes and renames the archive
   into place; every rank gets the :class:`SweepOutcome`.

The three are the root product's use of the steps every product shares
(fkev_slepc/sweep/run_steps.py: ``open_root``, ``solve_pending``, ``finish``).

:meth:`~SweepSession.run` does all three. Human-readable notes (resume decisions, the number of
points with ``progress``, the cross-check result) go to ``notify`` on rank 0; the library
prints nothing itself.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive import store
from fkev_slepc.archive.paths import PathProblem, check_archive_output
from fkev_slepc.model.kinematics import TRANSMISSION_WARN_DEG, solve_kinematics
from fkev_slepc.model.operators import Model
from fkev_slepc.model.plane import Plane
from fkev_slepc.scene import Scene
from fkev_slepc.solve.engines import make_cross_check_engine, make_engine
from fkev_slepc.solve.petsc_init import init_petsc
from fkev_slepc.solve.thresholds import SolveSettings
from fkev_slepc.status import EXIT_NOT_CONVERGED, EXIT_OK, RETRYABLE, Status, codes
from fkev_slepc.sweep.interrupt import SweepInterrupted  # raised by solve (also importable from here)
from fkev_slepc.sweep.parallel import local, software_versions
from fkev_slepc.sweep.progress import Progress
from fkev_slepc.sweep.run_steps import OutputError, RunRefused  # noqa: F401 (importable from here)
from fkev_slepc.sweep.run_steps import cannot_write, finish, open_root, solve_pending
from fkev_slepc.sweep.runner import Sweep, SweepOptions
from fkev_slepc.sweep.tracking import tracking_dofs
from fkev_slepc.sweep.tracking_angles import track_archive


def default_output(scene_path, plane: str = "in") -> Path:
    """``<scene dir>/out/<scene stem>.h5`` (``<scene stem>-out.h5`` out of plane).

    Examples
    --------
    >>> default_output("study/four-bar.toml").as_posix(), default_output("study/four-bar.toml", "out").name
    ('study/out/four-bar.h5', 'four-bar-out.h5')
    """
    p = Path(scene_path)
    return p.parent / "out" / (p.stem + Plane.parse(plane).suffix + ".h5")


def mesh_arrays(mech) -> dict:
    """The arrays of ``/mesh`` of a :class:`~fkev_slepc.model.mechanism.Mechanism`, by their table
    ``source`` (:data:`fkev_slepc.archive.products.MESH`): what ``store.create`` takes as ``mesh``."""
    out = {v.source: np.asarray(getattr(mech, v.source)) for v in P.MESH_ARRAYS}
    out[P.LINKS.source] = list(getattr(mech, P.LINKS.source))
    return out


def display_facts(scene: Scene) -> dict:
    """Root attributes figures and reports show instead of re-deriving them: the unit the speeds
    were given in (``speed_unit``: ``Driver.speed_unit``, ``rpm`` with the scene's ``speeds_rpm`` or
    an rpm override such as ``--speeds-rpm``) and the Rayleigh damping coefficients
    (``damping_alpha`` 1/s, ``damping_beta`` s)."""
    d = scene.damping
    return {"speed_unit": scene.driver.speed_unit, "damping_alpha": float(d.mass_proportional),
            "damping_beta": float(d.stiffness_proportional)}


def exit_code(status: np.ndarray) -> int:
    """``EXIT_NOT_CONVERGED`` if some point is pending, failed or not converged, else ``EXIT_OK``."""
    bad = np.isin(status, codes((Status.PENDING, *RETRYABLE)))
    return EXIT_NOT_CONVERGED if bad.any() else EXIT_OK


@dataclass(frozen=True)
class SweepRequest:
    """What to run: a checked scene (grid overrides applied, see :func:`grid.configure`) and
    where to write it."""

    scene: Scene
    output: Path
    resume: bool = False
    retry_failed: bool = False  # with resume: solve failed and not-converged points again
    solver: str | None = None  # None: the scene's [solver] method
    cross_check: bool = False  # also solve every point with the other engine
    command_line: str = field(default_factory=lambda: " ".join(sys.argv))  # archived
    accuracy: dict | None = None  # the mesh plan of mesh_for_accuracy (archived, not a resume condition)
    force: bool = False  # replace an existing archive (or unfinished run) instead of refusing
    make_dirs: bool = True  # create a missing output directory (fkev run: only for its default <scene dir>/out/)
    resume_command: str | None = None  # how the user continues after an interruption (printed)
    plane: str = "in"  # "out": the out-of-plane problem (docs/theory.md §19), archived as the attribute plane


@dataclass(frozen=True)
class OutputState:
    """Result of :meth:`SweepSession.open_output`, the same on every rank."""

    part: Path  # the file written during the run
    status: np.ndarray  # (angle, speed, case) archive status codes before this run
    lam1: np.ndarray  # |λ1| of converged points already archived (continuation hints)
    todo: np.ndarray  # (angle, speed, case) points to solve
    complete: bool = False  # the archive is finished and there is nothing to do


@dataclass(frozen=True)
class SweepOutcome:
    """What a sweep did (the same on every rank)."""

    output: Path
    n_points: int  # points in the grid
    n_solved: int  # points solved by this run
    counts: dict  # points of each status in the archive, by status name
    exit_code: int  # EXIT_OK, or EXIT_NOT_CONVERGED when some point is flagged
    wall_time_s: float  # this run, from the checked scene to the finished archive
    n_ranks: int
    cross_check: dict | None = None  # {engine, other, max_rel_diff, points, skipped}
    already_complete: bool = False  # resume of a finished archive: nothing was solved


class SweepSession:
    """A sweep of ``request`` over ``comm`` (collective: build and call it on every rank).

    Parameters
    ----------
    request : SweepRequest
    comm : mpi4py communicator
    notify : callable(str), optional
        Called on rank 0 with one-line notes for the user.
    model : Model, optional
        The scene's model (of ``request.plane``, with at least the motion terms of the grid's cases),
        when the caller keeps one (``Study.sweep``: its model pool); default a new one.

    Raises
    ------
    SceneError
        On every rank, when the engine rejects the solver options.
    """

    def __init__(self, request: SweepRequest, comm, notify: Callable[[str], None] | None = None, model=None):
        # PETSc's initialisation is collective over MPI_COMM_WORLD: do it here, on every rank,
        # before rank 0 alone imports PETSc (software versions); a no-op after the CLI's init.
        init_petsc()
        self.t0 = time.monotonic()
        self.request, self.comm = request, comm
        self.rank0 = comm.rank == 0
        self._notify = notify if (notify is not None and self.rank0) else (lambda _msg: None)
        scene = request.scene
        an = scene.analysis
        self.grid = P.Grid(np.asarray(an.crank_angles_deg, float), np.asarray(scene.driver.speeds, float),
                           tuple(an.cases), int(an.modes))
        self.model = Model(scene, cases=self.grid.cases, plane=request.plane) if model is None else model
        factory = make_cross_check_engine if request.cross_check else make_engine
        self.engine = factory(request.solver or scene.solver.method, self.model.n_free, scene.solver.petsc,
                              settings=SolveSettings.from_scene(scene))
        self.output = Path(request.output)
        self.track_dofs = tracking_dofs(self.model.n_free, len(self.grid.angles_deg), len(self.grid.speeds))
        self._final_settings: dict | None = None  # set by solve (rank 0)
        self._cross: dict | None = None

    # ------------------------------------------------------------------------- 1. output
    def open_output(self) -> OutputState:
        """Collective. Check (resume) or create the output before anything is solved; rank 0 holds
        the output's lock (archive/lock.py) until :meth:`finalise`, so a second writer is refused.

        Raises :class:`RunRefused` on every rank when the run cannot go on."""
        req = self.request
        try:
            return open_root(self.output, self.comm, self._open_on_rank0, req.make_dirs, lambda plan: plan.complete)
        except RunRefused:
            self.engine.close()
            raise

    def _expect(self) -> dict:
        """Root attributes a resumed archive must match (and a new one records)."""
        scene = self.request.scene
        elements = np.array([lk.elements for lk in scene.links], dtype="i4")
        return {"scene_toml": scene.source_text, "elements": elements, "n_free": self.model.n_free,
                "mode_shapes": int(scene.analysis.mode_shapes), "element": scene.analysis.element,
                "plane": self.request.plane}

    def _open_on_rank0(self) -> OutputState:
        try:
            return self._open_or_create()
        except OSError as exc:  # refused on every rank, not raised on rank 0 alone (others would wait)
            raise cannot_write(self.output, exc) from None

    def _open_or_create(self) -> OutputState:
        out, req, grid = self.output, self.request, self.grid
        resume = req.resume or req.retry_failed  # retrying failed points means continuing an archive
        try:  # before anything is created or solved: one line naming the path
            check_archive_output(out, resume=resume, force=req.force, make_parent=req.make_dirs,
                                 flag="output" if req.make_dirs else "-o")
        except PathProblem as exc:
            raise OutputError(str(exc)) from None
        if resume:
            try:
                src = store.open_for_resume(out, grid, self._expect())
            except FileNotFoundError as exc:
                self._notify(f"--resume: {exc}; starting a new run")
                src = None
            except store.ArchiveMismatch as exc:
                raise OutputError(f"--resume: {exc}") from None
            if src is not None:
                state = store.read_state(src)
                todo = state.todo(req.retry_failed)
                if src == out and not todo.any():
                    self._notify(f"{out} is complete; nothing to do")
                    return OutputState(out, state.status, state.lam1, todo, complete=True)
                if src == out:
                    store.reopen_finished(out)
                return OutputState(store.partial_path(out), state.status, state.lam1, todo)
        part = store.partial_path(out)
        mech, scene = self.model.mechanism, req.scene
        mesh = mesh_arrays(mech)
        attrs = dict(self._expect(), scene_source=str(scene.source), command_line=req.command_line,
                     n_ranks=self.comm.size, solver_settings=self._settings(),
                     imag_tol=scene.analysis.imag_tol, damping_tol=scene.analysis.damping_tol,
                     title=scene.title, **display_facts(scene), **software_versions())
        if req.accuracy is not None:
            attrs["accuracy"] = req.accuracy
        mu = np.degrees(solve_kinematics(mech, np.radians(grid.angles_deg)).transmission)
        if np.nanmin(mu, initial=90.0) < TRANSMISSION_WARN_DEG:  # NaN-free: every angle assembles
            self._notify(f"warning: transmission angle down to {np.nanmin(mu):.3g}° (< {TRANSMISSION_WARN_DEG:g}°): "
                         "near a toggle, the speed-dependent terms grow like 1/sin(μ) (docs/numerical-stability.md)")
        store.create(part, grid, attrs, mesh, self.model.n_free, scene.analysis.mode_shapes, self.track_dofs,
                     transmission_deg=mu)
        shape = grid.shape
        return OutputState(part, np.zeros(shape, np.uint8), np.full(shape, np.nan), np.ones(shape, bool))

    def _settings(self) -> dict:
        return dict(self.engine.settings())

    # -------------------------------------------------------------------------- 2. solve
    def solve(self, plan: OutputState, progress: bool = False) -> int:
        """Collective. Solve the points of ``plan.todo`` into ``plan.part``; the number solved.

        ``progress``: show points done, rate and ETA on rank 0 (:class:`progress.Progress`)."""
        an = self.request.scene.analysis
        bar = None
        if progress and self.rank0:
            self._notify(f"{int(plan.todo.sum())} of {self.grid.n_points} points to solve on "
                         f"{self.comm.size} rank(s) -> {plan.part}")
            bar = Progress(int(plan.todo.sum()))
        opts = SweepOptions(self.grid.n_modes, an.imag_tol, an.damping_tol, an.mode_shapes, self.track_dofs)
        sweep = Sweep(self.model, self.grid, self.engine, None, opts, plan.lam1)
        try:
            done = solve_pending(plan.part, self.output, P.SWEEP, plan.todo,
                                 lambda unit, mask: sweep.solve_angle(unit[0], mask), self.comm, 1, self._notify,
                                 "points", bar, how=self.request.resume_command or "the same sweep with resume=True")
        except SweepInterrupted:
            self.engine.close()
            raise
        finally:
            if bar is not None:
                bar.close()
        self._open_loops = track_archive(plan.part, sweep, self.comm)  # may solve extra angles (collective)
        self._final_settings = self._settings() if self.rank0 else None  # before close: reads solver objects
        self._cross = self._reduce_cross_check()
        if self._cross is not None and self.rank0:
            self._final_settings["cross_check"].update(
                {k: self._cross[k] for k in ("max_rel_diff", "points", "skipped")})
        self.engine.close()
        return done

    def _reduce_cross_check(self) -> dict | None:
        if not self.request.cross_check:
            return None
        from mpi4py import MPI

        e = self.engine
        worst = self.comm.allreduce(e.max_rel_diff, op=MPI.MAX)
        counts = self.comm.allreduce(np.array([e.n_points, e.n_skipped]), op=MPI.SUM)
        self._notify(f"cross-check {e.name} vs {e.other.name}: max relative frequency difference "
                     f"{worst:.2e} over {counts[0]} points ({counts[1]} not compared: not converged)")
        return {"engine": e.name, "other": e.other.name, "max_rel_diff": worst,
                "points": int(counts[0]), "skipped": int(counts[1])}

    # ----------------------------------------------------------------------- 3. finalise
    def finalise(self, plan: OutputState, n_solved: int) -> SweepOutcome:
        """Collective. Rank 0 writes the run attributes and renames ``plan.part`` to the output
        (modes were tracked at the end of :meth:`solve`); every rank returns the outcome."""
        self.comm.Barrier()
        status = store.read_state(plan.part).status if self.rank0 else None
        finish(plan.part, self.output, self.request.command_line, self.t0, self.comm,
               {"n_ranks": self.comm.size, "tracking_open_loops": self._open_loops,
                "last_solver_settings": self._final_settings})
        result = None if status is None else SweepOutcome(
            self.output, self.grid.n_points, n_solved, store.status_counts(status), exit_code(status),
            time.monotonic() - self.t0, self.comm.size, self._cross)
        return self.comm.bcast(result, root=0)

    # ---------------------------------------------------------------------------- all
    def run(self, progress: bool = False) -> SweepOutcome:
        """Collective. :meth:`open_output`, :meth:`solve`, :meth:`finalise`."""
        plan = self.open_output()
        if plan.complete:
            self.engine.close()
            return SweepOutcome(self.output, self.grid.n_points, 0, store.status_counts(plan.status),
                                exit_code(plan.status), time.monotonic() - self.t0, self.comm.size,
                                already_complete=True)
        return self.finalise(plan, self.solve(plan, progress))


def run_sweep(request: SweepRequest, comm=None, notify=None, progress: bool = False, model=None) -> SweepOutcome:
    """Run ``request`` over ``comm`` (None: this process alone, ``MPI.COMM_SELF``).

    Collective; see :class:`SweepSession` (``model``: the scene's model, default a new one). Raises ``SceneError`` (solver options) or
    :class:`RunRefused` (output) on every rank before anything is solved."""
    return SweepSession(request, local(comm), notify, model).run(progress)
