"""``fkev drive``: the rigid machine's steady cycle with the scene's ``[drive]`` (motor, gear,
flywheel): crank speed, acceleration and time over the revolution, the mean speed, the
coefficient of speed fluctuation and the flywheel for a requested one (docs/theory.md §20).
Wiring only; the physics is in fkev_slepc/model/drive_cycle.py."""

from __future__ import annotations

import json
import sys

import numpy as np

from fkev_slepc.api.drive import study_drive
from fkev_slepc.scene import SceneError
from fkev_slepc.status import EXIT_OK
from .common import load_checked, preflight, report_scene_error

FLAGS = {"fluctuation": "--fluctuation"}


def add_parser(sub) -> None:
    p = sub.add_parser(
        "drive", help="speed fluctuation over the cycle with the scene's motor and flywheel ([drive])",
        description="The rigid machine's periodic steady state (Eksergian's equation, docs/theory.md §20): the "
        "scene's [drive] motor (torque against speed), gear and flywheel turn the linkage, whose equivalent "
        "inertia J(θ) and process loads and gravity (as the load torque of fkev loads at rest) make the crank "
        "speed fluctuate. Prints the mean speed, the coefficient of fluctuation δ = (ω_max − ω_min)/ω_mean and "
        "the motor torque; with --fluctuation the flywheel inertia (motor shaft) for that δ.")
    p.add_argument("scene", help="scene file (TOML) with a [drive] section")
    p.add_argument("--fluctuation", type=float, metavar="D",
                   help="requested coefficient of speed fluctuation δ (0 < D < 1): report the flywheel for it")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--output", "-o", metavar="PATH.h5", help="archive the cycle (HDF5, checksummed: fkev verify)")
    p.add_argument("--plot", metavar="PATH.png", help="speed and torques over the cycle")
    p.set_defaults(func=run)


def run(args) -> int:
    quiet = getattr(args, "quiet", 0) or args.json

    def progress(k, flywheel, delta):
        if not quiet:
            print(f"  flywheel iteration {k}: J_f = {flywheel:.8g} kg m², δ = {delta:.8g}", file=sys.stderr, flush=True)

    try:
        scene = load_checked(args.scene, check_angles=False)
        preflight(scene, args, output=args.output)
        result = study_drive(scene, args.fluctuation, progress=progress, names=FLAGS)
    except SceneError as err:
        return report_scene_error(err)
    if args.output:
        result.save(args.output, {"command_line": " ".join(sys.argv)})
    if args.plot:
        result.plot().savefig(args.plot, dpi=120)
    if args.json:
        json.dump(result.as_dict(), sys.stdout)
        print()
    else:
        _summary(result)
    return EXIT_OK


def _summary(result) -> None:
    c, d = result.cycle, result.cycle.drive
    deg = np.degrees(c.theta)
    lo, hi = int(np.argmin(c.speed)), int(np.argmax(c.speed))
    print(f"{result.title}: steady cycle with the [drive] (gear ratio {d.gear_ratio:g}, motor {d.motor_inertia:g} + "
          f"flywheel {d.flywheel_inertia:g} kg m² on the motor shaft), {c.theta.size} crank angles")
    print(f"  mean speed {c.mean_speed:.8g} rad/s ({c.mean_speed * 30 / np.pi:.6g} rpm), period {c.period:.8g} s")
    print(f"  speed from {c.speed_min:.8g} rad/s (near {deg[lo]:g}°) to {c.speed_max:.8g} rad/s (near {deg[hi]:g}°)")
    print(f"  coefficient of fluctuation δ = {c.fluctuation:.6g} (energy method: {c.energy_estimate:.6g})")
    print(f"  crank acceleration from {c.accel.min():.6g} to {c.accel.max():.6g} rad/s²")
    print(f"  motor torque from {c.motor_torque.min():.6g} to {c.motor_torque.max():.6g} N m (motor shaft); "
          f"load torque from {c.load_torque.min():.6g} to {c.load_torque.max():.6g} N m")
    if result.fluctuation_requested is not None:
        print(f"  flywheel for δ = {result.fluctuation_requested:g}: {result.flywheel:.8g} kg m² on the motor shaft")
