"""``fkev verify ARCHIVE...``: is an archive intact? (checksums of every dataset, see archive/verify.py)

One line per archive; exit 0 when every archive is intact (or readable and still being
written), 2 when one is missing, unreadable or changed since its run finished.
"""

from __future__ import annotations

import sys
from pathlib import Path

from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_OK
from fkev_slepc.archive.verify import verify
from fkev_slepc.sweep.parallel import world


def add_parser(sub) -> None:
    p = sub.add_parser("verify", help="check an archive against its checksums",
                       description="Read every dataset of fkev archives and compare it with the SHA-256 "
                       "stored when the run finished; exit 2 if any archive is damaged.")
    p.add_argument("archives", type=Path, nargs="+", metavar="ARCHIVE", help="archive (.h5 or .h5.part)")
    p.set_defaults(func=run)


def run(args) -> int:
    if world().rank != 0:
        return EXIT_OK
    code = EXIT_OK
    for path in args.archives:
        check = verify(path)
        print(f"fkev verify: {check.summary()}", file=sys.stdout if check.ok else sys.stderr, flush=True)
        code = code if check.ok else EXIT_BAD_INPUT
    return code
