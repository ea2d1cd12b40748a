"""``fkev design-check SCENE --speed W``: per link the peak |σ| along the whole link, the static
and fatigue safety factors, the weak-axis buckling factor and the peak pin loads at one crank
speed, and the lowest out-of-plane frequency over the cycle with its crank-order margin
(docs/design.md, "Design check"); exit 3 when a safety factor is below 1. Wiring only; the computation is in
fkev_slepc/design/check.py."""

from __future__ import annotations

import csv
import json
import sys

from fkev_slepc.archive.paths import PathProblem, check_output
from fkev_slepc.periodic.steady import SharedModel
from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.scene.units import RAD_S_PER_RPM, with_rpm
from fkev_slepc.status import EXIT_NOT_CONVERGED, EXIT_OK
from .common import add_elements_argument, angles_and_gravity, load_checked, preflight, report_scene_error

FLAGS = {"speed_rad_s": "--speed", "gravity_m_s2": "--gravity", "angles_deg": "--angles", "case": "--case",
         "harmonics": "--harmonics", "criterion": "--criterion", "threshold": "--buckling-threshold", "tol": "--tol"}
CSV_KEYS = ("peak_stress_pa", "static_sf", "fatigue_sf", "fatigue_criterion", "sigma_mean_pa", "sigma_alternating_pa",
            "buckling_sf", "min_axial_force_n")


def add_parser(sub) -> None:
    from fkev_slepc.design.fatigue import CRITERIA
    from fkev_slepc.model.buckling import WARN_BELOW
    from fkev_slepc.periodic.settings import DEFAULTS

    p = sub.add_parser(
        "design-check", help="per-link stress, safety factors, weak-axis buckling and pin loads at one speed",
        description="The design check at one crank speed: for every link the peak |σ| of the steady periodic "
        "response along the whole link (both faces, every element end), the static safety factor against yield, "
        "the fatigue safety factor (Goodman, Soderberg or Gerber) at its critical point, the weak-axis Euler "
        "buckling factor under the kinetostatic axial force, and the peak pin loads of its joints; with out-of-plane "
        "section data, the lowest out-of-plane frequency over the cycle (frozen-time) and its margin to the crank "
        "orders. Strengths come from the links' [materials].")
    p.add_argument("scene", help="scene file (TOML)")
    speed = p.add_mutually_exclusive_group()
    speed.add_argument("--speed", type=float, metavar="W", help="crank speed, rad/s (default: the scene's highest)")
    speed.add_argument("--speed-rpm", type=float, metavar="RPM", help="crank speed, rev/min")
    p.add_argument("--criterion", default="goodman", choices=CRITERIA, help="fatigue criterion")
    p.add_argument("--buckling-threshold", type=float, default=WARN_BELOW, metavar="F",
                   help="warn below this weak-axis buckling factor")
    p.add_argument("--case", help="case name or Table 3.1 number (default: full)")
    p.add_argument("--gravity", metavar="GX,GY", help="gravity in the ground frame, m/s² (default: the scene's "
                   "analysis.gravity_m_s2, else none)")
    p.add_argument("--angles", metavar="SPEC", help="crank angles of the cycle, deg (default 0:355:5; with a "
                   "fatigue factor no gap over 30 deg around the revolution)")
    p.add_argument("--harmonics", type=int, metavar="H", help="harmonics of the balance (default: doubled from 8 "
                   "until the estimated error is below --tol)")
    p.add_argument("--tol", type=float, default=DEFAULTS.harmonic_tol, help="harmonic-balance tolerance (default 1e-8)")
    add_elements_argument(p)
    p.add_argument("--csv", metavar="PATH", help="write one row per link as CSV ('-': stdout)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args) -> int:
    from fkev_slepc.design.check import design_check

    flags = {**FLAGS, "speed_rad_s": "--speed-rpm"} if args.speed_rpm is not None else FLAGS
    try:
        bad = []
        angles, gravity = angles_and_gravity(args, bad)
        if bad:
            raise SceneError(args.scene, bad)
        if args.json and args.csv == "-":
            raise SceneError(args.scene, [Problem("--csv", "'-' (stdout) with --json would mix CSV into the JSON: "
                                                  "write the CSV to a file, or drop --json (got '-')")])
        scene = load_checked(args.scene, args.elements, check_angles=False)
        speed = (args.speed_rpm * RAD_S_PER_RPM if args.speed_rpm is not None else
                 max(scene.driver.speeds, key=abs) if args.speed is None else args.speed)
        # the checks of fkev response, before any solve: mesh size, harmonics, memory, overflow, the CSV path
        models = SharedModel(scene.analysis.cases)  # the overflow check's and the responses'
        preflight(scene, args, speeds=[speed], speed_flag=flags["speed_rad_s"], plots=(), periodic=True,
                  harmonics=args.harmonics, reduce="default", model_for=models)
        if args.csv not in (None, "-"):
            try:
                check_output(args.csv, (".csv", ".txt"), "--csv")
            except PathProblem as exc:
                raise SceneError(args.scene, [Problem("--csv", str(exc).removeprefix("--csv "))]) from None
        check = design_check(scene, speed, criterion=args.criterion, case=args.case or "full", angles_deg=angles,
                             gravity_m_s2=gravity, harmonics=args.harmonics, tol=args.tol,
                             threshold=args.buckling_threshold, names=flags, model_for=models)
    except SceneError as err:
        return report_scene_error(err)
    d = check.as_dict()
    rpm = args.speed_rpm is not None or scene.driver.speed_unit == "rpm"
    d["speed_rpm"] = check.speed / RAD_S_PER_RPM if rpm else None
    for w in check.warnings:
        print(f"{args.scene}: warning: {w}", file=sys.stderr, flush=True)
    if args.csv:
        _csv(d, args.csv)
    if args.json:
        json.dump(d, sys.stdout)
        print()
    elif args.csv != "-":
        _table(d, rpm)
    for f in check.failures:  # after the table, so the numbers are there to read
        print(f"{args.scene}: error: {f}", file=sys.stderr, flush=True)
    return EXIT_NOT_CONVERGED if check.failures else EXIT_OK  # 3: a safety factor below 1 is a failed check


def _csv(d: dict, path: str) -> None:
    out = sys.stdout if path == "-" else open(path, "w", newline="")
    w = csv.writer(out)
    w.writerow(["link", "material", *CSV_KEYS, "peak_pin_loads_n"])
    for name, lk in d["links"].items():
        pins = ";".join(f"{j}={p['peak_n']:.10g}" for j, p in lk["pin_loads"].items())
        w.writerow([name, lk["material"] or "", *("" if lk[k] is None else lk[k] for k in CSV_KEYS), pins])
    if out is not sys.stdout:
        out.close()


def _num(x, fmt: str, width: int) -> str:
    return f"{'-':>{width}}" if x is None else f"{x:{width}{fmt}}"


def _table(d: dict, rpm: bool) -> None:
    print(f"{d['scene']}: design check at Ω = {with_rpm(d['speed_rad_s'], rpm)}, case {d['case']}, fatigue by "
          f"{d['fatigue_criterion'].capitalize()}")
    print(f"  {'link':<10} {'material':<12} {'peak |σ| (MPa)':>14} {'static SF':>9} {'fatigue SF':>10} "
          f"{'σm (MPa)':>9} {'σa (MPa)':>9} {'buckling SF':>11} {'N_min (N)':>10}  peak pin loads (N)")
    for name, lk in d["links"].items():
        mpa = [None if lk[k] is None else lk[k] / 1e6
               for k in ("peak_stress_pa", "sigma_mean_pa", "sigma_alternating_pa")]
        pins = ", ".join(f"{j} {p['peak_n']:.5g}" for j, p in lk["pin_loads"].items())
        print(f"  {name:<10} {lk['material'] or '-':<12} {_num(mpa[0], '.5g', 14)} {_num(lk['static_sf'], '.3g', 9)} "
              f"{_num(lk['fatigue_sf'], '.3g', 10)} {_num(mpa[1], '.4g', 9)} {_num(mpa[2], '.4g', 9)} "
              f"{_num(lk['buckling_sf'], '.3g', 11)} {lk['min_axial_force_n']:10.5g}  {pins}")
    for name, lk in d["links"].items():
        p = lk["peak"]
        if p:
            where = f"s = {p['s_m']:g} m, face {p['face']}, θ = {p['crank_angle_deg']:g}°"
            print(f"  {name}: peak |σ| at {where}", end="")
            c = lk["critical_point"]
            print(f"; fatigue-critical point s = {c['s_m']:g} m, face {c['face']}" if c else "")
        for note in lk["notes"]:
            print(f"  {name}: {note}")
    print("  buckling SF: weak-axis Euler load π²E·I_out/(K·L)² over the most compressive kinetostatic axial "
          f"force (- : never in compression or no out-of-plane section); warning below {d['buckling_threshold']:g}")
    _out_of_plane(d["out_of_plane"])


def _orders(o: dict) -> str:
    """The crank orders inside the band, or the nearest below and above it with their margins."""
    inside = o["orders_inside"]
    if inside:
        n = f"{inside[0]}Ω" + (f"-{inside[-1]}Ω" if len(inside) > 1 else "")
        return f"; crank orders {n} inside the band (margin 0: crossed every revolution)"
    sides = ((o["below"], "below"), (o["above"], "above"))
    near = [f"{a['order']}Ω {a['margin_percent']:.1f} % {side}" for a, side in sides if a is not None]
    return f"; nearest crank orders {', '.join(near)}" if near else ""


def _out_of_plane(o: dict) -> None:
    """The out-of-plane lines (fkev_slepc/design/out_of_plane.py)."""
    if not o["checked"]:
        print(f"  out of plane: {o['note']}")
        return
    if o["f1_min_hz"] is None:
        print(f"  out of plane: no lowest frequency at any of the {o['n_angles']} crank angles")
    else:
        order = _orders(o)
        print(f"  out of plane: lowest frequency {o['f1_min_hz']:.5g} Hz at θ = {o['angle_min_deg']:g}° "
              f"(band {o['f1_min_hz']:.5g}-{o['f1_max_hz']:.5g} Hz over {o['n_angles']} crank angles, frozen-time){order}")
    if o["divergent_angles_deg"]:
        bad = o["divergent_angles_deg"]
        where = ", ".join(f"{x:g}" for x in bad[:6]) + ("…" if len(bad) > 6 else "")
        print(f"  out of plane: divergent (weak-axis buckling, frozen-time) at θ = {where}°")
    low = "no link in compression" if o["buckling_sf"] is None else \
        f"smallest weak-axis buckling SF {o['buckling_sf']:.3g} (link {o['buckling_link']})"
    print(f"  out of plane: {low}")
