"""One sweep from a checked scene to a finished archive: the code path of ``fkev run`` and of
``Study.sweep``.

A :class:`SweepSession` is collective over an MPI communicator (every rank builds it and calls
its methods in the same order) and runs in three steps:

1. :meth:`~SweepSession.open_output` -- before any solve: rank 0 checks the output (a resume
   against the archive's scene and grid, or a new ``<name>.h5.part``) and tells the other ranks
   what to solve, or raises :class:`RunRefused` on every rank;
2. :meth:`~SweepSession.solve` -- every rank solves its share of the points and writes them
   (:class:`~fkev_slepc.sweep.runner.Sweep`);
3. :meth:`~SweepSession.finalise` -- rank 0 tracks modes, writes the run attributes and renames
   the archive into place; every rank gets the :class:`SweepOutcome`.

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

from fkev_slepc.scene import Scene
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, EXIT_OK, RETRYABLE, Status, codes
from fkev_slepc.sweep.interrupt import StopRequest, SweepInterrupted  # noqa: F401 (raised by solve)


class RunRefused(Exception):
    """The sweep did not start: ``exit_code`` is what ``fkev run`` exits with (2: bad input).

    Raised on every rank alike (rank 0 decides and broadcasts it), so no rank is left waiting.
    """

    def __init__(self, message: str, exit_code: int = EXIT_BAD_INPUT):
        super().__init__(message, exit_code)
        self.message, self.exit_code = message, exit_code

    def __str__(self) -> str:
        return self.message


class OutputError(RunRefused):
    """The output archive cannot be used (e.g. ``resume`` of a different scene or grid)."""


def default_output(scene_path, plane: str = "in") -> Path:
    """``<scene dir>/out/<scene stem>.h5`` (``<scene stem>-out.h5`` out of plane).

    Examples
    --------
    >>> default_output("study/four-bar.toml").as_posix(), default_output("study/four-bar.toml", "out").name
    ('study/out/four-bar.h5', 'four-bar-out.h5')
    """
    p = Path(scene_path)
    return p.parent / "out" / (p.stem + ("" if plane == "in" else f"-{plane}") + ".h5")


def mesh_arrays(mech) -> dict:
    """The arrays of ``/mesh`` of a :class:`~fkev_slepc.model.mechanism.Mechanism`, by their table
    ``source`` (:data:`fkev_slepc.archive.products.MESH`): what ``store.create`` takes as ``mesh``."""
    from fkev_slepc.archive.products import LINKS, MESH_ARRAYS

    out = {v.source: np.asarray(getattr(mech, v.source)) for v in MESH_ARRAYS}
    out[LINKS.source] = list(getattr(mech, LINKS.source))
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

    Raises
    ------
    SceneError
        On every rank, when the engine rejects the solver options.
    """

    def __init__(self, request: SweepRequest, comm, notify: Callable[[str], None] | None = None):
        from fkev_slepc.archive.products import Grid
        from fkev_slepc.model.operators import Model
        from fkev_slepc.solve.engines import make_cross_check_engine, make_engine
        from fkev_slepc.solve.petsc_init import init_petsc
        from fkev_slepc.sweep.tracking import tracking_dofs

        # PETSc's initialisation is collective over MPI_COMM_WORLD: do it here, on every rank,
        # before rank 0 alone imports PETSc (software versions); a no-op after the CLI's init.
        init_petsc()
        self.t0 = time.monotonic()
        self.request, self.comm = request, comm
        self.rank0 = comm.rank == 0
        self._notify = notify if (notify is not None and self.rank0) else (lambda _msg: None)
        scene = request.scene
        an = scene.analysis
        self.grid = Grid(np.asarray(an.crank_angles_deg, float), np.asarray(scene.driver.speeds, float),
                         tuple(an.cases), int(an.modes))
        self.model = Model(scene, cases=self.grid.cases, plane=request.plane)
        from fkev_slepc.solve.thresholds import SolveSettings

        factory = make_cross_check_engine if request.cross_check else make_engine
        self.engine = factory(request.solver or scene.solver.method, self.model.n_free, scene.solver.petsc,
                              settings=SolveSettings.from_scene(scene))
        self.output = Path(request.output)
        self.track_dofs = tracking_dofs(self.model.n_free, len(self.grid.angles_deg), len(self.grid.speeds))
        self._final_settings: dict | None = None  # set by solve (rank 0)
        self._cross: dict | None = None

    # ------------------------------------------------------------------------- 1. output
    def open_output(self) -> OutputState:
        """Collective. Check (resume) or create the output before anything is solved.

        Raises :class:`RunRefused` on every rank when the run cannot go on."""
        plan: OutputState | RunRefused | None = None
        if self.rank0:
            try:
                plan = self._open_locked()
            except RunRefused as exc:
                plan = exc
            except OSError as exc:  # refused on every rank, not raised on rank 0 alone (others would wait)
                where = f": {exc.filename}" if exc.filename else ""
                plan = OutputError(f"{self.output}: cannot write the archive ({exc.strerror or exc}{where})")
        plan = self.comm.bcast(plan, root=0)
        if isinstance(plan, RunRefused):
            self.engine.close()
            raise plan
        return plan

    def _expect(self) -> dict:
        """Root attributes a resumed archive must match (and a new one records)."""
        scene = self.request.scene
        elements = np.array([lk.elements for lk in scene.links], dtype="i4")
        return {"scene_toml": scene.source_text, "elements": elements, "n_free": self.model.n_free,
                "mode_shapes": int(scene.analysis.mode_shapes), "element": scene.analysis.element,
                "plane": self.request.plane}

    def _open_locked(self) -> OutputState:
        """Rank 0: take the output's lock (archive/lock.py; held until :meth:`finalise`, so a
        second writer is refused), then open the output."""
        from fkev_slepc.archive.lock import ArchiveLocked, hold, release
        from fkev_slepc.archive.paths import PathProblem, check_output

        req = self.request
        try:  # a path that cannot be written is one line naming it, before the lock file is made
            check_output(self.output, (".h5",), "output" if req.make_dirs else "-o", make_parent=req.make_dirs)
            hold(self.output)
        except (ArchiveLocked, PathProblem) as exc:
            raise OutputError(str(exc)) from None
        try:
            plan = self._open_on_rank0()
        except BaseException:
            release(self.output)
            raise
        if plan.complete:  # nothing to write
            release(self.output)
        return plan

    def _open_on_rank0(self) -> OutputState:
        from fkev_slepc.archive import store

        from fkev_slepc.archive.paths import PathProblem, check_archive_output

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
        from fkev_slepc.sweep.parallel import software_versions

        attrs = dict(self._expect(), scene_source=str(scene.source), command_line=req.command_line,
                     n_ranks=self.comm.size, solver_settings=self._settings(),
                     imag_tol=scene.analysis.imag_tol, damping_tol=scene.analysis.damping_tol,
                     title=scene.title, **display_facts(scene), **software_versions())
        if req.accuracy is not None:
            attrs["accuracy"] = req.accuracy
        from fkev_slepc.model.kinematics import TRANSMISSION_WARN_DEG, solve_kinematics

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
        from fkev_slepc.archive import writer as archive_writer
        from fkev_slepc.sweep.progress import Progress
        from fkev_slepc.sweep.runner import Sweep, SweepOptions

        an = self.request.scene.analysis
        bar = None
        if progress and self.rank0:
            self._notify(f"{int(plan.todo.sum())} of {self.grid.n_points} points to solve on "
                         f"{self.comm.size} rank(s) -> {plan.part}")
            bar = Progress(int(plan.todo.sum()))
        opts = SweepOptions(self.grid.n_modes, an.imag_tol, an.damping_tol, an.mode_shapes, self.track_dofs)
        writer = archive_writer.Writer(plan.part, self.comm, parallel=archive_writer.use_mpio(self.comm))
        stop = StopRequest(notify=lambda what: self._notify(self._interrupt_note(what, plan.part)))
        try:
            with stop:  # Ctrl-C/SIGTERM: every rank leaves after the same sync (sweep.interrupt)
                sweep = Sweep(self.model, self.grid, self.engine, writer, opts, plan.lam1)
                done = sweep.run(plan.todo, self.comm, bar, stop=stop)
        finally:
            writer.close()
            if bar is not None:
                bar.close()
        if stop.stopped:
            self.engine.close()
            raise SweepInterrupted(plan.part, done)
        from fkev_slepc.sweep.tracking_angles import track_archive

        self._open_loops = track_archive(plan.part, sweep, self.comm)  # may solve extra angles (collective)
        self._final_settings = self._settings() if self.rank0 else None  # before close: reads solver objects
        self._cross = self._reduce_cross_check()
        if self._cross is not None and self.rank0:
            self._final_settings["cross_check"].update(
                {k: self._cross[k] for k in ("max_rel_diff", "points", "skipped")})
        self.engine.close()
        return done

    def _interrupt_note(self, what: str, part: Path) -> str:
        how = self.request.resume_command or "the same sweep with resume=True"
        return (f"interrupted by {what}: stopping at the next sync; the points finished so far stay in {part}; "
                f"continue with: {how}")

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
        result = self._finalise_on_rank0(plan, n_solved) if self.rank0 else None
        return self.comm.bcast(result, root=0)

    def _finalise_on_rank0(self, plan: OutputState, n_solved: int) -> SweepOutcome:
        from fkev_slepc.archive import store

        status = store.read_state(plan.part).status
        attrs = {"n_ranks": self.comm.size, "last_command_line": self.request.command_line,
                 "tracking_open_loops": self._open_loops, "last_solver_settings": self._final_settings}
        wall = time.monotonic() - self.t0
        store.finalize(plan.part, self.output, attrs, add_wall_time=wall)
        from fkev_slepc.archive.lock import release

        release(self.output)  # taken by open_output
        return SweepOutcome(self.output, self.grid.n_points, n_solved, store.status_counts(status),
                            exit_code(status), wall, self.comm.size, self._cross)

    # ---------------------------------------------------------------------------- all
    def run(self, progress: bool = False) -> SweepOutcome:
        """Collective. :meth:`open_output`, :meth:`solve`, :meth:`finalise`."""
        plan = self.open_output()
        if plan.complete:
            self.engine.close()
            from fkev_slepc.archive.store import status_counts

            return SweepOutcome(self.output, self.grid.n_points, 0, status_counts(plan.status),
                                exit_code(plan.status), time.monotonic() - self.t0, self.comm.size,
                                already_complete=True)
        return self.finalise(plan, self.solve(plan, progress))


def run_sweep(request: SweepRequest, comm=None, notify=None, progress: bool = False) -> SweepOutcome:
    """Run ``request`` over ``comm`` (None: this process alone, ``MPI.COMM_SELF``).

    Collective; see :class:`SweepSession`. Raises ``SceneError`` (solver options) or
    :class:`RunRefused` (output) on every rank before anything is solved."""
    from fkev_slepc.sweep.parallel import local

    return SweepSession(request, local(comm), notify).run(progress)
