"""``fkev critical``: from what crank speed does the linkage buckle (divergence) or flutter, frozen-time?

Both are frozen-time speeds: the matrices held at a crank angle. Whether vibration grows over a
crank revolution, and in which speed bands, is ``fkev floquet``'s answer.

Wiring only; the physics is in fkev_slepc/solve/critical.py (docs/stability.md).
"""

from __future__ import annotations

import json
import sys

import numpy as np

from fkev_slepc.model.plane import Plane
from fkev_slepc.scene import SceneError
from fkev_slepc.status import EXIT_OK
from .common import add_model_arguments, as_flags, load_checked, report_scene_error
from fkev_slepc.api import Study
from fkev_slepc.solve.critical import DEFAULT_MAX_FACTOR
from fkev_slepc.solve.stability import FROZEN_TIME


def add_parser(sub) -> None:
    p = sub.add_parser(
        "critical", help="divergence (buckling) and flutter onset speeds",
        description="Lowest crank speed at which K(Ω) = K₀ + Ω²K₂ becomes singular (divergence, an "
        "eigenproblem in Ω²) and lowest speed at which the smallest damping ratio of the reported modes "
        "crosses 0 on its way below -damping_tol (flutter), at one crank angle or the lowest over the "
        "scene's angles. -q: the two speeds only.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--case", help="case name or Table 3.1 number (default: the scene's first)")
    p.add_argument("--angle", type=float, help="crank angle, deg (default: every angle of the scene)")
    p.add_argument("--max-speed", type=float, metavar="W",
                   help="highest crank speed considered, rad/s (default: divergence unbounded; flutter "
                   f"searched up to the divergence speed, else {DEFAULT_MAX_FACTOR:g}x the scene's top speed)")
    p.add_argument("--modes", type=int, help="modes whose damping is watched (default: the scene's)")
    p.add_argument("--plane", choices=("in", "out"), default="in",
                   help="in: the in-plane problem; out: bending out of the plane and torsion, whose divergence "
                   "is the weak-axis buckling of a compressed link (docs/theory.md §19)")
    add_model_arguments(p)
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args) -> int:
    try:
        scene = load_checked(args.scene, args.elements, check_angles=args.angle is None)
        with Study(scene, None) as study:
            found = study.critical(scene.analysis.cases[0] if args.case is None else args.case, args.angle,
                                   args.max_speed, args.modes, args.solver, args.plane)
            n_free = study.pool.model(found.case, args.plane).n_free
    except SceneError as err:  # API argument names -> this command's flags
        return report_scene_error(as_flags(err, {"plane": "--plane"}))
    out = {"scene": scene.title, "plane": args.plane, "n_free": n_free, **found.as_dict(),
           "max_speed_rad_s": args.max_speed,
           "stability_scope": {"time": FROZEN_TIME}}
    if args.json:
        json.dump(out, sys.stdout, indent=1)
        print()
    else:
        _print(out, quiet=bool(args.quiet))
    return EXIT_OK


def _speed(v: float, angle: float) -> str:
    return f"{v:.10g} rad/s ({v * 30 / np.pi:.6g} rpm) at θ = {angle:g}°"


def _print(o: dict, quiet: bool = False) -> None:
    """The two speeds; unless ``quiet``, how flutter was searched (one line) and any note
    (what stopped a search), sorted by crank angle and marked with it."""
    per = o["per_angle"]
    kind = Plane.parse(o["plane"])
    plane = "" if kind.primary else f", {kind.label}"
    print(f"{o['scene']}: case {o['case']}{plane}, {o['n_free']} DOFs, {len(per)} crank angle(s); frozen-time "
          "critical speeds (the matrices held at each crank angle)")
    top = o["max_speed_rad_s"]
    if o["divergence_speed_rad_s"] is not None:
        div = "from " + _speed(o["divergence_speed_rad_s"], o["divergence_angle_deg"])
    else:
        div = f"none up to {top:g} rad/s" if top is not None else "none: K(Ω) is nonsingular at every speed"
    print(f"  divergence (K singular): {div}")
    if o["flutter_speed_rad_s"] is not None:
        flut = "from " + _speed(o["flutter_speed_rad_s"], o["flutter_angle_deg"])
    else:
        bounds = [r["flutter_search_max_rad_s"] for r in per if r["flutter_scan_points"]]
        flut = f"none up to {min(bounds):g} rad/s" if bounds else "not searched"
    if not kind.flutter:
        print("  frozen-time flutter: none out of plane (K symmetric, no gyroscopic C: docs/theory.md §19.6)")
    else:
        print(f"  frozen-time flutter (min ζ of {o['modes']} modes crosses 0 and falls below -{o['damping_tol']:g}): "
              f"{flut}; unstable speed bands over a revolution: fkev floquet")
    if quiet:
        return
    scanned = [r for r in per if r["flutter_scan_points"]]
    if scanned:
        spacing = sorted({r["flutter_search_max_rad_s"] / r["flutter_scan_points"] for r in scanned})
        span = f"{spacing[0]:.4g}" if len(spacing) == 1 else f"{spacing[0]:.4g}-{spacing[-1]:.4g}"
        print(f"  flutter scanned on {scanned[0]['flutter_scan_points']} speeds per angle (spacing {span} rad/s; "
              f"a dip and return between two is not seen), onset refined to {o['flutter_rtol']:g} relative")
    for r in sorted(per, key=lambda r: r["angle_deg"]):
        for note in r["notes"]:
            print(f"  note, θ = {r['angle_deg']:g}°: {_flag_words(note)}")


def _flag_words(note: str) -> str:
    return note.replace("no maximum speed given", "no --max-speed given")
