"""Initialise petsc4py/slepc4py with command-line PETSc options, once, before any import of PETSc."""

from __future__ import annotations

import sys

_ARGS: list[str] = []


def init_petsc(petsc_args: list[str] | None = None) -> None:
    """Pass ``petsc_args`` to ``slepc4py.init``. Must run before ``from petsc4py import PETSc``
    anywhere in the process; later calls are no-ops (the first one wins)."""
    global _ARGS
    if "petsc4py.PETSc" in sys.modules:
        return
    import slepc4py

    _ARGS = list(petsc_args or [])
    slepc4py.init([sys.argv[0] if sys.argv else "fkev", *_ARGS])


def command_line_options() -> list[str]:
    """The PETSc options given on the command line (they take precedence over scene values)."""
    return list(_ARGS)
