"""``fkev design SCENE --set KEY=VALUES ...``: the sweep repeated over a grid of scene-key values
(fkev_slepc/design/study.py), MPI-parallel over design points, into one resumable archive
(the base sweep of the scene as written, and ``/design``), with a summary table per design point:
the lowest frequency of each mode over the crank cycle at the top speed and the divergence speed."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, EXIT_OK

UNSOLVED = ("failed", "not_converged")  # a design point with one of these at any grid point has no minima


def add_parser(sub) -> None:
    p = sub.add_parser(
        "design", help="design study: the sweep over a grid of scene-key values (MPI-parallel)",
        description="Solve the scene's sweep grid at every design point, the product of the values given "
        "with --set for scene keys (any numeric key path, e.g. links[1].length_m), and archive it with the "
        "design keys as dimensions (readable with fkev_slepc.design.results.open_design as xarray).",
        epilog="Default output: <scene dir>/out/<scene stem>-design.h5. Run under mpiexec to use several ranks.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--set", dest="sets", action="append", required=True, metavar="KEY=START:STOP:STEP|a,b,c",
                   help="a design key and its values (STOP included when on the grid); repeatable (a grid)")
    p.add_argument("-o", "--output", type=Path, help="archive path (default <scene dir>/out/<stem>-design.h5)")
    p.add_argument("--angles", metavar="START:STOP:STEP|a,b,c", help="crank angles, deg; default the scene's")
    p.add_argument("--speeds", metavar="START:STOP:STEP|a,b,c",
                   help="crank speeds, rad/s; default the scene's (the printed cycle minima are at the top one)")
    p.add_argument("--cases", metavar="c1,c2,...", help="case names or Table 3.1 numbers, or 'all'")
    p.add_argument("--modes", type=int, metavar="N", help="modes per point (default the scene's)")
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default the scene's)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted design study of the same grid")
    p.add_argument("--force", action="store_true", help="replace an existing archive (refused otherwise)")
    p.add_argument("--np", type=int, metavar="N", help="start N MPI ranks (runs mpiexec itself, as fkev run --np)")
    p.set_defaults(func=run)


def parse_sets(sets: list[str]) -> dict:
    """``["links[1].length_m=0.25:0.4:0.05", ...]`` -> ``{key: values text}`` (SceneError naming --set)."""
    out, bad = {}, []
    for s in sets:
        key, eq, values = s.partition("=")
        if not eq or not key.strip() or not values.strip():
            bad.append(Problem("--set", f"expected KEY=START:STOP:STEP or KEY=a,b,c (got {s!r})"))
        elif key.strip() in out:
            bad.append(Problem("--set", f"{key.strip()} is given twice (got {out[key.strip()]!r} and {values.strip()!r}; "
                                        "one --set per key, its values as a list or range)"))
        else:
            out[key.strip()] = values.strip()
    if bad:
        raise SceneError("--set", bad)
    return out


def run(args) -> int:
    from fkev_slepc.design.results import open_design
    from fkev_slepc.design.study import design_grid, run_design
    from fkev_slepc.scene import load_scene
    from fkev_slepc.sweep.grid import CLI_NAMES, configure
    from fkev_slepc.sweep.parallel import install_abort_hook, world
    from fkev_slepc.sweep.session import RunRefused, SweepInterrupted

    comm = world()
    install_abort_hook()
    rank0 = comm.rank == 0
    output = args.output or Path(args.scene).parent / "out" / f"{Path(args.scene).stem}-design.h5"
    try:
        grid = design_grid(parse_sets(args.sets), "--set")
        scene = configure(load_scene(args.scene), angles=args.angles, speeds=args.speeds, cases=args.cases,
                          modes=args.modes, names=CLI_NAMES)
        notify = None if args.quiet else (lambda m: print(f"fkev design: {m}", file=sys.stderr, flush=True))
        run_design(scene, grid, output, comm, resume=args.resume, force=args.force, solver=args.solver,
                   notify=notify, command_line=" ".join(["fkev", *sys.argv[1:]]))
    except SweepInterrupted as err:  # the notice with what to do is already printed
        return err.exit_code
    except (SceneError, RunRefused) as err:  # every rank raised it; rank 0 says it
        bad_scene = isinstance(err, SceneError)
        if rank0:
            print(str(err) if bad_scene else f"fkev design: {err}", file=sys.stderr, flush=True)
        return EXIT_BAD_INPUT if bad_scene else err.exit_code
    if not rank0:
        return EXIT_OK
    ds = open_design(output)
    print_summary(ds, output)
    return EXIT_NOT_CONVERGED if np.isin(ds.status.values, UNSOLVED).any() else EXIT_OK


def print_summary(ds, output) -> None:
    """One row per design point: its values, the lowest frequency of each mode over the crank
    cycle at the top speed (first case), and the lowest divergence speed of each case; a point
    with a failed or not-converged grid point says so instead of minima over the angles that solved."""
    keys = list(ds.attrs["design_keys"])
    top, case = float(ds.speed_rad_s.max()), str(ds.case.values[0])
    fmin = ds.frequency_min_hz.sel(speed_rad_s=top, case=case)
    modes = [int(m) for m in ds.mode.values]
    cases = [str(c) for c in ds.case.values]
    print(f"{output}: {int(np.prod([ds.sizes[k] for k in keys]))} design points x {ds.sizes['crank_angle_deg']} angles "
          f"x {ds.sizes['speed_rad_s']} speeds x {len(cases)} case(s)")
    head = [f"{k:>18}" for k in keys] + [f"{'f' + str(m) + ' min [Hz]':>12}" for m in modes] \
        + [f"{'div ' + c + ' [rad/s]':>22}" for c in cases]
    print(f"cycle minimum at Ω = {top:g} rad/s, case {case}; divergence: lowest over the crank angles")
    print(" ".join(head))
    for idx in np.ndindex(*[ds.sizes[k] for k in keys]):
        sel = {k: i for k, i in zip(keys, idx)}
        vals = [f"{float(ds[k].values[i]):>18.6g}" for k, i in sel.items()]
        unsolved = np.isin(ds.status.isel(sel).values, UNSOLVED)
        if unsolved.any():
            print(" ".join(vals) + f"  {int(unsolved.sum())} of {unsolved.size} grid points failed or did not converge: "
                  "no minima (fkev info names them)")
            continue
        f = [f"{float(v):>12.5g}" for v in fmin.isel(sel).values]
        d = ds.divergence_speed_rad_s.isel(sel)
        div = [f"{float(d.sel(case=c)):>22.6g}" for c in cases]
        print(" ".join(vals + f + div))
