"""Command line: ``fkev run | point | check | info | verify | plot | export | critical | loads | floquet | response | design-check | runup``. Wiring only.

Each subcommand lives in its own module exposing ``add_parser(subparsers)``, which registers
the parser and sets ``func`` (args -> exit code). PETSc/SLEPc options (``-fkev_pep_type toar``)
are separated from our own flags here and handed to ``slepc4py.init`` before anything imports
PETSc, so the options database sees them. The global flags ``-v``/``-q`` may stand before or
after the subcommand; an error in a subcommand's flags prints that subcommand's usage.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import importlib

from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_NOT_CONVERGED, EXIT_OK  # noqa: F401 (re-exported)
from fkev_slepc.cli import pipes
from fkev_slepc.solve.petsc_init import init_petsc
from fkev_slepc.sweep.parallel import configure_logging, software_versions, world
SUBCOMMANDS = ("run", "point", "check", "info", "verify", "plot", "export", "critical", "margins", "design",
               "design-check", "loads", "drive", "floquet", "response", "runup")
COLLECTIVE = ("run", "design", "floquet")  # every rank of mpiexec takes part; any other command runs on rank 0 alone
GLOBAL_FLAGS = {"-v": ("verbose", 1), "--verbose": ("verbose", 1), "-q": ("quiet", 1), "--quiet": ("quiet", 1)}


def split_global_flags(argv: list[str]) -> tuple[list[str], dict[str, int]]:
    """Remove ``-v``/``-vv``/``--verbose``/``-q``/``--quiet`` wherever they stand (before or after
    the subcommand, before a bare ``--``); returns (rest, counts)."""
    counts = {"verbose": 0, "quiet": 0}
    rest: list[str] = []
    for i, tok in enumerate(argv):
        if tok == "--":
            rest.extend(argv[i:])
            break
        if tok in GLOBAL_FLAGS:
            counts[GLOBAL_FLAGS[tok][0]] += 1
        elif len(tok) > 2 and tok[0] == "-" and set(tok[1:]) <= {"v"}:  # -vv, -vvv
            counts["verbose"] += len(tok) - 1
        elif len(tok) > 2 and tok[0] == "-" and set(tok[1:]) <= {"q"}:
            counts["quiet"] += len(tok) - 1
        else:
            rest.append(tok)
    return rest, counts


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


def attach_negative_values(argv: list[str]) -> list[str]:
    """``--speed -5e2`` as ``--speed=-5e2`` (and ``--gravity -981,0``, ``--angles -90:90:10``):
    argparse reads only ``-5`` and ``-0.5`` as negative numbers and takes ``-5e2``, ``-inf`` or a list
    for an unknown option.

    Examples
    --------
    >>> attach_negative_values(["point", "s.toml", "--speed", "-5e2", "--angle", "-10"])
    ['point', 's.toml', '--speed=-5e2', '--angle=-10']
    >>> attach_negative_values(["loads", "s.toml", "--gravity", "-981,0"])
    ['loads', 's.toml', '--gravity=-981,0']
    """
    out: list[str] = []
    for tok in argv:
        prev = out[-1] if out else ""
        if tok.startswith("-") and _is_number(tok) and prev.startswith("--") and len(prev) > 2 and "=" not in prev:
            out[-1] = f"{prev}={tok}"
        else:
            out.append(tok)
    return out


def _is_number(tok: str) -> bool:
    """A number, or numbers joined by ``,`` or ``:`` (``-981,0``, ``-5e2``, ``-90:90:10``): the value
    of an option that takes numbers, even with a leading minus.

    Examples
    --------
    >>> [_is_number(t) for t in ("-5e2", "-981,0", "-90:90:10", "-log_view", "-")]
    [True, True, True, False, False]
    """
    try:
        for part in tok.replace(":", ",").split(","):
            float(part)
        return True
    except ValueError:
        return False


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="fkev",
        description="Free kineto-elastovibration of flexible planar linkages (FE + SLEPc).",
        epilog="PETSc/SLEPc options (e.g. -fkev_pep_type toar) may follow the scene path or '--'.",
    )
    ap.add_argument("-v", "--verbose", action="count", default=0,
                    help="more log output (-vv: debug); before or after the subcommand")
    ap.add_argument("-q", "--quiet", action="count", default=0,
                    help="errors only, no progress output; before or after the subcommand")
    ap.add_argument("--version", action="store_true", help="versions of fkev, PETSc, SLEPc and MPI, then exit")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS:
        try:
            mod = importlib.import_module(f"fkev_slepc.cli.{name.replace('-', '_')}")
        except ModuleNotFoundError as exc:  # a subcommand not built yet in this checkout
            if exc.name != f"fkev_slepc.cli.{name.replace('-', '_')}":
                raise
            continue
        mod.add_parser(sub)
    ap.set_defaults(command=None)
    ap.commands = sub.choices  # name -> subparser (for its usage on errors)
    return ap


def version_text() -> str:
    """``fkev X.Y (PETSc a.b.c, SLEPc a.b.c, h5py ..., HDF5 ..., MPI library)``."""
    v = software_versions()
    return (f"fkev {v['fkev_version']} (PETSc {v['petsc_version']}, SLEPc {v['slepc_version']}, "
            f"h5py {v['h5py_version']}, HDF5 {v['hdf5_version']}, MPI: {v['mpi_version']})")


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    full_argv, environ = list(argv), dict(os.environ)  # before MPI starts (it adds variables)
    argv, flags = split_global_flags(argv)
    ours, petsc = split_petsc_options(argv)

    init_petsc(petsc)

    pipes.guard()  # a closed stdout ends quietly (exit 141), not in PETSc's SIGPIPE handler
    try:
        code = _main(full_argv, environ, flags, ours)
        sys.stdout.flush()
    except BrokenPipeError:
        return pipes.closed()
    return code


def _main(full_argv: list[str], environ: dict, flags: dict, ours: list[str]) -> int:
    parser = build_parser()
    args, extra = parser.parse_known_args(attach_negative_values(ours))
    if args.version:
        print(version_text())
        return EXIT_OK
    if args.command is None:
        parser.error("a command is required (one of: " + ", ".join(parser.commands) + ")")
    if extra:  # the subcommand's usage, not the top-level one
        parser.commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    if getattr(args, "np", None) is not None:  # fkev run --np N: launch the ranks ourselves
        from fkev_slepc.cli.launch import relaunch

        code = relaunch(args.np, full_argv, environ)
        if code >= 0:
            return code
    args.verbose, args.quiet = flags["verbose"], flags["quiet"] or getattr(args, "quiet", 0)
    level = logging.ERROR if args.quiet else logging.WARNING - 10 * min(args.verbose, 2)

    archived_scan = args.command == "response" and args.speeds is not None and args.output  # fkev response --speeds -o
    if args.command not in COLLECTIVE and not archived_scan and world().rank > 0:
        return EXIT_OK  # under mpiexec: one process computes and prints (rank 0), once
    configure_logging(level)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:  # outside a sweep's solve loop (which stops cleanly by itself)
        print(f"fkev {args.command}: interrupted", file=sys.stderr, flush=True)
        return EXIT_INTERRUPTED
