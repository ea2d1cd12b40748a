"""``fkev runup SCENE``: the linkage along a prescribed crank history, integrated in time by PETSc TS
(TSALPHA2 by default; any TS type and option as ``-fkev_runup_ts_...``), with every link's peak
deflection and stress per revolution (docs/runup.md, docs/theory.md §21). Wiring only: the run is
``Study.runup`` (fkev_slepc/api/runup.py)."""

from __future__ import annotations

import json
import sys

import numpy as np

from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.status import EXIT_OK
from .common import add_elements_argument, load_checked, preflight, report_scene_error

FLAGS = {"speed": "--speed", "revolutions": "--revolutions", "ramp": "--ramp", "duration": "--duration",
         "case": "--case", "reduce": "--reduce", "steps_per_revolution": "--steps-per-revolution", "start": "--start"}


def add_parser(sub) -> None:
    p = sub.add_parser(
        "runup", help="run-up in time (PETSc TS): deflection and stress per revolution along a crank history",
        description="The elastic coordinates along a prescribed crank history, M(θ)q̈ + C(θ,Ω)q̇ + K(θ,Ω,α)q = "
        "f(θ,Ω,α) with the exact coefficients of the periodic system at the speed Ω(t) and crank acceleration α(t) of "
        "the moment, integrated by PETSc TS (TSALPHA2; PETSc options -fkev_runup_ts_type, -fkev_runup_ts_adapt_type "
        "basic, -fkev_runup_ts_alpha_radius ...). From the rest deflection (the quasi-static deflection under the "
        "loads at the first angle and speed). Output per revolution: time, speed, every link's peak deflection and "
        "stress.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--speed", type=float, metavar="W", help="constant crank speed, rad/s (with --revolutions)")
    p.add_argument("--revolutions", type=float, metavar="N", help="revolutions at --speed")
    p.add_argument("--ramp", metavar="W0:W1", help="a linear speed ramp from W0 to W1, rad/s (with --duration): "
                   "θ = W0 t + (W1 - W0) t²/(2T)")
    p.add_argument("--duration", type=float, metavar="T", help="duration of the --ramp, s")
    p.add_argument("--case", default="full", help="case name or Table 3.1 number")
    p.add_argument("--reduce", default=None, metavar="none|links|links:N|N|moving:R",
                   help="the Floquet map's bases, one for the whole run: links (component modes in link frames, "
                   "the default modes per link), links:N, N frozen modes per angle or moving:R, the frozen ones at "
                   "the largest speed of the history (default none: the full model)")
    p.add_argument("--steps-per-revolution", type=int, default=256, metavar="K",
                   help="fixed step 2π/(|Ω|max K) (at constant speed a revolution is K steps)")
    p.add_argument("--start", choices=("static", "zero"), default="static",
                   help="initial state: the rest deflection K⁻¹f with zero rate, or zero")
    add_elements_argument(p)
    p.add_argument("--output", "-o", metavar="PATH.h5", help="HDF5 product, rewritten at every checkpoint")
    p.add_argument("--resume", action="store_true", help="with -o: continue an interrupted run from its checkpoint")
    p.add_argument("--plot", metavar="FIG", help="peak stress (or deflection) per revolution vs speed and time")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def _parse(args):
    from fkev_slepc.api.runup import parse_ramp

    ramp = None
    bad = []
    if args.ramp is not None:
        try:
            ramp = parse_ramp(args.ramp)
        except ValueError as err:
            bad.append(Problem("--ramp", str(err).removeprefix("--ramp: ")))
    if args.duration is not None and not (np.isfinite(args.duration) and args.duration > 0):
        bad.append(Problem("--duration", f"must be a time > 0, s (got {args.duration!r})"))
    if args.resume and not args.output:
        bad.append(Problem("--resume", "needs -o FILE (the product whose checkpoint it continues)"))
    if bad:
        raise SceneError(args.scene, bad)
    return ramp


def run(args) -> int:
    from fkev_slepc.api.runup import checked_runup, study_runup

    try:
        ramp = _parse(args)
        scene = load_checked(args.scene, args.elements, check_angles=False)
        history = dict(speed=args.speed, revolutions=args.revolutions, ramp=ramp, duration=args.duration)
        checked_runup(scene, history, args.case, args.reduce, args.steps_per_revolution, args.start, FLAGS)
        preflight(scene, args, plots=("plot",), output=args.output, periodic=True)
        bar = _progress(args)
        try:
            res = study_runup(scene, **history, case=args.case, reduce=args.reduce, start=args.start,
                              steps_per_revolution=args.steps_per_revolution, output=args.output, resume=args.resume,
                              progress=bar, names=FLAGS)
        finally:
            if bar is not None:
                bar.close()
    except SceneError as err:
        return report_scene_error(err)
    if args.plot:
        res.plot(args.plot)
    d = res.as_dict()
    if args.json:
        json.dump(d, sys.stdout)
        print()
    else:
        _print(d)
    return EXIT_OK


class _Bar:
    """tqdm on stderr over the simulated time (s), updated at most every 1 % of it."""

    def __init__(self):
        from tqdm import tqdm

        self.bar = tqdm(total=1.0, file=sys.stderr, unit="run", bar_format="{l_bar}{bar}| {elapsed}<{remaining}")
        self.shown = 0.0

    def __call__(self, t, duration):
        f = min(t / duration, 1.0)
        if f - self.shown >= 0.01 or f >= 1.0:
            self.bar.update(f - self.shown)
            self.shown = f

    def close(self):
        self.bar.close()


def _progress(args):
    return None if getattr(args, "quiet", 0) else _Bar()


def _print(d: dict) -> None:
    kind = (f"constant speed {d['w0_rad_s']:g} rad/s" if d["history"] == "constant"
            else f"ramp {d['w0_rad_s']:g} -> {d['w1_rad_s']:g} rad/s")
    print(f"{d['scene']}: run-up, {kind} over {d['duration_s']:.6g} s, case {d['case']}, {d['coordinates']} "
          f"coordinates ({d['reduce']}), {d['steps']} {d['ts_type']} steps")
    n = len(d["time_s"])
    for name, link in d["links"].items():
        D = np.array([np.nan if x is None else x for x in link["peak_deflection_m"]], float)
        S = np.array([np.nan if x is None else x for x in link["peak_stress_pa"]], float)
        if not n:
            continue
        k = int(np.nanargmax(D))
        stress = f", peak |σ| {np.nanmax(S) / 1e6:.4g} MPa" if np.isfinite(S).any() else ""
        print(f"  {name}: peak deflection {D[k]:.4g} m in revolution {k + 1} of {n} (t = {d['time_s'][k]:.4g} s, "
              f"Ω = {d['speed_rad_s'][k]:.5g} rad/s){stress}")
