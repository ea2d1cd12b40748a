"""``fkev point``: frequencies, eigenvalues and frozen-time stability at one operating point (``Study.point``).

The stability verdict is frozen-time (the matrices held at the crank angle); the verdict over a
crank revolution is ``fkev floquet``'s (docs/stability.md)."""

from __future__ import annotations

import json
import sys

from fkev_slepc.model.plane import Plane
from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.status import CONVERGED, EXIT_NOT_CONVERGED, EXIT_OK
from fkev_slepc.scene.units import RAD_S_PER_RPM, speeds_given_in_rpm, with_rpm
from fkev_slepc.scene.validity import slenderness_warnings
from .sensitivity_table import add_sensitivity_argument, check_sensitivity_keys, print_sensitivities, sensitivities
from .common import (
    preflight,
    add_accuracy_arguments, add_elements_argument, apply_element, as_flags, load_checked, report_scene_error,
    transmission_warning,
)
from fkev_slepc.api import Study



def add_parser(sub) -> None:
    p = sub.add_parser("point", help="solve one operating point (angle, speed, case)",
                       description="Natural frequencies and frozen-time stability at one crank angle, speed and case "
                       "(the verdict over a crank revolution: fkev floquet).")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--angle", type=float, help="crank angle, deg (default: the scene's first)")
    speed = p.add_mutually_exclusive_group()
    speed.add_argument("--speed", type=float, help="crank speed, rad/s (default: the scene's first)")
    speed.add_argument("--speed-rpm", type=float, metavar="RPM", help="crank speed, rev/min")
    p.add_argument("--case", help="case name or Table 3.1 number (default: the scene's first)")
    p.add_argument("--plane", choices=("in", "out"), default="in",
                   help="in: the in-plane problem; out: bending out of the plane and torsion "
                   "(docs/theory.md §19; needs the links' out-of-plane section data)")
    p.add_argument("--modes", type=int, help="number of modes (default: the scene's)")
    add_elements_argument(p)
    add_accuracy_arguments(p)
    add_sensitivity_argument(p)
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default: the scene's)")
    p.add_argument("--cross-check", action="store_true", help="solve with SLEPc and dense QZ and compare")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args) -> int:
    flags = {"speed_rad_s": "--speed-rpm"} if args.speed_rpm is not None else {}
    flags["plane"] = "--plane"
    if not Plane.parse(args.plane).sensitivities and args.sensitivity:  # refused before any work
        return report_scene_error(SceneError(args.scene, [Problem(
            "--sensitivity", f"sensitivities are in plane only (got --plane {args.plane})")]))
    try:
        scene = load_checked(args.scene, args.elements, check_angles=False)  # only --angle matters
        an = scene.analysis
        speed = scene.driver.speeds[0] if args.speed is None else args.speed
        if args.speed_rpm is not None:
            speed = args.speed_rpm * RAD_S_PER_RPM
        check_sensitivity_keys(scene, args.sensitivity)
        scene = apply_element(scene, args.element)
        preflight(scene, args, speeds=[speed], speed_flag="--speed-rpm" if args.speed_rpm is not None else "--speed",
                  plots=())
        res = Study(scene).point(
            an.crank_angles_deg[0] if args.angle is None else args.angle, speed,
            an.cases[0] if args.case is None else args.case,
            modes=args.modes, solver=args.solver, cross_check=args.cross_check, rel_error=args.rel_error,
            plane=args.plane)
    except SceneError as err:  # argument names -> the flags that set them
        return report_scene_error(as_flags(err, flags))

    transmission_warning(res.transmission_angle_deg, res.angle_deg)
    try:
        sens = sensitivities(res, args.sensitivity)
    except SceneError as err:
        return report_scene_error(err)
    rpm = args.speed_rpm is not None or (args.speed is None and speeds_given_in_rpm(scene.source_text))
    out = res.as_dict()
    out["speed_rpm"] = res.speed_rad_s / RAD_S_PER_RPM if rpm else None
    out["validity_warnings"] = slenderness_warnings(scene)  # scene/validity.py: Euler-Bernoulli > 1 % off
    if sens:
        out["sensitivity"] = sens
    if args.json:
        json.dump(out, sys.stdout, indent=1)
        print()
    else:
        _print_table(out, args.scene)
        print_sensitivities(sens)
    return EXIT_OK if res.status in CONVERGED else EXIT_NOT_CONVERGED


def _print_table(o: dict, scene: str = "SCENE") -> None:
    kind = Plane.parse(o["plane"])
    plane = "" if kind.primary else f", {kind.label}"
    print(f"{o['scene']}: θ = {o['angle_deg']:g}°, Ω = {with_rpm(o['speed_rad_s'], o['speed_rpm'] is not None)}, "
          f"case {o['case']}{plane}, {o['n_free']} DOFs, {o['kind']} problem, solver {o['solver']}")
    print(f"{'mode':>4} {'f [Hz]':>14} {'Re λ [1/s]':>14} {'Im λ [1/s]':>14} {'ζ':>11} {'residual':>10}")
    rows = zip(o["frequency_hz"], o["eigenvalue"], o["damping_ratio"], o["residual"])
    for i, (f, (re, im), z, r) in enumerate(rows, 1):
        fmt = lambda v, w: f"{v:{w}.6g}" if v is not None else f"{'—':>{w}}"  # noqa: E731
        zeta = f"{z:11.3e}" if z is not None else f"{'—':>11}"
        print(f"{i:>4} {fmt(f, 14)} {fmt(re, 14)} {fmt(im, 14)} {zeta} {fmt(r, 10) if r is None else f'{r:10.1e}'}")
    print(f"max Re λ = {o['max_real']!r} 1/s; divergence: {o['stability_scope']['divergence']}; "
          f"frozen-time status: {o['status']}"
          + (f"; divergent (real) eigenvalues: {o['divergent']}" if o["divergent"] else "")
          + (f" ({o['message']})" if o["message"] else ""))
    worst = max((r for r in o["residual"] if r is not None), default=None)
    pairs = (f"every reported pair accepted (largest pair error {worst:.1e} <= max_pair_error {o['max_pair_error']:g})"
             if o["pairs_accepted"] else "pairs NOT accepted: the frequencies are not trustworthy")
    print(f"accuracy: {pairs}; frozen-time stability: {growing(o['unstable_modes'])}")
    if o["speed_rad_s"] != 0 and not kind.primary:
        print(f"frozen-time: the matrices held at θ = {o['angle_deg']:g}°; whether vibration grows over a crank "
              f"revolution is the Floquet verdict: fkev floquet {scene} --plane out --speeds {o['speed_rad_s']:g} "
              f"--case {o['case']}")
    elif o["speed_rad_s"] != 0:
        print(f"frozen-time: the matrices held at θ = {o['angle_deg']:g}°; whether vibration grows over a crank "
              f"revolution is the Floquet verdict: fkev floquet {scene} --speeds {o['speed_rad_s']:g} --case {o['case']}")
    if "rel_error_estimate" in o:
        a = o["accuracy"]
        print(f"requested rel_error {a['rel_error']:g}: element {a['element']}, {a['elements_per_link']} elements per "
              f"link, estimated max relative error {o['rel_error_estimate']:.1e}")
    if "cross_check_max_rel_diff" in o:
        print(f"cross-check SLEPc vs dense: max relative frequency difference {o['cross_check_max_rel_diff']:.2e}")


def growing(modes: list[int]) -> str:
    """The frozen-time stability words for the modes that grow.

    Examples
    --------
    >>> growing([]), growing([2]), growing([1, 2])
    ('no reported mode grows', 'mode 2 grows (damping ratio < -analysis.damping_tol)', \
'modes 1, 2 grow (damping ratio < -analysis.damping_tol)')
    """
    if not modes:
        return "no reported mode grows"
    words = f"modes {', '.join(map(str, modes))} grow" if len(modes) > 1 else f"mode {modes[0]} grows"
    return words + " (damping ratio < -analysis.damping_tol)"
