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
from .common import add_elements_argument, angles_and_gravity, load_checked, preflight, report_scene_error

FLAGS = {"speed_rad_s": "--speed", "accel_rad_s2": "--accel", "gravity_m_s2": "--gravity",
         "angles_deg": "--angles"}


def add_parser(sub) -> None:
    p = sub.add_parser(
        "loads", help="joint forces and driving torque over the crank cycle (kinetostatics)",
        description="Rigid-body kinetostatics at one crank speed: every joint's force (ground frame, and along/"
        "normal to each link), the sliders' guide reactions, each link's axial force, and the driving torque "
        "with the power check τΩ = dE/dt. Ground joints report the bearing reaction on the linkage; a moving "
        "pin the force on the first link end its connects names.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--speed", type=float, metavar="W", help="crank speed, rad/s (default: the scene's highest)")
    p.add_argument("--accel", type=float, metavar="A", help="crank acceleration, rad/s² (default: the scene's)")
    p.add_argument("--gravity", metavar="GX,GY", help="gravity in the ground frame, m/s² (default: the scene's "
                   "analysis.gravity_m_s2, else none), e.g. 0,-9.81")
    p.add_argument("--angles", metavar="SPEC", help="crank angles, deg: START:STOP:STEP or a,b,c "
                   "(default: the scene's)")
    add_elements_argument(p)
    p.add_argument("--csv", metavar="PATH", help="write every angle's forces as CSV ('-': stdout)")
    p.add_argument("--output", "-o", metavar="PATH.h5", help="archive the loads (HDF5, xarray-readable)")
    p.add_argument("--plot", metavar="PATH.png", help="joint-force polar plot and torque vs crank angle")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def _parse(args):
    bad = []
    angles, gravity = angles_and_gravity(args, bad)
    if bad:
        raise SceneError(args.scene, bad)
    return angles, gravity


def run(args) -> int:
    from fkev_slepc.api.loads import study_loads

    try:
        angles, gravity = _parse(args)
        scene = load_checked(args.scene, args.elements, check_angles=angles is None)
        speed = max(scene.driver.speeds, key=abs) if args.speed is None else args.speed
        preflight(scene, args, speeds=[speed], output=args.output)
        loads = study_loads(scene, speed, angles, args.accel, gravity, names=FLAGS)
    except SceneError as err:
        return report_scene_error(err)
    if args.output:
        loads.save(args.output, {"command_line": " ".join(sys.argv)})
    if args.plot:
        loads.plot().savefig(args.plot, dpi=120)
    if args.csv:
        _csv(loads, args.csv)
    if args.json:
        json.dump(loads.as_dict(), sys.stdout)
        print()
    elif args.csv != "-":
        _table(loads)
    return EXIT_OK


def _csv(loads, path) -> None:
    out = sys.stdout if path == "-" else open(path, "w", newline="")
    w = csv.writer(out)
    head = ["crank_angle_deg", "driving_torque_n_m", "power_w"]
    for name in loads.joint_names:
        head += [f"{name}_fx_n", f"{name}_fy_n", f"{name}_magnitude_n"]
    w.writerow(head)
    mag = loads.joint_magnitude
    for a in range(loads.theta.size):
        row = [loads.crank_angle_deg[a], loads.torque[a], loads.power[a]]
        for jj in range(len(loads.joint_names)):
            row += [*loads.joint_force[a, jj], mag[a, jj]]
        w.writerow([f"{v:.10g}" for v in row])
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
    for jj, name in enumerate(names):
        k = int(np.nanargmax(mag[:, jj]))
        print(f"  joint {name} ({d['joints'][name]['kind']}): peak |F| {mag[k, jj]:.6g} N at θ = "
              f"{loads.crank_angle_deg[k]:g}°")
    for lk, name in enumerate(loads.link_names):
        _, N = loads.link_axial(lk)
        print(f"  link {name}: axial force from {np.nanmin(N):.6g} to {np.nanmax(N):.6g} N (tension > 0)")
    print(f"  driving torque from {np.nanmin(loads.torque):.6g} to {np.nanmax(loads.torque):.6g} N m; "
          f"power check max|τΩ − dE/dt| / max|τΩ| = {loads.power_residual:.2e}")
