"""``fkev plot ARCHIVE [ARCHIVE ...] --kind KIND [options] [-o FILE]``: figures from archives.

Wiring only: load the archive(s), call :func:`fkev_slepc.plots.draw.draw`, save. Without ``-o``
the figure goes next to the (first) archive as ``<archive stem>_<kind>.png``. A bad request
(unknown case, angle or speed not on the grid, no mode shapes in the archive, not an
archive, an output path that cannot be written) is reported in one line on stderr with exit
code 2, before anything is drawn.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from fkev_slepc.status import EXIT_BAD_INPUT

from .common import PLOT_FORMATS, add_plane_selection

FORMATS = PLOT_FORMATS  # the figure formats of every --plot (cli/common.py)


def _floats(text: str) -> list[float]:
    try:
        return [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers separated by commas (got {text!r})") from None


def _ints(text: str) -> list[int]:
    try:
        return [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected integers separated by commas (got {text!r})") from None


def _words(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def _flatten(groups):
    return [v for g in groups for v in g] if groups else None


def add_parser(subparsers) -> None:
    # matplotlib is imported only when a figure is drawn (not on every `fkev` start, on every rank);
    # an unknown --kind is rejected by plots.draw with the list of kinds.
    p = subparsers.add_parser(
        "plot",
        help="draw a figure from sweep archive(s)",
        description=(
            "Draw a figure from a sweep archive. Kinds: freq-angle (frequency vs crank angle, one curve "
            "per speed; several archives of one scene at different meshes are overlaid), param-speed "
            "(ω_i/ω_i(structure) vs α = Ω/ω_1(structure) at one angle), error-angle (% error of the "
            "simplified cases vs full over the cycle at one speed), mode-shape (needs an archive made "
            "with `fkev run SCENE --mode-shapes`), stability (max Re λ over angle × speed), campbell "
            "(frequency vs speed with crank-order lines), bands (each mode's frequency band over the crank cycle vs "
            "speed, with crank-order lines; --speed marks an operating speed)."
        ),
    )
    p.add_argument("archive", type=Path, nargs="+", help="HDF5 archive(s) written by `fkev run`")
    p.add_argument("--kind", required=True, metavar="KIND", help="which figure (kinds listed above)")
    p.add_argument("--case", dest="cases", type=_words, action="append", metavar="NAME[,NAME]",
                   help="case name(s) or Table 3.1 numbers (repeatable; default depends on the kind)")
    p.add_argument("--speed", dest="speeds", type=_floats, action="append", metavar="RAD_S[,...]",
                   help="crank speed(s) in rad/s (default: all for freq-angle, the highest otherwise)")
    p.add_argument("--angle", dest="angles", type=_floats, action="append", metavar="DEG",
                   help="crank angle in degrees (default: 10 if on the grid, else the first)")
    p.add_argument("--modes", type=_ints, action="append", metavar="I[,J]",
                   help="1-based mode numbers (default: all archived modes)")
    p.add_argument("--order", choices=("sorted", "tracked", "matched"),
                   help="mode order (default: tracked along angle for freq-angle, along speed for campbell; "
                        "error-angle: matched to full's modes by MAC; sorted otherwise)")
    p.add_argument("--orders", type=int, metavar="K", help="campbell: crank orders drawn (default: enough to "
                   "reach the highest frequency, at most 8)")
    add_plane_selection(p)
    p.add_argument("--dpi", type=int, default=110, help="resolution of raster output (default 110)")
    p.add_argument("-o", "--output", type=Path, help="output file (.png, .pdf or .svg)")
    p.set_defaults(func=run)


def default_output(archive: Path, kind: str) -> Path:
    """``<archive dir>/<archive stem>_<kind>.png``."""
    return archive.with_name(f"{archive.stem}_{kind}.png")


def run(args) -> int:
    from fkev_slepc.plots.draw import draw
    from fkev_slepc.archive.reader import ArchiveError, load

    from fkev_slepc.archive.paths import PathProblem, check_output

    out = args.output or default_output(args.archive[0], args.kind)
    try:  # before drawing: a bad path is one line, not a traceback after the work
        check_output(out, FORMATS, "-o" if args.output else "output")
    except PathProblem as err:
        print(f"fkev plot: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.orders is not None and args.orders < 1:
        print(f"fkev plot: --orders: must be >= 1 (got {args.orders})", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        runs = [load(a, plane=args.plane) for a in args.archive]
        with warnings.catch_warnings(record=True) as caught:  # said in one line each, not as Python warnings
            warnings.simplefilter("always")
            fig = draw(
                runs if len(runs) > 1 else runs[0],
                args.kind,
                cases=_flatten(args.cases),
                speeds=_flatten(args.speeds),
                angles=_flatten(args.angles),
                modes=_flatten(args.modes),
                order=args.order,
                orders=args.orders,
            )
        for w in caught:
            print(f"fkev plot: warning: {w.message}", file=sys.stderr)
    except ArchiveError as exc:
        from fkev_slepc.cli.common import ARCHIVE_FLAGS, flag_words

        print(f"fkev plot: {flag_words(exc, ARCHIVE_FLAGS)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    fig.savefig(out, dpi=args.dpi)
    print(out)
    return 0
