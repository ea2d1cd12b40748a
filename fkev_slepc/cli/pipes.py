"""A closed stdout (``fkev point … | head -1``) ends the command quietly, as POSIX tools do.

PETSc installs its own handler for SIGPIPE when it initialises, which turns a reader that goes
away into "Caught signal number 13 Broken Pipe" and an MPI abort (exit 59). :func:`guard` puts
Python's default back (SIGPIPE ignored, so a write to a closed pipe raises BrokenPipeError), and
:func:`closed` is what :func:`fkev_slepc.cli.main` does with that error: nothing more is written to
stdout and the exit code is 141, the shell's code for a process ended by SIGPIPE.
"""

from __future__ import annotations

import os
import signal
import sys

EXIT_CLOSED_STDOUT = 128 + signal.SIGPIPE  # 141, what `yes | head -1` reports for `yes`


def guard() -> None:
    """Initialise PETSc now (with the options already given to ``init_petsc``), then take
    SIGPIPE back from PETSc's handler."""
    from petsc4py import PETSc  # noqa: F401 (initialises PETSc and its signal handlers)

    signal.signal(signal.SIGPIPE, signal.SIG_IGN)


def closed() -> int:
    """After BrokenPipeError on stdout: point stdout at /dev/null (so the interpreter's last
    flush is silent) and return :data:`EXIT_CLOSED_STDOUT`."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # stdout is not a file descriptor (tests capture it)
        pass
    return EXIT_CLOSED_STDOUT
