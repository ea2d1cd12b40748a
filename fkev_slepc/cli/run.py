"""``fkev run SCENE``: the sweep over crank angle × speed × case into an HDF5 archive.

Run it on any number of ranks (``mpiexec -n 2 fkev run scene.toml``); every rank takes part.
Without ``-o`` the archive is ``<scene dir>/out/<scene stem>.h5``; while being written it is
``<name>.h5.part`` and it is renamed when complete. ``--resume`` continues a killed run (or
adds ``--retry-failed`` points to a finished one) and refuses when the scene or grid changed.
Exit codes: 0 every point converged (unstable/divergent points included), 2 bad scene or
options, 3 some points failed or did not converge.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from fkev_slepc.solve.engines import make_cross_check_engine, make_engine
from fkev_slepc.scene.cases import CASE_NAMES, case_name
from fkev_slepc.scene import Problem, Scene, SceneError, with_elements
from .common import RAD_S_PER_RPM, add_accuracy_arguments, add_elements_argument, apply_element, modes_problem

MAX_POINTS_PER_AXIS = 1_000_000


def add_parser(sub) -> None:
    p = sub.add_parser(
        "run", help="sweep crank angle x speed x case into an HDF5 archive (MPI-parallel)",
        description="Solve every (crank angle, speed, case) point of a scene and archive it. "
        "Run under mpiexec to use several ranks.",
        epilog="PETSc/SLEPc options (-fkev_pep_type toar ...) may follow the scene path or '--'. "
        "Default output: <scene dir>/out/<scene stem>.h5. Set FKEV_HDF5_MPIO=0 to write through "
        "rank 0 instead of parallel HDF5 (file systems without MPI-IO locking).")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("-o", "--output", type=Path, help="archive path (default <scene dir>/out/<stem>.h5)")
    p.add_argument("--angles", metavar="START:STOP:STEP|a,b,c",
                   help="crank angles, deg (STOP included when on the grid); default the scene's")
    speeds = p.add_mutually_exclusive_group()
    speeds.add_argument("--speeds", metavar="a,b,c", help="crank speeds, rad/s; default the scene's")
    speeds.add_argument("--speeds-rpm", metavar="a,b,c", help="crank speeds, rev/min")
    p.add_argument("--cases", metavar="c1,c2,...", help="case names or Table 3.1 numbers, or 'all'")
    p.add_argument("--modes", type=int, metavar="N", help="modes per point (default the scene's)")
    add_elements_argument(p)
    add_accuracy_arguments(p)
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default the scene's)")
    p.add_argument("--mode-shapes", action="store_true", help="also archive mode shapes (/modes)")
    p.add_argument("--cross-check", action="store_true",
                   help="also solve every point with the other engine (dense <-> SLEPc) and report the "
                        "largest relative frequency difference (archived in the solver settings)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run of the same scene")
    p.add_argument("--retry-failed", action="store_true", help="with --resume: solve failed and not-converged points again")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument("--np", type=int, metavar="N", help="start N MPI ranks (runs mpiexec itself; with Open MPI "
                   "adds --oversubscribe when N exceeds the CPUs)")
    p.set_defaults(func=run)


# ------------------------------------------------------------------------------- options
def parse_angles(text: str) -> tuple[float, ...]:
    """``START:STOP:STEP`` (STOP included when it lies on the grid) or ``a,b,c`` (deg)."""
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise ValueError(f"expected START:STOP:STEP or a,b,c (got {text!r})")
        start, stop, step = (_number(v, text) for v in parts)
        if step <= 0:
            raise ValueError(f"STEP must be > 0 (got {text!r})")
        if stop < start:
            raise ValueError(f"STOP must be >= START (got {text!r})")
        n = int(np.floor((stop - start) / step + 1e-9)) + 1
        if n > MAX_POINTS_PER_AXIS:
            raise ValueError(f"{n} angles is too many (got {text!r})")
        values = tuple(float(v) for v in start + step * np.arange(n))
    else:
        values = _list(text)
    return values


def parse_speeds(text: str) -> tuple[float, ...]:
    values = _list(text)
    if any(v < 0 for v in values):
        raise ValueError(f"speeds must be >= 0 rad/s (got {text!r})")
    return values


def parse_speeds_rpm(text: str) -> tuple[float, ...]:
    values = _list(text)
    if any(v < 0 for v in values):
        raise ValueError(f"speeds must be >= 0 rpm (got {text!r})")
    return tuple(v * RAD_S_PER_RPM for v in values)


def parse_cases(text: str) -> tuple[str, ...]:
    if text.strip() == "all":
        return CASE_NAMES
    names = tuple(case_name(v) for v in text.split(","))
    if len(set(names)) != len(names):
        raise ValueError(f"a case is listed twice (got {text!r})")
    return names


def _number(v: str, text: str) -> float:
    try:
        x = float(v)
    except ValueError:
        raise ValueError(f"{v.strip()!r} is not a number (got {text!r})") from None
    if not np.isfinite(x):
        raise ValueError(f"values must be finite (got {text!r})")
    return x


def _list(text: str) -> tuple[float, ...]:
    values = tuple(_number(v, text) for v in text.split(","))
    if len(set(values)) != len(values):
        raise ValueError(f"a value is listed twice (got {text!r})")
    return values


def prepare(args) -> Scene:
    """The scene with the command-line overrides applied and checked; SceneError otherwise."""
    from fkev_slepc.model.kinematics import assembly_problems
    from fkev_slepc.scene import load_scene

    scene = load_scene(args.scene)
    if args.elements is not None:
        scene = with_elements(scene, args.elements)
    scene = apply_element(scene, getattr(args, "element", None))
    an, drv, problems = scene.analysis, scene.driver, []
    for flag, value, parse, field in (("--angles", args.angles, parse_angles, "crank_angles_deg"),
                                      ("--speeds", args.speeds, parse_speeds, "speeds"),
                                      ("--speeds-rpm", args.speeds_rpm, parse_speeds_rpm, "speeds"),
                                      ("--cases", args.cases, parse_cases, "cases")):
        if value is None:
            continue
        try:
            parsed = parse(value)
        except ValueError as err:
            problems.append(Problem(flag, str(err)))
            continue
        if field == "speeds":
            drv = replace(drv, speeds=parsed)
        else:
            an = replace(an, **{field: parsed})
    if args.modes is not None:
        if args.modes < 1:
            problems.append(Problem("--modes", f"must be >= 1 (got {args.modes})"))
        else:
            an = replace(an, modes=args.modes)
    if problems:
        raise SceneError(scene.source, problems)
    scene = replace(scene, analysis=replace(an, mode_shapes=an.mode_shapes or args.mode_shapes), driver=drv)
    bad = assembly_problems(scene)
    if bad and args.angles is not None:
        bad = [Problem(p.path.replace("analysis.crank_angles_deg", "--angles"), p.message) for p in bad]
    if bad:
        raise SceneError(scene.source, bad)
    return scene


def _plan_accuracy(args, scene: Scene, comm):
    """With ``--rel-error`` (or ``analysis.rel_error``): rank 0 plans the element and mesh at a few
    sample points of the grid (solve/accuracy.py), every rank gets the re-meshed scene; the plan
    (with its estimate) is archived as the ``accuracy`` attribute. Returns (scene, plan dict or None)."""
    rel_error = scene.analysis.rel_error if getattr(args, "rel_error", None) is None else args.rel_error
    if rel_error is None:
        return scene, None
    from fkev_slepc.solve.accuracy import planned_scene, sample_points

    out = None
    if comm.rank == 0:
        an = scene.analysis
        points = sample_points(an.crank_angles_deg, scene.driver.speeds, an.cases)
        try:
            _, plan = planned_scene(scene, points, an.modes, rel_error, args.solver or scene.solver.method)
            out = dict(plan.summary(), sample_points=points)
        except ValueError as err:
            out = str(err)
    out = comm.bcast(out, root=0)
    if isinstance(out, str):
        raise SceneError(scene.source, [Problem("--rel-error", out)])
    scene = apply_element(with_elements(scene, out["elements_per_link"]), out["element"])
    if comm.rank == 0 and not args.quiet:
        print(f"fkev run: rel_error {rel_error:g}: element {out['element']}, {out['elements_per_link']} elements per "
              f"link, estimated max relative error {out['predicted_rel_error']:.1e} at {len(out['sample_points'])} "
              "sample points", file=sys.stderr, flush=True)
    return scene, out


def default_output(scene_path) -> Path:
    """``<scene dir>/out/<scene stem>.h5``."""
    p = Path(scene_path)
    return p.parent / "out" / (p.stem + ".h5")


# ----------------------------------------------------------------------------------- run
def run(args) -> int:
    from fkev_slepc.archive import store as archive
    from fkev_slepc.archive import writer as archive_writer
    from fkev_slepc.sweep.parallel import install_abort_hook, world

    comm = world()
    install_abort_hook()
    rank0 = comm.rank == 0
    try:
        scene = prepare(args)
        scene, plan = _plan_accuracy(args, scene, comm)
    except SceneError as err:
        if rank0:
            print(str(err), file=sys.stderr, flush=True)
        return 2
    from fkev_slepc.model.operators import Model
    from fkev_slepc.sweep.runner import Sweep, SweepOptions, tracking_dofs

    t0 = time.monotonic()
    an = scene.analysis
    grid = archive.Grid(np.asarray(an.crank_angles_deg, float), np.asarray(scene.driver.speeds, float),
                        tuple(an.cases), int(an.modes))
    model = Model(scene, cases=grid.cases)
    too_many = modes_problem(grid.n_modes, model.n_free, "--modes" if args.modes is not None else None)
    try:
        if too_many:
            raise SceneError(scene.source, [too_many])
        factory = make_cross_check_engine if args.cross_check else make_engine
        engine = factory(args.solver or scene.solver.method, model.n_free, scene.solver.petsc)
    except SceneError as err:
        if rank0:
            print(str(err), file=sys.stderr, flush=True)
        return 2
    out = Path(args.output) if args.output else default_output(args.scene)
    part = archive.partial_path(out)
    track_dofs = tracking_dofs(model.n_free, len(grid.angles_deg))
    elements = np.array([lk.elements for lk in scene.links], dtype="i4")
    expect = {"scene_toml": scene.source_text, "elements": elements, "n_free": model.n_free,
              "mode_shapes": int(an.mode_shapes), "element": an.element}
    args.accuracy_plan = plan  # archived with the run attributes (not a resume condition)
    setup = None
    if rank0:
        setup = _open_or_create(args, out, part, grid, expect, model, engine, scene, comm.size, track_dofs)
    setup = comm.bcast(setup, root=0)
    if isinstance(setup, str):  # refused: message already printed by rank 0
        return int(setup.split(":")[0])
    state, todo = setup
    if rank0 and not args.quiet:
        print(f"fkev run: {int(todo.sum())} of {grid.n_points} points to solve on {comm.size} rank(s) -> {part}",
              file=sys.stderr, flush=True)
    progress = None if args.quiet or not rank0 else Progress(int(todo.sum()))
    opts = SweepOptions(grid.n_modes, an.imag_tol, an.stability_tol, an.mode_shapes, track_dofs)
    writer = archive_writer.Writer(part, comm, parallel=archive_writer.use_mpio(comm))
    sweep = Sweep(model, grid, engine, writer, opts, state.lam1)
    sweep.run(todo, comm, progress)
    writer.close()
    settings = _settings(engine) if rank0 else None
    if args.cross_check:
        from mpi4py import MPI

        worst = comm.allreduce(engine.max_rel_diff, op=MPI.MAX)
        counts = comm.allreduce(np.array([engine.n_points, engine.n_skipped]), op=MPI.SUM)
        if rank0:
            settings["cross_check"].update(max_rel_diff=worst, points=int(counts[0]), skipped=int(counts[1]))
            print(f"fkev run: cross-check {engine.name} vs {engine.other.name}: max relative frequency "
                  f"difference {worst:.2e} over {counts[0]} points ({counts[1]} not compared: not converged)",
                  file=sys.stderr, flush=True)
    engine.close()
    if progress is not None:
        progress.close()
    comm.Barrier()
    code = _finish(part, out, grid, comm.size, t0, args.quiet, settings) if rank0 else None
    return int(comm.bcast(code, root=0))


def _open_or_create(args, out, *rest):
    """Rank 0: the output's lock (archive/lock.py; held until _finish), then the setup below."""
    from fkev_slepc.archive.lock import ArchiveLocked, hold

    try:
        hold(out)
    except ArchiveLocked as exc:
        print(f"fkev run: {exc}", file=sys.stderr, flush=True)
        return f"2:{exc}"
    return _open_or_create_locked(args, out, *rest)  # a refusal ends the process, and the lock with it


def _open_or_create_locked(args, out, part, grid, expect, model, engine, scene, n_ranks, track_dofs):
    """Rank 0: a state and todo mask, or 'code:message' when refusing (message printed)."""
    from fkev_slepc.archive import store as archive
    from fkev_slepc.model.kinematics import TRANSMISSION_WARN_DEG, solve_kinematics
    from fkev_slepc.sweep.parallel import software_versions

    if args.resume:
        try:
            src = archive.open_for_resume(out, grid, expect)
        except FileNotFoundError as exc:
            print(f"fkev run: --resume: {exc}; starting a new run", file=sys.stderr, flush=True)
            src = None
        except archive.ArchiveMismatch as exc:
            print(f"fkev run: --resume: {exc}", file=sys.stderr, flush=True)
            return f"2:{exc}"
        if src is not None:
            state = archive.read_state(src)
            todo = state.todo(args.retry_failed)
            if src == out and not todo.any():
                print(f"fkev run: {out} is complete; nothing to do", file=sys.stderr, flush=True)
                return f"{_exit_code(state.status)}:complete"
            if src == out:
                archive.reopen_finished(out)
            return state, todo
    out.parent.mkdir(parents=True, exist_ok=True)
    mech = model.mechanism
    mesh = {"node_link": mech.node_link, "node_s": mech.node_s, "node_dofs": mech.node_dofs,
            "elem_nodes": mech.elem_nodes, "link_names": list(mech.link_names)}
    attrs = dict(expect, scene_source=str(scene.source), command_line=" ".join(sys.argv),
                 n_ranks=n_ranks, solver_settings=_settings(engine), imag_tol=scene.analysis.imag_tol,
                 stability_tol=scene.analysis.stability_tol, title=scene.title, **software_versions())
    if getattr(args, "accuracy_plan", None) is not None:
        attrs["accuracy"] = args.accuracy_plan
    mu = np.degrees(solve_kinematics(mech, np.radians(grid.angles_deg)).transmission)
    if np.nanmin(mu, initial=90.0) < TRANSMISSION_WARN_DEG:  # NaN-free: every angle assembles
        print(f"fkev run: warning: transmission angle down to {np.nanmin(mu):.3g}° (< {TRANSMISSION_WARN_DEG:g}°): near a "
              "toggle, the speed-dependent terms grow like 1/sin(μ) (docs/numerical-stability.md)", file=sys.stderr)
    archive.create(part, grid, attrs, mesh, model.n_free, scene.analysis.mode_shapes, track_dofs,
                   transmission_deg=mu)
    shape = grid.shape
    state = archive.ArchiveState(np.zeros(shape, np.uint8), np.full(shape, np.nan))
    return state, np.ones(shape, bool)


def _settings(engine) -> dict:
    settings = getattr(engine, "settings", None)
    return dict(settings()) if callable(settings) else {"engine": getattr(engine, "name", "?")}


def _exit_code(status) -> int:
    from fkev_slepc.status import RETRYABLE, Status, codes

    bad = np.isin(status, codes((Status.PENDING, *RETRYABLE)))
    return 3 if bad.any() else 0


def _finish(part, out, grid, n_ranks, t0, quiet, settings) -> int:
    """Rank 0: track modes, write the run attributes, rename; summary line; exit code."""
    from fkev_slepc.archive import store as archive
    from fkev_slepc.archive.lock import release
    from fkev_slepc.sweep.runner import track

    freq, status, sig = archive.read_tracking_inputs(part)
    tracked, open_loops = track(freq, status, sig, grid.angles_deg)
    attrs = {"n_ranks": n_ranks, "last_command_line": " ".join(sys.argv), "tracking_open_loops": open_loops,
             "last_solver_settings": settings}
    wall = time.monotonic() - t0  # this run, from the checked scene to the finished archive
    archive.finalize(part, out, tracked, attrs, add_wall_time=wall)
    release(out)  # taken by _open_or_create
    counts = archive.status_counts(status)
    if not quiet:
        summary = ", ".join(f"{k} {v}" for k, v in counts.items() if v)
        print(f"fkev run: wrote {out}: {grid.n_points} points ({summary}) in {wall:.1f} s on {n_ranks} rank(s)",
              flush=True)
    return _exit_code(status)


class Progress:
    """Points done / total, rate and ETA on rank 0: a tqdm bar on a terminal, else a line
    every ``every`` seconds (and at the end) on stderr."""

    def __init__(self, total: int, every: float = 10.0, stream=None):
        self.total, self.every = total, every
        self.stream = stream or sys.stderr
        self.t0 = self._last = time.monotonic()
        self.bar = None
        if self.stream.isatty() and os.environ.get("TERM") != "dumb":
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=total, unit="pt", file=self.stream, dynamic_ncols=True)
            except ImportError:  # pragma: no cover - tqdm is part of the stack
                self.bar = None
        self.done = 0

    def __call__(self, done: int, total: int) -> None:
        if self.bar is not None:
            self.bar.update(done - self.done)
        now = time.monotonic()
        self.done = done
        if self.bar is None and (now - self._last >= self.every or done >= total):
            self._last = now
            print(self.line(done, total, now - self.t0), file=self.stream, flush=True)

    @staticmethod
    def line(done: int, total: int, elapsed: float) -> str:
        rate = done / elapsed if elapsed > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else float("nan")
        eta_s = time.strftime("%H:%M:%S", time.gmtime(eta)) if np.isfinite(eta) else "?"
        pct = 100.0 * done / total if total else 100.0
        return f"fkev run: {done}/{total} points ({pct:.0f}%), {rate:.1f} points/s, ETA {eta_s}"

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
