"""``fkev response``: the steady periodic elastic response at a crank speed: deflections,
bending moments, axial forces and extreme-fibre stresses at stations along the links over one
revolution (docs/response.md §3-4). Wiring only; the physics is in fkev_slepc/periodic/ (response, harmonic_balance, shooting, stations)."""

from __future__ import annotations

import json
import sys

import numpy as np

from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.periodic.steady import SharedModel
from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, EXIT_OK
from .common import (
    add_elements_argument, add_speed_arguments, add_speeds_arguments, angles_and_gravity, apply_element, chosen_speed,
    load_checked, preflight, report_scene_error,
)

FLAGS = {"speed_rad_s": "--speed", "gravity_m_s2": "--gravity", "angles_deg": "--angles", "case": "--case",
         "harmonics": "--harmonics", "stations": "--station", "elements": "--elements", "reduce": "--reduce"}


def add_parser(sub) -> None:
    p = sub.add_parser(
        "response", help="steady periodic elastic response: deflection and stress over the cycle",
        description="The periodic solution of M(θ)q̈ + C(θ)q̇ + K(θ)q = f(θ) at a constant crank speed, with the "
        "exact periodic coefficients and the rigid-body inertia loads (gravity and the scene's [[loads]] too), by "
        "harmonic balance (one static solve for a lone rotating link); with --shooting cross-checked by shooting on "
        "the monodromy, whose Floquet multipliers say whether the response attracts.")
    p.add_argument("scene", help="scene file (TOML)")
    add_speed_arguments(p)
    add_speeds_arguments(p, "response vs speed instead: peak of every station at these speeds (START:STOP:STEP "
                         "or a,b,c, rad/s), forced resonances n·Ω = ω̄ₖ marked")
    p.add_argument("--case", help="case name or Table 3.1 number (default: full)")
    p.add_argument("--gravity", metavar="GX,GY", help="gravity in the ground frame, m/s² (default: the scene's "
                   "analysis.gravity_m_s2, else none)")
    p.add_argument("--angles", metavar="SPEC", help="output crank angles, deg (default 0:355:5)")
    p.add_argument("--station", action="append", metavar="LINK:S1,S2", help="stations on LINK at these distances "
                   "from its root, m (repeatable; default every link's root, midspan and tip)")
    p.add_argument("--harmonics", type=int, metavar="H", help="harmonics of the balance (default: doubled from 8 "
                   "until the estimated error is below --tol)")
    p.add_argument("--tol", type=float, default=DEFAULTS.harmonic_tol, help="harmonic-balance tolerance (default 1e-8)")
    p.add_argument("--reduce", default=None, metavar="default|none|links|links:N", help="links: solve on each "
                   "link's Craig-Bampton component modes in its own frame (q = W(θ)z plus the static correction of "
                   "the dropped modes; modes per link doubled until stress and deflection change by < 1e-3, the "
                   "truncation stated); links:N: N modes per link, measured against 2N; none: the full model; "
                   f"default: the full model up to {DEFAULTS.full_max_dofs} free DOFs, links above")
    shooting = p.add_mutually_exclusive_group()
    shooting.add_argument("--shooting", action="store_true", help="also shoot on the monodromy: the Floquet "
                          "multipliers (does the response attract?) and a second method's cross-check")
    shooting.add_argument("--no-shooting", action="store_true", help="no monodromy (the default; kept for scripts)")
    add_elements_argument(p)
    p.add_argument("--element", choices=("thesis", "cubic"), help="element type (default: the scene's)")
    p.add_argument("--output", "-o", metavar="PATH.h5", help="archive the response (HDF5, xarray-readable); with "
                   "--speeds an fkev archive (the frozen sweep of the speeds and /response), one speed per unit of "
                   "work over the MPI ranks (mpirun -n N), resumable")
    p.add_argument("--resume", action="store_true", help="with --speeds -o: continue an interrupted run (only the "
                   "pending speeds are solved)")
    p.add_argument("--force", action="store_true", help="with --speeds -o: replace an existing archive")
    p.add_argument("--plot", metavar="PATH.png", help="the deflected linkage at 4 angles (with --speeds: peak "
                   "response vs speed)")
    p.add_argument("--plot-stations", metavar="PATH.png", help="stress (or moment) vs crank angle per station")
    p.add_argument("--plot-stress", metavar="PATH.png", help="the signed stress range along each link (both faces) "
                   "and σ over the cycle at the critical point")
    p.add_argument("--gif", metavar="PATH.gif", help="animation of the deflected linkage over one revolution")
    p.add_argument("--scale", type=float, help="magnification of the deflections in figures (default: automatic)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def _parse(args):
    from fkev_slepc.sweep.grid import parse_speeds, parse_speeds_rpm

    bad, stations = [], None
    angles, gravity = angles_and_gravity(args, bad)
    if args.station:
        stations = {}
        for text in args.station:
            link, _, values = text.partition(":")
            try:
                stations.setdefault(link, []).extend(float(v) for v in values.split(","))
            except ValueError:
                bad.append(Problem("--station", f"expected LINK:S1,S2,... in m (got {text!r})"))
    for flag, text, parse in (("--speeds", args.speeds, parse_speeds), ("--speeds-rpm", args.speeds_rpm, parse_speeds_rpm)):
        if text is not None:
            try:
                args.speed_list, args.speeds_flag = parse(text), flag
            except ValueError as err:
                bad.append(Problem(flag, str(err)))
    if not (np.isfinite(args.tol) and 0 < args.tol < 1):
        bad.append(Problem("--tol", f"must be in (0, 1) (got {args.tol})"))
    if args.scale is not None and not (np.isfinite(args.scale) and args.scale > 0):
        bad.append(Problem("--scale", f"must be a finite magnification > 0 (got {args.scale})"))
    if bad:
        raise SceneError(args.scene, bad)
    return angles, gravity, stations


def run(args) -> int:
    from fkev_slepc.api.response import study_response

    try:
        angles, gravity, stations = _parse(args)
        scene = apply_element(load_checked(args.scene, args.elements, check_angles=False), args.element)
        scan = args.speeds is not None or args.speeds_rpm is not None
        flags = dict(FLAGS)
        speed = None if scan else chosen_speed(args, scene, flags)
        models = None if scan else SharedModel(scene.analysis.cases)  # the overflow check's and the response's
        preflight(scene, args, speeds=args.speed_list if scan else [speed],
                  speed_flag=args.speeds_flag if scan else flags["speed_rad_s"], plots=("plot", "plot_stations"),
                  output=None if scan else args.output, periodic=True, harmonics=args.harmonics,
                  reduce=args.reduce or "default", model_for=models)
        settings = _settings(args, scene)
        if scan:
            return _vs_speed(args, scene, angles, gravity, stations, settings)
        res = study_response(scene, speed, args.case or "full", angles, gravity_m_s2=gravity,
                             harmonics=args.harmonics, stations=stations, names=flags, settings=settings,
                             reduce=args.reduce, model_for=models)
    except SceneError as err:
        return report_scene_error(err)
    missed = not res.error <= args.tol  # NaN (not estimated) misses too
    if args.output:
        res.save(args.output, {"command_line": " ".join(sys.argv)})
    if args.plot:
        res.plot("deflected", scale=args.scale).savefig(args.plot, dpi=120)
    if args.plot_stations:
        res.plot("stations").savefig(args.plot_stations, dpi=120)
    if args.plot_stress:
        res.plot("stress").savefig(args.plot_stress, dpi=120)
    if args.gif:
        res.animate(args.gif, args.scale)
    d = res.as_dict()
    if args.json:
        json.dump(d, sys.stdout)
        print()
    else:
        _print(d)
    if missed and res.method == "shooting":
        _note(f"fkev response: the shooting's error estimate {res.error:.2g} misses --tol {args.tol:g} at "
              f"{res.shooting_steps} Magnus steps (the most it takes)")
        return EXIT_NOT_CONVERGED
    if missed:
        _note(f"fkev response: the harmonic balance's error estimate {res.hb_error:.2g} misses --tol {args.tol:g} "
              f"at {res.harmonics} harmonics: raise --harmonics (or leave it out: doubled until --tol)")
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _note(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _print(d: dict) -> None:
    print(f"{d['scene']}: steady periodic response at Ω = {d['speed_rad_s']:g} rad/s, case {d['case']}, "
          f"{len(d['crank_angle_deg'])} output angles")
    err = d["harmonic_balance_error"]
    if d["method"] == "shooting":
        print(f"  harmonic balance: {_abandoned(d)}")
        print(f"  response by shooting: {d['shooting_steps']} Magnus steps, estimated error {d['response_error']:.1e}")
    else:
        print(f"  harmonic balance: {d['harmonics']} harmonics, estimated error {err:.1e}" if err is not None else
              f"  harmonic balance: {d['harmonics']} harmonics")
    t = d["truncation"]
    if t is not None:
        state = "converged" if t["converged"] else f"NOT converged to {t['tol']:g}"
        print(f"  link components: {t['modes_per_link']} modes per link ({t['basis']} unknowns per harmonic, modes "
              f"to {t['covered_rad_s']:.4g} rad/s); doubling them changes stress {t['stress']:.1e}, deflection "
              f"{t['deflection']:.1e} ({state})")
    if d["max_abs_multiplier"] is not None:
        verdict = {"attracts": "attracts (every |μ| < 1)",
                   "neutral": "is neutrally stable (max |μ| = 1 within its error: undamped)",
                   "does not attract": "does NOT attract (some |μ| > 1: the machine would not settle on it)"}[
            d["floquet_verdict"]]
        print(f"  Floquet: max |μ| = {d['max_abs_multiplier']:.10g} (±{d['multiplier_error']:.1e}): the response "
              f"{verdict}; shooting vs harmonic balance {d['methods_difference']:.1e}")
    print(f"  {'station':>16} {'transverse (mm)':>22} {'from chord (mm)':>22} {'moment (N m)':>20} "
          f"{'axial force (N)':>20} {'max |σ| (MPa)':>14}")
    for s in d["stations"]:
        env = s["envelope"]
        stress = [v for v in s["stress_pa"] if v is not None]
        smax = f"{max(stress) / 1e6:14.4g}" if stress else f"{'(no c)':>14}"
        print(f"  {s['link'] + ' @ ' + format(s['s_m'], 'g') + ' m':>16} "
              f"{env['transverse_m'][0] * 1e3:10.6g} {env['transverse_m'][1] * 1e3:10.6g}   "
              f"{env['transverse_chord_m'][0] * 1e3:10.6g} {env['transverse_chord_m'][1] * 1e3:10.6g}   "
              f"{env['moment_n_m'][0]:9.4g} {env['moment_n_m'][1]:9.4g}  "
              f"{env['axial_force_n'][0]:9.4g} {env['axial_force_n'][1]:9.4g} {smax}")
    p = d["peak_stress"]
    if p:
        print(f"  peak stress {p['stress_pa'] / 1e6:.4g} MPa on {p['link']} at s = {p['s_m']:g} m, θ = "
              f"{p['crank_angle_deg']:g}°")
    else:
        print("  stresses need each section's fibre distance: give section = {shape = ...} or fibre_distance_m")
    for name, link in d["links"].items():
        q = link["peak"]
        if q:
            print(f"  whole link {name}: peak |σ| {q['stress_pa'] / 1e6:.6g} MPa (σ = {q['sigma_pa'] / 1e6:.6g} MPa, "
                  f"face {q['face']}) at s = {q['s_m']:g} m, θ = {q['crank_angle_deg']:g}°")
    print(f"  largest node deflection {d['max_deflection_m'] * 1e3:.4g} mm (envelopes are min and max over the cycle)")


def _abandoned(d: dict) -> str:
    """Why the balance of a response (``ResponseResult.solution``) was abandoned, in words."""
    hs = ", ".join(str(h) for h, _ in d["levels"])
    es = ", ".join(f"{e:.1e}" for _, e in d["levels"])
    return f"abandoned at {d['harmonics']} harmonics (estimates {es} at H = {hs}: not falling geometrically to the tol)"


def _truncation_cell(sol: dict) -> str:
    """One speed's truncation in a scan's row: the balance's H (or the shooting's steps), the change
    that measures it, the link components' modes and change, and whether it converged to the tol."""
    def num(x):
        return "-" if x is None else f"{x:.1e}"

    cell = (f"HB H={sol['harmonics']} {num(sol['response_error'])}" if sol["method"] == "harmonic balance" else
            f"shot {sol['shooting_steps']} st {num(sol['response_error'])}")
    t = sol.get("truncation")
    if t is not None:
        cell += f", links:{t['modes_per_link']} {num(max(t['stress'], t['deflection']))}"
    return cell + (" yes" if sol["converged"] else " NO")


def _settings(args, scene):
    """The run's PeriodicSettings: the defaults (a speed scan: ``SCAN``) with --tol and --shooting."""
    from fkev_slepc.periodic.settings import SCAN, checked_settings

    base = SCAN if args.speeds is not None or args.speeds_rpm is not None else DEFAULTS
    return checked_settings(scene.source, base, dict(harmonic_tol=args.tol, shoot=args.shooting),
                            {"harmonic_tol": "--tol", "shoot": "--shooting"})


def _vs_speed(args, scene, angles, gravity, stations, settings) -> int:
    from fkev_slepc.api.response_speeds import response_vs_speed
    from fkev_slepc.api.response_archive import archived_response_vs_speed
    from fkev_slepc.sweep.interrupt import SweepInterrupted
    from fkev_slepc.sweep.parallel import install_abort_hook, world
    from fkev_slepc.sweep.session import RunRefused

    options = dict(angles_deg=angles, gravity_m_s2=gravity, harmonics=args.harmonics, settings=settings,
                   stations=stations, names={**FLAGS, "speeds_rad_s": args.speeds_flag}, reduce=args.reduce)
    comm = world() if args.output else None
    rank0 = comm is None or comm.rank == 0
    try:
        if args.output:
            install_abort_hook()
            sp = archived_response_vs_speed(scene, args.speed_list, args.case or "full", args.output,
                                            resume=args.resume, force=args.force, comm=comm,
                                            command_line="fkev " + " ".join(sys.argv[1:]),
                                            notify=None if args.json else _note, **options)
        else:
            sp = response_vs_speed(scene, args.speed_list, args.case or "full", **options)
    except SceneError as err:
        return report_scene_error(err) if rank0 else EXIT_BAD_INPUT
    except (RunRefused, SweepInterrupted) as err:
        if rank0:
            _note(str(err))
        return err.exit_code
    if not rank0:
        return EXIT_OK
    if args.plot:
        sp.plot().savefig(args.plot, dpi=120)
    d = sp.as_dict()
    if args.json:
        json.dump(d, sys.stdout)
        print()
        return _archived_exit(args)
    print(f"{d['scene']}: peak response over the cycle vs speed, case {d['case']}")
    print(f"  {'Ω (rad/s)':>10} {'max |μ|':>10} {'truncation (change, converged)':>36} "
          + " ".join(f"{s['station']:>20}" for s in d["stations"]))
    for i, w in enumerate(d["speed_rad_s"]):
        mu = d["max_abs_multiplier"][i]
        cells = [s["peak_stress_pa"][i] for s in d["stations"]]
        unit, scale = ("MPa", 1e-6) if cells[0] is not None else ("mm", 1e3)
        if unit == "mm":
            cells = [s["peak_transverse_chord_m"][i] for s in d["stations"]]
        trunc = _truncation_cell(d["solution"][i]) if d["solution"] else ""
        print(f"  {w:10.4g} {'' if mu is None else format(mu, '.6f'):>10} {trunc:>36} "
              + " ".join(f"{c * scale:17.4g} {unit}" for c in cells))
    for r in d["forced_resonances"]:
        print(f"  forced resonance {r['order']}·Ω = ω̄{r['mode']} ({r['frequency_rad_s']:.5g} rad/s) at "
              f"Ω ≈ {r['speed_rad_s']:.5g} rad/s")
    return _archived_exit(args)


def _archived_exit(args) -> int:
    """EXIT_NOT_CONVERGED when a speed of the archive failed or missed its tolerance (named on stderr)."""
    if not args.output:
        return EXIT_OK
    from fkev_slepc.status import RETRYABLE, Status, codes
    from fkev_slepc.api.response_archive import read_status

    st = read_status(args.output)
    bad = np.flatnonzero(np.isin(st, codes(RETRYABLE)))
    for i in bad:
        _note(f"fkev response: speed {args.speed_list[i]:g} rad/s is {Status.from_code(int(st[i])).value}: "
              f"message in the archive's /response/errors")
    return EXIT_NOT_CONVERGED if bad.size else EXIT_OK
