"""``fkev floquet SCENE``: does vibration grow over crank revolutions, and in which speed bands?

Wiring only: the run is ``Study.floquet`` (fkev_slepc/api/floquet.py, fkev_slepc/sweep/floquet_run.py),
the bands fkev_slepc/periodic/bands.py, the figure fkev_slepc/plots/floquet.py (docs/stability.md).
"""

from __future__ import annotations

import json
import sys

import numpy as np
from pathlib import Path

from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.scene import SceneError
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, EXIT_OK
from .common import add_elements_argument, add_speeds_arguments, load_checked, preflight

NAMES = {"speeds": "--speeds", "speeds_rpm": "--speeds-rpm", "angles": "--angles", "cases": "--case",
         "modes": "--modes", "element": "--element", "rel_error": "--rel-error", "tol": "--tol", "rtol": "--rtol",
         "monodromy_tol": "--monodromy-tol", "output": "-o", "resonance_order": "--resonance-order",
         "reduce": "--reduce", "plane": "--plane",
         "zeta_floor": "--zeta-floor"}


GAPS_LISTED = 12  # resonance gaps listed in the text report
SAMPLE_WORDS = {"edge": "edge-refinement", "probe": "resonance-probe"}  # /floquet/samples purposes


def add_parser(sub) -> None:
    p = sub.add_parser(
        "floquet", help="Floquet multipliers over a speed range: unstable speed bands and their resonances",
        description="The cycle verdict: Floquet multipliers μ of one crank revolution of the time-periodic linkage "
        "(exact periodic coefficients) at each speed, the edges of every unstable band (max|μ| > 1) refined to "
        "--rtol, each labelled with its resonance 2ω̄ₖ/n or (ω̄ⱼ ± ω̄ₖ)/n of the cycle-mean frozen frequencies, "
        "beside the frozen-time verdicts of the same speeds. Archived (HDF5 /floquet, resumable over MPI ranks).")
    p.add_argument("scene", help="scene file (TOML)")
    add_speeds_arguments(p, "crank speeds > 0, rad/s (default the scene's)")
    p.add_argument("--case", default="full", help="case name or Table 3.1 number (default full)")
    p.add_argument("--angles", metavar="START:STOP:STEP|a,b,c",
                   help="crank angles of the frozen sweep (cycle-mean frequencies, frozen verdicts; default the scene's)")
    p.add_argument("-o", "--output", type=Path, help="archive (default <scene dir>/out/<stem>-floquet.h5)")
    p.add_argument("--tol", type=float, default=None, help="max|μ| - 1 above which (and above 10x the multiplier "
                   "error estimate) a speed is unstable (default 1e-6)")
    p.add_argument("--rtol", type=float, default=None, help="relative accuracy of the band edges (default 1e-6)")
    p.add_argument("--monodromy-tol", type=float, default=None, help="error of the multipliers' moduli asked of the monodromy, relative to max(1, max|mu|) "
                   f"(default {DEFAULTS.monodromy_tol:g})")
    p.add_argument("--zeta-floor", type=float, default=None, metavar="ZETA",
                   help="undamped scene: list a band as surviving real damping only where the modal damping "
                   f"ratio that closes it, ζ*, exceeds ZETA (default {DEFAULTS.zeta_floor:g}; 0: every band); a damped "
                   "scene's verdicts answer for its own damping (docs/stability.md)")
    p.add_argument("--resonance-order", type=int, default=None, metavar="N",
                   help="list the resonance candidates 2ω̄ₖ/n, (ω̄ⱼ ± ω̄ₖ)/n of order n <= N that lie between two stable "
                   "grid speeds, where a band narrower than the spacing would not be seen (default 3; 0: none)")
    p.add_argument("--reduce", default=None, metavar="default|auto|none|N|links|links:N|moving|moving:R",
                   help="reduction of each monodromy: auto (frozen-mode basis grown until max|μ| and the Floquet "
                   "frequencies change < 1e-3, truncation archived), none (full model), N frozen modes per angle, "
                   "links (component modes in link frames, modes per link doubled to the same rule), links:N (N "
                   "fixed-interface modes per link, truncation measured against 2N), moving (the lowest r frozen modes "
                   "followed around the cycle, r doubled from 8 to the same rule: docs/theory.md §18.10), moving:R "
                   "(R modes, truncation against 2R); default (the default), per "
                   f"speed: the full model below {DEFAULTS.auto_min_steps:,} full-model Magnus steps; above, links "
                   f"where {4 * DEFAULTS.link_modes} modes per link are fewer than the free DOFs and need at most "
                   f"1/{DEFAULTS.links_step_ratio:g} of the full model's steps, else auto (docs/engine.md)")
    p.add_argument("--probe-resonances", action="store_true",
                   help="solve one more monodromy at each of those candidates (a band found there is refined)")
    add_elements_argument(p)
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver of the frozen sweep")
    p.add_argument("--plane", choices=("in", "out"), default="in",
                   help="in: the in-plane problem; out: bending out of the plane and torsion (docs/theory.md §19.9; "
                   "default archive <scene dir>/out/<stem>-out-floquet.h5)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run (only pending speeds are solved)")
    p.add_argument("--force", action="store_true", help="replace an existing archive")
    p.add_argument("--plot", type=Path, metavar="FIG", help="also draw max|μ| vs speed with the bands (png, pdf, svg)")
    p.add_argument("--no-critical", action="store_true", help="skip the frozen-time critical speeds (fkev critical)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args) -> int:
    from fkev_slepc.api import Study
    from fkev_slepc.api.floquet import SETTING_NAMES, study_floquet
    from fkev_slepc.periodic.settings import checked_settings
    from fkev_slepc.sweep.interrupt import SweepInterrupted
    from fkev_slepc.sweep.parallel import install_abort_hook, world
    from fkev_slepc.sweep.session import RunRefused

    comm = world()
    install_abort_hook()
    rank0 = comm.rank == 0
    try:
        study = Study(load_checked(args.scene, args.elements, check_angles=False), Path(args.scene))
        preflight(study.scene, args, periodic=True)  # figure path, mesh size, damping; speeds: study_floquet
        settings = checked_settings(study.scene.source, None, dict(  # the defaults, with the flags given
            verdict_tol=args.tol, edge_rtol=args.rtol, monodromy_tol=args.monodromy_tol,
            resonance_order=args.resonance_order, probe=args.probe_resonances or None, reduce=args.reduce,
            zeta_floor=args.zeta_floor),
            {field: NAMES[key] for field, key in SETTING_NAMES.items()})
        res = study_floquet(study, args.speeds, args.case, args.output, speeds_rpm=args.speeds_rpm,
                            angles_deg=args.angles, resume=args.resume, force=args.force, settings=settings,
                            solver=args.solver, comm=comm, critical=not args.no_critical, names=NAMES,
                            command_line="fkev " + " ".join(sys.argv[1:]),
                            notify=None if args.json or args.quiet else _note, plane=args.plane)
    except SceneError as err:
        if rank0:
            print(str(err), file=sys.stderr, flush=True)
        return EXIT_BAD_INPUT
    except RunRefused as err:
        if rank0:
            _note(str(err))
        return err.exit_code
    except SweepInterrupted as err:  # the notice with what to do is already printed
        return err.exit_code
    if not rank0:
        return EXIT_OK
    out = res.as_dict()
    if args.plot is not None:
        from fkev_slepc.plots.floquet import speed_map

        speed_map(res).savefig(args.plot, dpi=130)
        out["figure"] = str(args.plot)
    if args.json:
        json.dump(out, sys.stdout, indent=1)
        print()
    else:
        print("\n".join(lines(out)))
    return EXIT_NOT_CONVERGED if any(s in ("failed", "not_converged") for s in out["status"]) else EXIT_OK


def lines(o: dict) -> list[str]:
    """The text report of ``fkev floquet``."""
    w = o["speed_rad_s"]
    mx = [v - 1.0 for v in o["max_abs_multiplier"] if v is not None]
    n_bad = sum(s == "unstable" for s in o["status"])
    n_open = sum(s in ("failed", "not_converged") for s in o["status"])
    extra = o.get("samples_beside_grid") or {}
    more = ", ".join(f"{n} {SAMPLE_WORDS.get(k, k)} {_plural(n, 'speed')}" for k, n in sorted(extra.items()) if n)
    out = [f"{o['scene']}: case {o['case']}, {_speeds(w)}{f' (and {more})' if more else ''}; archive {o['archive']}",
           f"  cycle verdict (Floquet multipliers of one revolution): {n_bad} of {len(w)} grid {_plural(len(w), 'speed')} "
           f"unstable (max|μ| - 1 > {o['tol']:g} + 10 x error estimate)"
           + (f", {n_open} not converged (no verdict)" if n_open else "") + f"; max|μ| - 1 {_span(mx, '.3g')}"]
    frozen = [100 * v for v in o["frozen_time_unstable_fraction"] if v is not None]
    if frozen:
        out.append(f"  frozen-time verdict of the same speeds: {_span(frozen, '.0f')} % of crank angles unstable or "
                   "divergent")
    out.append(f"  unstable runs (unstable grid speeds in a row, outer edges refined to {o['edge_rtol']:g} relative; "
               "between the grid speeds of a run the verdict is not sampled):" + ("" if o["bands"] else " none"))
    for b in o["bands"]:
        res = f"{b['resonance']} = {b['predicted_rad_s']:.6g} rad/s" if b["resonance"] else "no resonance in range"
        out.append(f"    {_edges(b, o['edge_rtol'])}{_unstable_at(b)}: {res}; max|μ| {b['peak_max_abs_multiplier']:.6g} "
                   f"at {b['peak_rad_s']:g} rad/s{_damping_needed(b)}"
                   + (f" [ζ* below the floor {o['damping']['zeta_floor']:g}: closed by real damping]"
                      if b.get("survives_damping") is False else ""))
    out += _damping_lines(o)
    out += _reduction_lines(o) + _resolution_lines(o) + _gap_lines(o)
    crit = o.get("frozen_time_critical")
    if crit:
        def show(v, a):
            return "none" if v is None else f"{v:.10g} rad/s (θ = {a:g}°)"

        out.append(f"  frozen-time critical speeds up to {crit['max_speed_rad_s']:g} rad/s: divergence "
                   f"{show(crit['divergence_speed_rad_s'], crit['divergence_angle_deg'])}, flutter "
                   f"{show(crit['flutter_speed_rad_s'], crit['flutter_angle_deg'])}")
    return out


def _damping_lines(o: dict) -> list[str]:
    """The damping the verdicts answer for: the scene's own, or an undamped scene's reporting floor
    with how many bands need more damping than it to close."""
    d = o.get("damping")
    if not d:
        return []
    if d["zeta_floor"] is None:
        z = (f" (modal ζ {_span([100 * d['modal_zeta_min'], 100 * d['modal_zeta_max']], '.2g')} % of the frozen modes)"
             if d["modal_zeta_min"] is not None else "")
        return [f"  damping: the verdicts include the scene's Rayleigh damping α = {d['mass_proportional_1_s']:g} 1/s, "
                f"β = {d['stiffness_proportional_s']:g} s{z}"]
    n, k = len(o["bands"]), o["bands_surviving_damping"]
    return [f"  damping: none in the scene; the bands held against the floor ζ = {d['zeta_floor']:g} (--zeta-floor): "
            f"{k} of {n} unstable {_plural(n, 'run')} survive it (ζ* above it, or not estimated), {n - k} close under any "
            "damping at or above it"]


def _damping_needed(b: dict) -> str:
    """'(Re s = x 1/s; closed by modal damping ζ >= z)' for a labelled band (docs/stability.md)."""
    rate, zeta = b.get("growth_rate_1_s"), b.get("suppressing_damping_ratio")
    if rate is None:
        return ""
    return f" (Re s = {rate:.3g} 1/s" + ("" if zeta is None else f"; closed by modal damping ζ >= {zeta:.2g}") + ")"


def _plural(n: int, word: str) -> str:
    return word if n == 1 else word + "s"


def _speeds(w: list) -> str:
    return f"1 speed {w[0]:g} rad/s" if len(w) == 1 else f"{len(w)} speeds {min(w):g}-{max(w):g} rad/s"


def _span(v: list, fmt: str) -> str:
    """'x' for one value (or all equal as printed), else 'from x to y'."""
    if not v:
        return "not computed"
    lo, hi = format(min(v), fmt), format(max(v), fmt)
    return lo if lo == hi else f"from {lo} to {hi}"


def _edges(b: dict, rtol: float) -> str:
    """A band's edges, to the digits ``rtol`` gives; one not located says why (open at the end of
    the speeds examined, or not refined)."""
    fmt = f".{max(4, int(np.ceil(-np.log10(rtol))) + 1)}g"
    missing = "edge not located (a monodromy did not converge)"
    lo = (f"<= {b['unstable_down_to_rad_s']:g}" if b["lower_open"] else
          missing if b["lower_rad_s"] is None else format(b["lower_rad_s"], fmt))
    hi = (f">= {b['unstable_up_to_rad_s']:g}" if b["upper_open"] else
          missing if b["upper_rad_s"] is None else format(b["upper_rad_s"], fmt))
    ends = [end for end, is_open in (("lowest", b["lower_open"]), ("highest", b["upper_open"])) if is_open]
    return f"{lo} to {hi} rad/s" + (f", unstable at the {' and the '.join(ends)} speed examined" if ends else "")


def _unstable_at(b: dict) -> str:
    """Where a run is known to be unstable: its grid speeds (stable speeds can lie between them)."""
    w = b.get("unstable_grid_speeds_rad_s")
    if w is None:
        return ""
    if not w:
        return f" (no grid speed inside; unstable at {b['peak_rad_s']:g} rad/s)"
    if len(w) == 1:
        return f" (unstable at the grid speed {w[0]:g})"
    shown = ", ".join(f"{v:g}" for v in w) if len(w) <= 6 else f"{w[0]:g}, {w[1]:g}, ..., {w[-1]:g} ({len(w)})"
    return f" (unstable at the grid speeds {shown}; between them not sampled)"


def _reduction_lines(o: dict) -> list[str]:
    """Which speeds were solved on a reduced basis (frozen-mode, or link components with the frequency range
    they cover), its size and its measured truncation."""
    size = [b or 0 for b in o.get("basis_size") or []]
    red = [i for i, b in enumerate(size) if b > 0]
    if not red:
        return ["  model: the full model at every grid speed (no frozen-mode reduction)"] if size else []
    pick = lambda key: [o[key][i] for i in red if o.get(key) and o[key][i] is not None]  # noqa: E731
    stuck = sum(not c for c in pick("truncation_converged"))
    covered = [c for c in pick("covered_rad_s") if np.isfinite(c)]
    kind = (f"link component-mode basis (fixed-interface modes up to {_span(covered, '.4g')} rad/s) of " if covered
            else "frozen-mode basis of ")
    return [f"  model: {len(red)} of {len(size)} grid {_plural(len(size), 'speed')} on a {kind}"
            f"{_span([size[i] for i in red], 'd')} vectors; truncation change of max|μ| {_span(pick('truncation_max_abs'), '.2g')}"
            f", of the retained frequencies {_span(pick('truncation_frequency'), '.2g')} (relative)"
            + (f"; {stuck} not converged (basis cap reached)" if stuck else "")]


def _resolution_lines(o: dict) -> list[str]:
    """A warning when bands hold at most one grid speed: others as narrow can lie unseen between stable speeds."""
    thin = [b for b in o["bands"] if b.get("grid_speeds_inside", 2) <= 1]
    if not thin or len(o["speed_rad_s"]) < 2:
        return []
    w = sorted(o["speed_rad_s"])
    step = _span([b - a for a, b in zip(w, w[1:])], ".3g")
    return [f"  resolution: {len(thin)} of {len(o['bands'])} unstable {_plural(len(o['bands']), 'run')} with at most one "
            f"grid speed inside (spacing {step} rad/s): bands as narrow may lie unseen between stable grid speeds, and "
            "stable ones between the unstable speeds of a run; refine --speeds"]


def _gap_lines(o: dict) -> list[str]:
    """The grid's blind spots: resonance candidates between stable speeds, probed or not."""
    gaps, n = o.get("resonance_gaps") or [], o.get("resonance_order", 0)
    if not n or len(o["speed_rad_s"]) < 2:  # one speed has no gaps
        return []
    head = f"  resonance candidates of order n <= {n} between two stable grid speeds (a band narrower than the spacing " \
           "would not be seen there):"
    if not gaps:
        return [head + " none"]
    probed = [g for g in gaps if g["probe_status"]]
    out = [head + f" {len(gaps)}, {len(probed)} probed"]
    for g in gaps[:GAPS_LISTED]:
        lo, hi = g["between_rad_s"]
        verdict = (f"probed: {g['probe_status']}, max|μ| {g['probe_max_abs_multiplier']:.6g}" if g["probe_status"]
                   else "not sampled")
        out.append(f"    {g['resonance']} = {g['predicted_rad_s']:.6g} rad/s (between {lo:g} and {hi:g}): {verdict}")
    if len(gaps) > GAPS_LISTED:
        out.append(f"    ... and {len(gaps) - GAPS_LISTED} more (all in --json: resonance_gaps)")
    if len(probed) < len(gaps):
        out.append("    add a monodromy at each with --probe-resonances (or a finer --speeds grid)")
    return out


def _note(message: str) -> None:
    print(f"fkev floquet: {message}", file=sys.stderr, flush=True)
