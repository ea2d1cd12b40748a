"""MPI helpers: the world communicator, rank-tagged logging, abort on an uncaught exception.

Library modules only call ``logging.getLogger(__name__)``; the CLI calls
:func:`configure_logging`. Ranks > 0 log at WARNING so output is not multiplied by the rank count.
"""

from __future__ import annotations

import logging
import sys
from fkev_slepc._version import __version__


def world():
    """``MPI.COMM_WORLD`` (mpi4py is imported lazily so ``fkev check`` works without MPI)."""
    from mpi4py import MPI

    return MPI.COMM_WORLD


def local(comm=None):
    """``comm``, or this process alone (``MPI.COMM_SELF``) for None."""
    if comm is None:
        from mpi4py import MPI

        comm = MPI.COMM_SELF
    return comm


def configure_logging(level: int = logging.WARNING) -> None:
    comm = world()
    rank, size = comm.rank, comm.size
    fmt = f"%(asctime)s [{rank}/{size}] %(levelname)s %(name)s: %(message)s" if size > 1 else (
        "%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(fmt, datefmt="%H:%M:%S"))
    root = logging.getLogger("fkev_slepc")
    root.handlers[:] = [handler]
    root.setLevel(level if rank == 0 else max(level, logging.WARNING))
    root.propagate = False


def install_abort_hook() -> None:
    """On an uncaught exception with more than one rank, print it and ``Abort`` the job,
    so the other ranks do not hang in a collective call (PyFR's mpiutil does the same)."""
    comm = world()
    if comm.size == 1:
        return
    previous = sys.excepthook

    def hook(exc_type, exc, tb):
        previous(exc_type, exc, tb)
        sys.stderr.flush()
        comm.Abort(1)

    sys.excepthook = hook


def software_versions() -> dict:
    """Versions of fkev_slepc and of the libraries it runs with (archived as root attributes)."""
    import h5py
    from mpi4py import MPI

    out = {
        "fkev_version": __version__,
        "h5py_version": h5py.version.version,
        "hdf5_version": h5py.version.hdf5_version,
        "mpi_version": MPI.Get_library_version().replace("\0", "").splitlines()[0].strip(),
    }
    try:  # PETSc is already initialised by the CLI; importing it here only reads versions
        from petsc4py import PETSc
        from slepc4py import SLEPc

        out["petsc_version"] = ".".join(map(str, PETSc.Sys.getVersion()))
        out["slepc_version"] = ".".join(map(str, SLEPc.Sys.getVersion()))
    except ImportError:  # pragma: no cover - the stack always has them
        out["petsc_version"] = out["slepc_version"] = "unavailable"
    return out
