"""Shared command-line plumbing of the benchmark scripts (not part of the package)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run from a checkout without installing


def parser(doc: str, *, modes: int, repeats: int) -> argparse.ArgumentParser:
    """An argument parser with the options every benchmark has (--scene, --modes, --repeats)."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--scene", default="runs/bahgat-willmert-1976.toml")
    ap.add_argument("--modes", type=int, default=modes)
    ap.add_argument("--repeats", type=int, default=repeats)
    return ap


def parse(ap: argparse.ArgumentParser, argv=None) -> tuple[argparse.Namespace, list[str]]:
    """Parse our flags; everything after ``--`` is PETSc's and initialises PETSc (before any
    PETSc import) so ``-fkev_...`` options reach the options database."""
    argv = list(sys.argv[1:] if argv is None else argv)
    cut = argv.index("--") if "--" in argv else len(argv)
    args, petsc = ap.parse_args(argv[:cut]), argv[cut + 1 :]
    from fkev_slepc.solve.petsc_init import init_petsc

    init_petsc(petsc)
    return args, petsc


def bare_toar_settings(pep, n_modes: int, alpha: float, SLEPc) -> None:
    """What the engine sets on its PEP (target 0, nearest first, nev = 2·n_modes + 2, an even
    ncv, tolerance 1e-14, scalar scale α), for the benchmarks' own PEPs."""
    pep.setTarget(0.0)
    pep.setWhichEigenpairs(SLEPc.PEP.Which.TARGET_MAGNITUDE)
    nev = 2 * n_modes + 2
    pep.setDimensions(nev=nev, ncv=max(nev + 16, 2 * nev))
    pep.setTolerances(1e-14)
    pep.setScale(SLEPc.PEP.Scale.SCALAR, alpha=float(alpha))
