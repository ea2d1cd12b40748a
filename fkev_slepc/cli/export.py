"""``fkev export ARCHIVE --format csv [-o FILE]``: the archive as one long (tidy) table.

One row per (crank angle, speed, case, mode), C order as in the archive: ``crank_angle_deg,
speed_rad_s, case, mode, frequency_hz, damping_ratio, status``. The damping ratio is the
archive's ``damping_ratio`` when it has one, else ζ = −Re λ / |λ| from the eigenvalues (the
modal damping of λ = −ζω_n ± iω_n√(1−ζ²); negative for a growing mode). Modes a point did not
find, and every mode of a point that did not converge, have empty frequency and damping
fields; ``status`` says why. Without ``-o`` the table goes to stdout.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_OK

FORMATS = ("csv",)
# the archive's names (fkev_slepc/archive/products.py): crank_angle_deg, speed_rad_s, case, mode,
# frequency_hz, damping_ratio, status
COLUMNS = (P.ANGLE, P.SPEED, P.CASE, P.MODE, P.FREQUENCY.path, P.DAMPING.path, P.STATUS_VAR.path)


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="write an archive as a long table (CSV)",
                       description="One row per crank angle, speed, case and mode: frequency, damping ratio "
                       "and the point's status.")
    p.add_argument("archive", type=Path, help="archive (.h5) written by `fkev run`")
    p.add_argument("--format", choices=FORMATS, default="csv", help="table format (default csv)")
    p.add_argument("-o", "--output", type=Path, help="output file (.csv); default stdout")
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
        res = load(args.archive, verify=False)
    except (ArchiveError, PathProblem) as err:
        print(f"fkev export: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    rows = table(res)
    if args.output is None:
        write_csv(rows, sys.stdout)
    else:
        with open(args.output, "w", newline="", encoding="utf-8") as fh:
            write_csv(rows, fh)
    return EXIT_OK


def table(res) -> dict[str, np.ndarray]:
    """The columns of the long table, each a flat array over (angle, speed, case, mode)."""
    na, ns, nc = res.status.shape
    nm = len(res.modes)
    ia, js, kc, lm = np.meshgrid(np.arange(na), np.arange(ns), np.arange(nc), np.arange(nm), indexing="ij")
    freq = res.frequency()
    zeta = np.where(np.isfinite(freq), res.damping_ratio, np.nan)
    names = np.broadcast_to(res.status_names[..., None], (na, ns, nc, nm))
    cols = (res.crank_angle_deg[ia], res.speed_rad_s[js], np.asarray(res.cases)[kc], res.modes[lm], freq, zeta, names)
    return {name: c.ravel() for name, c in zip(COLUMNS, cols)}


def write_csv(columns: dict[str, np.ndarray], fh) -> None:
    """Write the columns as CSV (full precision, ``repr`` of floats; NaN as an empty field)."""
    def cell(v):
        if isinstance(v, (float, np.floating)):
            return "" if not np.isfinite(v) else repr(float(v))
        return str(v)

    w = csv.writer(fh, lineterminator="\n")
    w.writerow(COLUMNS)
    cols = [columns[c].tolist() for c in COLUMNS]
    w.writerows([[cell(v) for v in row] for row in zip(*cols)])
