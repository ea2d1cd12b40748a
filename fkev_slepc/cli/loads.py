"""``fkev loads``: joint forces, guide reactions, link axial forces and the driving torque over
the crank cycle at one crank speed (rigid-body kinetostatics, docs/response.md §1). Wiring only;
the physics is in fkev_slepc/model/joint_loads.py."""

from __future__ import annotations

import csv
import json
import sys

import numpy as np

from fkev_slepc.scene import SceneError
from fkev_slepc.status import EXIT_OK
from .common import (
    add_elements_argument, add_speed_arguments, angles_and_gravity, chosen_speed, load_checked, preflight,
    report_scene_error,
)
from fkev_slepc.api.loads import study_loads
from fkev_slepc.model.buckling import weak_axis_buckling
from fkev_slepc.model.mechanism import build_mechanism

FLAGS = {"speed_rad_s": "--speed", "accel_rad_s2": "--accel", "gravity_m_s2": "--gravity",
         "angles_deg": "--angles"}


def add_parser(sub) -> None:
    p = sub.add_parser(
        "loads", help="joint forces and driving torque over the crank cycle (kinetostatics)",
        description="Rigid-body kinetostatics at one crank speed: every joint's force (ground frame, and along/"
        "normal to each link), the sliders' guide reactions and wrist-pin forces (the block a body of its own), "
        "every pin's force on each link it joins in that link's frame, each link's axial force, and the driving "
        "torque with the power check τΩ + P_process = dE/dt; the scene's [[loads]] (process loads) included. "
        "Ground joints report the bearing reaction on the linkage; a moving pin the force on the first link end "
        "its connects names.")
    p.add_argument("scene", help="scene file (TOML)")
    add_speed_arguments(p)
    p.add_argument("--accel", type=float, metavar="A", help="crank acceleration, rad/s² (default: the scene's)")
    p.add_argument("--gravity", metavar="GX,GY", help="gravity in the ground frame, m/s² (default: the scene's "
                   "analysis.gravity_m_s2, else none), e.g. 0,-9.81")
    p.add_argument("--angles", metavar="SPEC", help="crank angles, deg: START:STOP:STEP or a,b,c "
                   "(default: the scene's)")
    add_elements_argument(p)
    p.add_argument("--csv", metavar="PATH", help="write every angle's forces as CSV ('-': stdout)")
    p.add_argument("--output", "-o", metavar="PATH.h5", help="archive the loads (HDF5, xarray-readable)")
    p.add_argument("--plot", metavar="PATH.png", help="joint-force polar plot and torque vs crank angle")
    p.add_argument("--polar", choices=("ground", "link"), default="ground",
                   help="the polar plot's frame: ground (each joint's force) or link (every pin's force on each "
                   "link it joins, relative to that link's axis: what a journal bearing on the link sees)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def _parse(args):
    bad = []
    angles, gravity = angles_and_gravity(args, bad)
    if bad:
        raise SceneError(args.scene, bad)
    return angles, gravity


def run(args) -> int:
    try:
        angles, gravity = _parse(args)
        scene = load_checked(args.scene, args.elements, check_angles=angles is None)
        flags = dict(FLAGS)
        speed = chosen_speed(args, scene, flags)
        preflight(scene, args, speeds=[speed], output=args.output)
        loads = study_loads(scene, speed, angles, args.accel, gravity, names=flags)
    except SceneError as err:
        return report_scene_error(err)
    if args.output:
        loads.save(args.output, {"command_line": " ".join(sys.argv)})
    if args.plot:
        loads.plot(args.polar).savefig(args.plot, dpi=120)
    if args.csv:
        _csv(loads, args.csv)
    buckling = _buckling(scene, loads)
    if args.json:
        json.dump({**loads.as_dict(), "buckling": {b.link: b.as_dict() for b in buckling}}, sys.stdout)
        print()
    elif args.csv != "-":
        _table(loads)
        for b in buckling:
            if b.factor is not None:
                print(f"  link {b.link}: weak-axis buckling factor {b.factor:.4g} (P_cr = {b.euler_load_n:.6g} N, "
                      f"K = {b.length_factor:g}, N_min = {b.min_axial_force_n:.6g} N at θ = {b.crank_angle_deg:g}°)")
    for b in buckling:
        if b.warning():
            print(f"{args.scene}: warning: {b.warning()}", file=sys.stderr, flush=True)
    return EXIT_OK


def _buckling(scene, loads):
    """The weak-axis Euler margins of the links (fkev_slepc/model/buckling.py)."""
    return weak_axis_buckling(build_mechanism(scene), loads)


def _csv(loads, path) -> None:
    out = sys.stdout if path == "-" else open(path, "w", newline="")
    w = csv.writer(out)
    head = ["crank_angle_deg", "driving_torque_n_m", "power_w"]
    for name in loads.joint_names:
        head += [f"{name}_fx_n", f"{name}_fy_n", f"{name}_magnitude_n"]
    sliders = [jj for jj in range(len(loads.joint_names)) if not np.isnan(loads.pin_force[:, jj]).all()]
    pairs = [(jj, lk, k) for jj, here in enumerate(loads.attach) for lk, k in here]
    head += [f"{loads.joint_names[jj]}_pin_{c}_n" for jj in sliders for c in ("fx", "fy")]
    head += [f"{loads.joint_names[jj]}_in_{loads.link_names[lk]}_{c}_n" for jj, lk, _ in pairs for c in ("along", "normal")]
    head += [f"{name}_{c}" for name in loads.process_names for c in ("fx_n", "fy_n", "moment_n_m")]
    w.writerow(head + ["process_power_w"])
    mag = loads.joint_magnitude
    for a in range(loads.theta.size):
        row = [loads.crank_angle_deg[a], loads.torque[a], loads.power[a]]
        for jj in range(len(loads.joint_names)):
            row += [*loads.joint_force[a, jj], mag[a, jj]]
        row += [v for jj in sliders for v in loads.pin_force[a, jj]]
        row += [v for _, lk, k in pairs for v in (loads.bearing_along[a, lk, k], loads.bearing_normal[a, lk, k])]
        for i in range(len(loads.process_names)):
            row += [*loads.process_force[a, i], loads.process_moment[a, i]]
        w.writerow([f"{v:.10g}" for v in row + [loads.process_power[a]]])
    if out is not sys.stdout:
        out.close()


def _table(loads) -> None:
    d = loads.as_dict()
    print(f"{loads.title}: Ω = {loads.speed:g} rad/s, α = {loads.accel:g} rad/s², g = "
          f"({loads.gravity[0]:g}, {loads.gravity[1]:g}) m/s², {loads.theta.size} crank angles")
    names = loads.joint_names
    print("  " + f"{'θ (deg)':>8} {'τ (N m)':>12} " + " ".join(f"{'|F_' + n + '| (N)':>14}" for n in names))
    mag = loads.joint_magnitude
    for a in range(loads.theta.size):
        print("  " + f"{loads.crank_angle_deg[a]:8.2f} {loads.torque[a]:12.5g} "
              + " ".join(f"{m:14.6g}" for m in mag[a]))
    deg = loads.crank_angle_deg
    for jj, name in enumerate(names):
        k = int(np.nanargmax(mag[:, jj]))
        kind = d["joints"][name]["kind"]
        print(f"  joint {name} ({kind}): peak |F| {mag[k, jj]:.6g} N at θ = {deg[k]:g}°"
              + (" (guide reaction)" if kind == "prismatic" else ""))
        if kind == "prismatic":
            pin = np.hypot(*loads.pin_force[:, jj].T)
            k = int(np.nanargmax(pin))
            print(f"    wrist pin (link end on the block): peak |F| {pin[k]:.6g} N at θ = {deg[k]:g}°")
        for lk, pt in loads.attach[jj]:
            along, normal = loads.bearing_along[:, lk, pt], loads.bearing_normal[:, lk, pt]
            print(f"    on {loads.link_names[lk]}, its frame: along {_range(along, deg)}; normal {_range(normal, deg)}")
    for i, name in enumerate(loads.process_names):
        f = np.hypot(*loads.process_force[:, i].T)
        k = int(np.nanargmax(f))
        print(f"  process load {name}: peak |F| {f[k]:.6g} N at θ = {deg[k]:g}°, peak |M| "
              f"{np.nanmax(np.abs(loads.process_moment[:, i])):.6g} N m")
    for lk, name in enumerate(loads.link_names):
        _, N = loads.link_axial(lk)
        print(f"  link {name}: axial force from {np.nanmin(N):.6g} to {np.nanmax(N):.6g} N (tension > 0)")
    print(f"  driving torque from {np.nanmin(loads.torque):.6g} to {np.nanmax(loads.torque):.6g} N m; "
          f"power check max|τΩ{' + P_process' if loads.process_names else ''} − dE/dt| / max|τΩ| = "
          f"{loads.power_residual:.2e}")


def _range(x, deg) -> str:
    """``from a (θ°) to b N (θ°)``: the extremes of a force over the angles and where."""
    lo, hi = int(np.nanargmin(x)), int(np.nanargmax(x))
    return f"{x[lo]:.6g} N ({deg[lo]:g}°) to {x[hi]:.6g} N ({deg[hi]:g}°)"
