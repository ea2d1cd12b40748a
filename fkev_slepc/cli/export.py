"""``fkev export ARCHIVE --format csv [-o FILE]``: the archive as one long (tidy) table.

The table and its columns: :mod:`fkev_slepc.api.table` (also ``SweepResults.to_csv``). Without
``-o`` the table goes to stdout.
"""

from __future__ import annotations

import sys
from pathlib import Path

from fkev_slepc.api.table import table, write_csv
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_OK

from .common import ARCHIVE_FLAGS, add_plane_selection, flag_words

FORMATS = ("csv",)


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="write an archive as a long table (CSV)",
                       description="One row per crank angle, speed, case and mode: frequency, damping ratio "
                       "and the point's status.")
    p.add_argument("archive", type=Path, help="archive (.h5) written by `fkev run`")
    p.add_argument("--format", choices=FORMATS, default="csv", help="table format (default csv)")
    p.add_argument("-o", "--output", type=Path, help="output file (.csv); default stdout")
    add_plane_selection(p)
    p.add_argument("--no-verify", action="store_true",
                   help="export even if `fkev verify` finds the archive changed since its run (not advised)")
    p.set_defaults(func=run)


def run(args) -> int:
    from fkev_slepc.archive.paths import PathProblem, check_output
    from fkev_slepc.archive.reader import ArchiveError, load

    from fkev_slepc.archive.verify import verify

    try:
        if args.output is not None:
            check_output(args.output, (".csv",), "-o")
        if not args.no_verify:  # never export the numbers of a damaged archive
            check = verify(args.archive)
            if check.writer is not None or not check.ok:
                raise ArchiveError(check.summary() + ("" if check.writer else "; export anyway with --no-verify"))
        res = load(args.archive, verify=False, plane=args.plane)
    except (ArchiveError, PathProblem) as err:
        print(f"fkev export: {flag_words(err, ARCHIVE_FLAGS)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    rows = table(res)
    if args.output is None:
        write_csv(rows, sys.stdout)
    else:
        with open(args.output, "w", newline="", encoding="utf-8") as fh:
            write_csv(rows, fh)
    return EXIT_OK
