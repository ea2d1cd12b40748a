"""``fkev design SCENE --set KEY=VALUES ...``: the sweep repeated over a grid of scene-key values
(fkev_slepc/design/study.py), MPI-parallel over design points, into one resumable archive
(the base sweep of the scene as written, and ``/design``), with a summary table per design point:
the lowest frequency of each mode over the crank cycle at the top speed and the divergence speed, and
the design check's columns (torque range, peak joint and wrist-pin forces, weak-axis buckling factors;
with --stress peak |σ|, static and fatigue factors; with --sensitivity d/d(key) of the kinetostatic
ones) per design point, as text, --json or --csv (fkev_slepc/design/point_checks.py)."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np

from fkev_slepc.design.results import design_rows
from fkev_slepc.design.study_keys import CLI_NAMES as CLI_KEY_NAMES
from fkev_slepc.scene import Problem, SceneError, load_scene
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, EXIT_OK
from .common import add_speeds_arguments
from fkev_slepc.design.fatigue import CRITERIA
from fkev_slepc.design.point_checks import CheckOptions
from fkev_slepc.design.study import design_grid, run_design
from fkev_slepc.sweep.grid import CLI_NAMES, configure
from fkev_slepc.sweep.parallel import install_abort_hook, world
from fkev_slepc.sweep.session import RunRefused, SweepInterrupted

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
    add_speeds_arguments(p, "crank speeds, rad/s; default the scene's (the printed cycle minima are at the top one)")
    p.add_argument("--cases", metavar="c1,c2,...", help="case names or Table 3.1 numbers, or 'all'")
    p.add_argument("--modes", type=int, metavar="N", help="modes per point (default the scene's)")
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default the scene's)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted design study of the same grid")
    p.add_argument("--force", action="store_true", help="replace an existing archive (refused otherwise)")
    p.add_argument("--np", type=int, metavar="N", help="start N MPI ranks (runs mpiexec itself, as fkev run --np)")
    p.add_argument("--stress", action="store_true", help="per link the design check's peak |σ|, static and fatigue "
                   "factors at every speed and case (one periodic response each: costs far more than the frequencies)")
    p.add_argument("--criterion", default="goodman", choices=CRITERIA, help="fatigue criterion of --stress")
    p.add_argument("--harmonics", type=int, metavar="H", help="harmonics of the --stress responses (default: doubled "
                   "from 8 until converged)")
    p.add_argument("--sensitivity", action="store_true", help="d/d(design key) of the torque range, peak joint and "
                   "pin forces and buckling factors (central differences of the kinetostatics)")
    p.add_argument("--json", action="store_true", help="print one row per design point and speed as JSON")
    p.add_argument("--csv", metavar="PATH", help="write one row per design point and speed as CSV ('-': stdout)")
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
    comm = world()
    install_abort_hook()
    rank0 = comm.rank == 0
    output = args.output or Path(args.scene).parent / "out" / f"{Path(args.scene).stem}-design.h5"
    try:
        grid = design_grid(parse_sets(args.sets), "--set", CLI_KEY_NAMES)
        scene = configure(load_scene(args.scene), angles=args.angles, speeds=args.speeds, speeds_rpm=args.speeds_rpm, cases=args.cases,
                          modes=args.modes, names=CLI_NAMES)
        notify = None if args.quiet else (lambda m: print(f"fkev design: {m}", file=sys.stderr, flush=True))
        checks = CheckOptions(args.stress, args.sensitivity, args.criterion, args.harmonics)
        run_design(scene, grid, output, comm, resume=args.resume, force=args.force, solver=args.solver,
                   notify=notify, command_line=" ".join(["fkev", *sys.argv[1:]]), checks=checks,
                   names={**CLI_NAMES, "angles_deg": "--angles", "harmonics": "--harmonics", "criterion": "--criterion"})
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
    if args.csv:
        write_csv(ds, args.csv)
    if args.json:
        json.dump({"archive": str(output), "design_keys": list(ds.attrs["design_keys"]),
                   "rows": design_rows(ds)}, sys.stdout)
        print()
    elif args.csv != "-":
        print_summary(ds, output)
        print_checks(ds)
    return EXIT_NOT_CONVERGED if np.isin(ds.status.values, UNSOLVED).any() else EXIT_OK


def write_csv(ds, path: str) -> None:
    """:func:`~fkev_slepc.design.results.design_rows` as CSV (empty cells for None)."""
    rows = design_rows(ds)
    out = sys.stdout if path == "-" else open(path, "w", newline="")
    w = csv.DictWriter(out, fieldnames=list(rows[0]) if rows else [])
    w.writeheader()
    w.writerows({k: "" if v is None else v for k, v in r.items()} for r in rows)
    if out is not sys.stdout:
        out.close()


def print_checks(ds) -> None:
    """The design check per design point at the top speed (first case): torque range, peak joint
    forces (and wrist pins), buckling factors, with --stress peak |σ| and the safety factors;
    with --sensitivity the derivatives of the kinetostatic columns."""
    keys = list(ds.attrs["design_keys"])
    top, case = float(ds.speed_rad_s.max()), str(ds.case.values[0])
    rows = [r for r in design_rows(ds) if r["speed_rad_s"] == top]
    smooth = {"torque_min_n_m": ("τ min [N m]", 1), "torque_max_n_m": ("τ max [N m]", 1),
              "peak_joint_force_n": ("|F| {} [N]", 1), "peak_pin_force_n": ("pin {} [N]", 1),
              "buckling_sf": ("buckling SF {}", 1)}
    stress = {f"peak_stress_pa.{case}": ("σ {} [MPa]", 1e6), f"static_sf.{case}": ("static SF {}", 1),
              f"fatigue_sf.{case}": ("fatigue SF {}", 1)}
    criterion = ds.fatigue_sf.attrs.get("fatigue_criterion", "") if "fatigue_sf" in ds else ""
    print(f"design check at Ω = {top:g} rad/s over the crank angles"
          + (f"; stress case {case}, fatigue by {criterion}" if criterion else "") + ":")
    _table(rows, keys, _columns(rows[0], smooth | stress))
    if "sensitivity_torque_max_n_m" in ds:
        for key in keys:
            print(f"d/d({key}) at Ω = {top:g} rad/s, per unit of the key (central differences of the kinetostatics):")
            _table(rows, keys, _columns(rows[0], {f"sensitivity_{p}.{key}": ("d " + label, scale)
                                                  for p, (label, scale) in smooth.items()}))


def _columns(row: dict, prefixes: dict) -> list[tuple[str, str, float]]:
    """(column, label, scale) of the columns of ``row`` named ``prefix`` or ``prefix.NAME``."""
    out = []
    for c in row:
        for p, (label, scale) in prefixes.items():
            rest = c[len(p) + 1:]
            if c == p or (c.startswith(p + ".") and "." not in rest):
                out.append((c, label.format(rest).replace("  ", " "), scale))
    return out


def _table(rows, keys, cols) -> None:
    """One line per design point (its number first, as /design/point): key values, then ``cols``."""
    width = [max(12, len(label) + 1) for _, label, _ in cols]
    print(" ".join(["point"] + [f"{k:>18}" for k in keys] + [f"{label:>{w}}" for (_, label, _), w in zip(cols, width)]))
    for ip, r in enumerate(rows):
        vals = [f"{ip:>5}"] + [f"{r[k]:>18.6g}" for k in keys]
        vals += ["-".rjust(w) if r[c] is None else f"{r[c] / scale:>{w}.5g}" for (c, _, scale), w in zip(cols, width)]
        print(" ".join(vals))


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
                  "no minima (why: /design/errors in the archive)")
            continue
        f = [f"{float(v):>12.5g}" for v in fmin.isel(sel).values]
        d = ds.divergence_speed_rad_s.isel(sel)
        div = [f"{float(d.sel(case=c)):>22.6g}" for c in cases]
        print(" ".join(vals + f + div))
