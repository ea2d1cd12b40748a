"""Command line: ``fkev run | point | check | info | plot``. Wiring only.

Each subcommand lives in its own module exposing ``add_parser(subparsers)``, which registers
the parser and sets ``func`` (args -> exit code). PETSc/SLEPc options (``-fkev_pep_type toar``)
are separated from our own flags here and handed to ``slepc4py.init`` before anything imports
PETSc, so the options database sees them.
"""

from __future__ import annotations

import argparse
import logging
import sys

from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, EXIT_OK  # noqa: F401 (re-exported)
SUBCOMMANDS = ("run", "point", "check", "info", "verify", "plot")


def split_petsc_options(argv: list[str]) -> tuple[list[str], list[str]]:
    """Split argv into (ours, petsc). PETSc options start with a single dash and a word
    longer than one letter (``-fkev_pep_tol 1e-12``, ``-log_view``); a following token that
    does not start with '-' (or is a negative number) is that option's value. Everything
    after a bare ``--`` is PETSc's."""
    ours: list[str] = []
    petsc: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        if tok == "--":
            petsc.extend(argv[i + 1 :])
            break
        if tok.startswith("-") and not tok.startswith("--") and len(tok) > 2 and not _is_number(tok):
            petsc.append(tok)
            if i + 1 < len(argv) and (not argv[i + 1].startswith("-") or _is_number(argv[i + 1])):
                if not argv[i + 1].endswith(".toml") and not argv[i + 1].endswith(".h5"):
                    petsc.append(argv[i + 1])
                    i += 1
            i += 1
            continue
        ours.append(tok)
        i += 1
    return ours, petsc


def _is_number(tok: str) -> bool:
    try:
        float(tok)
        return True
    except ValueError:
        return False


def build_parser() -> argparse.ArgumentParser:
    import importlib

    ap = argparse.ArgumentParser(
        prog="fkev",
        description="Free kineto-elastovibration of flexible planar linkages (FE + SLEPc).",
        epilog="PETSc/SLEPc options (e.g. -fkev_pep_type toar) may follow the scene path or '--'.",
    )
    ap.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    sub = ap.add_subparsers(dest="command", required=True)
    for name in SUBCOMMANDS:
        try:
            mod = importlib.import_module(f"fkev_slepc.cli.{name}")
        except ModuleNotFoundError as exc:  # a subcommand not built yet in this checkout
            if exc.name != f"fkev_slepc.cli.{name}":
                raise
            continue
        mod.add_parser(sub)
    return ap


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ours, petsc = split_petsc_options(argv)
    from fkev_slepc.solve.petsc_init import init_petsc

    init_petsc(petsc)
    args = build_parser().parse_args(ours)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    from fkev_slepc.sweep.parallel import configure_logging

    configure_logging(level)
    return int(args.func(args) or 0)
