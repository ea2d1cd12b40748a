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
import shlex
import sys
from pathlib import Path

from fkev_slepc.model.plane import planes_of
from fkev_slepc.scene import SceneError
from fkev_slepc.status import EXIT_BAD_INPUT
from fkev_slepc.sweep.session import default_output
from .common import SWEEP_FLAGS, add_accuracy_arguments, add_elements_argument, as_flags, flag_words, load_checked
from .launch import NP_VARIABLE


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
    speeds.add_argument("--speeds", metavar="START:STOP:STEP|a,b,c",
                        help="crank speeds, rad/s (STOP included when on the grid); default the scene's")
    speeds.add_argument("--speeds-rpm", metavar="START:STOP:STEP|a,b,c", help="crank speeds, rev/min")
    p.add_argument("--cases", metavar="c1,c2,...", help="case names or Table 3.1 numbers, or 'all'")
    p.add_argument("--modes", type=int, metavar="N", help="modes per point (default the scene's)")
    add_elements_argument(p)
    add_accuracy_arguments(p)
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default the scene's)")
    p.add_argument("--mode-shapes", action="store_true", help="also archive mode shapes (/modes)")
    p.add_argument("--plane", choices=("in", "out", "both"),
                   help="in: the in-plane problem; out: bending out of the plane and torsion (docs/theory.md §19; "
                   "alone in its archive, default output <scene dir>/out/<stem>-out.h5); both: the in-plane sweep "
                   "and the out-of-plane one of the same grid in one archive (/planes/out). Default both when "
                   "every link gives its out-of-plane section data (and no --rel-error), else in")
    p.add_argument("--cross-check", action="store_true",
                   help="also solve every point with the other engine (dense <-> SLEPc) and report the "
                        "largest relative frequency difference (archived in the solver settings)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run of the same scene")
    p.add_argument("--retry-failed", action="store_true",
                   help="solve failed and not-converged points again (implies --resume)")
    p.add_argument("--force", action="store_true",
                   help="replace an existing archive or unfinished run (refused otherwise)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument("--np", type=int, metavar="N", help="start N MPI ranks (runs mpiexec itself; with Open MPI "
                   "adds --oversubscribe when N exceeds the CPUs)")
    p.set_defaults(func=run)


def run(args) -> int:
    """Parse, run the sweep (:mod:`fkev_slepc.sweep.session`, as ``Study.sweep``), print, exit code."""
    from fkev_slepc.sweep.grid import CLI_NAMES, configure
    from fkev_slepc.sweep.parallel import install_abort_hook, world
    from fkev_slepc.sweep.accuracy_mesh import mesh_for_accuracy
    from fkev_slepc.sweep.plane_run import default_plane, run_out_of_plane
    from fkev_slepc.sweep.session import RunRefused, SweepInterrupted, SweepRequest, run_sweep

    comm = world()
    install_abort_hook()
    rank0 = comm.rank == 0
    try:
        scene = load_checked(args.scene, args.elements, check_angles=False)  # configure checks the grid's angles
        scene = configure(scene, angles=args.angles, speeds=args.speeds, speeds_rpm=args.speeds_rpm,
                          cases=args.cases, modes=args.modes, mode_shapes=args.mode_shapes, element=args.element,
                          rel_error=args.rel_error, names=CLI_NAMES)
        plane = default_plane(scene, args.plane, args.rel_error)
        planes = planes_of(plane, "--plane")
        from fkev_slepc.api.point import out_of_plane_arguments

        try:
            for p in planes:
                out_of_plane_arguments(scene, p.name, args.rel_error, plane)
        except SceneError as err:
            raise as_flags(err, {"plane": "--plane", "rel_error": "--rel-error"}) from None
        scene, plan = mesh_for_accuracy(scene, args.solver, comm, None if args.quiet else _note, CLI_NAMES["rel_error"])
        sweep_plane = planes[0].name
        request = SweepRequest(scene, Path(args.output) if args.output else default_output(args.scene, sweep_plane),
                               resume=args.resume, retry_failed=args.retry_failed, solver=args.solver,
                               cross_check=args.cross_check, accuracy=plan, force=args.force,
                               make_dirs=args.output is None, resume_command=resume_command(sys.argv[1:]),
                               plane=sweep_plane)
        outcome = run_sweep(request, comm, notify=_note, progress=not args.quiet)
        other = run_out_of_plane(request, comm, _note, not args.quiet) if len(planes) > 1 else None
    except SweepInterrupted as err:  # the notice with the resume command is already printed
        return err.exit_code
    except SceneError as err:
        if rank0:
            print(str(err), file=sys.stderr, flush=True)
        return EXIT_BAD_INPUT
    except RunRefused as err:
        if rank0:
            _note(flag_words(err, SWEEP_FLAGS))
        return err.exit_code
    if rank0 and not args.quiet and not outcome.already_complete:
        summary = ", ".join(f"{k} {v}" for k, v in outcome.counts.items() if v)
        print(f"fkev run: wrote {outcome.output}: {outcome.n_points} points ({summary}) in "
              f"{outcome.wall_time_s:.1f} s on {outcome.n_ranks} rank(s)", flush=True)
    if rank0 and not args.quiet and other is not None and not other.already_complete:
        summary = ", ".join(f"{k} {v}" for k, v in other.counts.items() if v)
        print(f"fkev run: out of plane (/planes/out): {other.n_points} points ({summary}), "
              f"{other.n_solved} solved by this run", flush=True)
    return max(outcome.exit_code, other.exit_code if other is not None else 0)


def resume_command(argv: list[str]) -> str:
    """The command that continues this run: the same arguments with ``--resume`` (without
    ``--force``), and ``--np N`` again when ``fkev run --np N`` launched this rank."""
    args = [a for a in argv if a != "--force"]
    if "--resume" not in args:
        args.append("--resume")
    n = os.environ.get(NP_VARIABLE)
    if n and "--np" not in args:
        args += ["--np", n]
    return shlex.join(["fkev", *args])


def _note(message: str) -> None:
    print(f"fkev run: {message}", file=sys.stderr, flush=True)
