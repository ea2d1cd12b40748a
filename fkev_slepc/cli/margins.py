"""``fkev margins ARCHIVE --speed W``: each mode's frequency band over the whole cycle against the
crank orders n·Ω/2π at an operating speed, the margin table, and the band Campbell diagram
(fkev_slepc/design/margins.py, fkev_slepc/plots/bands.py)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from fkev_slepc.model.plane import Plane
from fkev_slepc.scene.units import RAD_S_PER_RPM
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_OK
from .common import ARCHIVE_FLAGS, add_plane_selection, flag_words


def add_parser(sub) -> None:
    p = sub.add_parser(
        "margins", help="frequency bands over the cycle vs crank orders at an operating speed",
        description="For an operating crank speed W on the archive's grid: each mode's frequency band "
        "(min-max over the crank angles), the crank orders n·W/2π inside or near it, and the margin of the "
        "closest order (%, relative to the band edge it approaches) with the angles where it is closest.")
    p.add_argument("archive", type=Path, help="HDF5 archive written by `fkev run` (several crank angles)")
    speed = p.add_mutually_exclusive_group(required=True)
    speed.add_argument("--speed", type=float, metavar="W", help="operating crank speed, rad/s (on the grid)")
    speed.add_argument("--speed-rpm", type=float, metavar="RPM", help="operating crank speed, rev/min")
    p.add_argument("--case", help="case name or Table 3.1 number (default full, else the archive's first)")
    p.add_argument("--orders", type=int, metavar="N", help="orders n = 1..N (default: one past the highest band)")
    p.add_argument("--order", choices=("tracked", "sorted"),
                   help="modes followed along θ (default when archived) or the k-th lowest at each θ")
    p.add_argument("--modes", type=lambda t: [int(v) for v in t.split(",") if v.strip()], metavar="I[,J]",
                   help="1-based modes (default all archived)")
    p.add_argument("--per-order", type=lambda t: [int(v) for v in t.split(",") if v.strip()], default=[1, 2, 3],
                   metavar="N[,M]", help="orders of the per-order table, one row per mode and order (default 1,2,3)")
    add_plane_selection(p)
    p.add_argument("--plot", type=Path, metavar="FILE", help="also draw the band Campbell diagram (.png/.pdf/.svg)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args) -> int:
    from fkev_slepc.archive.paths import PathProblem, check_output
    from fkev_slepc.archive.reader import ArchiveError, load
    from fkev_slepc.design.margins import margins

    import math

    from .common import PLOT_FORMATS

    given, flag = (args.speed, "--speed") if args.speed is not None else (args.speed_rpm, "--speed-rpm")
    if not math.isfinite(given) or (args.modes is not None and not args.modes):
        what = (f"{flag}: must be a finite crank speed on the archive's grid (got {given})" if not math.isfinite(given)
                else "--modes: give at least one mode number, e.g. 1,2 (got none)")
        print(f"fkev margins: {what}", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        if args.plot is not None:
            check_output(args.plot, PLOT_FORMATS, "--plot")
        res = load(args.archive, plane=args.plane)
        speed = args.speed if args.speed is not None else args.speed_rpm * RAD_S_PER_RPM
        table = margins(res, speed, args.case, args.orders, args.order, args.modes, args.per_order)
        fig = None
        if args.plot is not None:
            from fkev_slepc.plots.bands import band_campbell

            fig = band_campbell(res, table.case, args.modes, args.orders, table.order, table.speed_rad_s)
    except (ArchiveError, PathProblem) as err:
        print(f"fkev margins: {flag_words(err, ARCHIVE_FLAGS)}", file=sys.stderr)  # API names -> flags
        return EXIT_BAD_INPUT
    out = table.as_dict()
    if args.json:
        json.dump(out, sys.stdout, indent=1)
        print()
    else:
        print_table(res.title, out)
    if fig is not None:
        fig.savefig(args.plot, dpi=110)
        print(f"band Campbell diagram: {args.plot}", file=sys.stderr if args.json else sys.stdout)
    return EXIT_OK


def _approach(a) -> str:
    if a is None:
        return "—"
    where = ", ".join(f"{x:g}" for x in a["angles_deg"][:3]) + ("…" if len(a["angles_deg"]) > 3 else "")
    return f"{a['order']}Ω {a['margin_percent']:.1f} % (θ {where})"


def print_table(title: str, o: dict) -> None:
    kind = Plane.parse(o["plane"])
    print(f"{title}: margins at Ω = {o['speed_rad_s']:g} rad/s (crank order {o['crank_order_hz']:.4g} Hz), "
          f"case {o['case']}, {'' if kind.primary else kind.label + ', '}{o['order']} modes over "
          f"{o['n_angles']} crank angles, orders 1-{o['orders']}")
    print(f"{'mode':>4} {'band [Hz]':>19} {'inside':>14} {'closest':>8} {'margin':>7}  {'where closest (θ deg)':<28}"
          f" {'nearest below':<26} {'nearest above':<26}")
    for m in o["modes"]:
        if m["f_min_hz"] is None:
            print(f"{m['mode']:>4} {'no converged angle':>19}")
            continue
        inside = ",".join(map(str, m["orders_inside"])) or "none"
        where = ", ".join(f"{x:.1f}" for x in m["closest_angles_deg"][:4]) + ("…" if len(m["closest_angles_deg"]) > 4 else "")
        print(f"{m['mode']:>4} {m['f_min_hz']:>9.2f}-{m['f_max_hz']:<9.2f} {inside:>14} {str(m['closest_order']) + 'Ω':>8}"
              f" {m['margin_percent']:>6.1f}%  {where:<28} {_approach(m['below']):<26} {_approach(m['above']):<26}")
    print(f"margin: distance of n·Ω/2π from the band, % of the band edge it approaches (0: inside, crossed "
          f"every revolution at the angles shown); near: within {o['near_percent']:g} %")
    if o["tracking_fell_back"]:
        print("modes in sorted order: tracking fell back at this speed (ambiguous MAC, /tracking/fallback)")
    print(f"{'mode':>4} {'order':>5} {'n·Ω/2π [Hz]':>12} {'band [Hz]':>19} {'margin':>7}  "
          f"{'θ (deg): crossed, or closest':<30}")
    for r in o["per_order"]:
        where = ", ".join(f"{x:.1f}" for x in r["angles_deg"][:4]) + ("…" if len(r["angles_deg"]) > 4 else "")
        print(f"{r['mode']:>4} {str(r['order']) + '×':>5} {r['frequency_hz']:>12.2f} {r['f_min_hz']:>9.2f}-"
              f"{r['f_max_hz']:<9.2f} {r['margin_percent']:>6.1f}%  {where:<30}")
