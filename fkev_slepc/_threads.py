"""One BLAS thread per process for the command line (``fkev``, ``python -m fkev_slepc``, and every
rank ``mpirun``/``fkev run --np`` starts), set before numpy is imported.

A sweep's parallelism is its MPI ranks; OpenBLAS's default of one thread per core on every rank
oversubscribes the cores and made a 777-point ``fkev run`` 1.6x slower (docs/engine.md, "BLAS
threads"). Thread pools are sized when the BLAS library loads, so this must happen before the
first ``import numpy``: the package's ``__init__`` calls :func:`pin_for_cli` first thing. No
threadpoolctl (not packaged for Debian bookworm): environment variables.

Overriding: a variable already set (``OPENBLAS_NUM_THREADS=4 fkev run ...``) is kept, and
``FKEV_BLAS_THREADS=N`` sets all of them to N (``FKEV_BLAS_THREADS=default``: leave the BLAS
library's own default). The Python API (``import fkev_slepc`` in your own program) is not pinned:
there numpy is usually imported first and the threads are the caller's choice.
"""

from __future__ import annotations

import os
import sys

BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")
OVERRIDE = "FKEV_BLAS_THREADS"


def is_cli(argv0: str | None = None) -> bool:
    """Whether this process is the command line: ``fkev`` or ``python -m fkev_slepc`` (``-m``
    while runpy imports the package; the path of ``fkev_slepc/__main__.py`` afterwards)."""
    a = sys.argv[0] if argv0 is None and sys.argv else (argv0 or "")
    return os.path.basename(a) == "fkev" or a == "-m" or a.endswith(os.path.join("fkev_slepc", "__main__.py"))


def blas_environment(environ, threads: str | None = None) -> dict:
    """The variables to add to ``environ`` (not changing it): each of
    :data:`BLAS_THREAD_VARIABLES` not already set, to ``threads`` (default: ``environ``'s
    ``FKEV_BLAS_THREADS`` or 1; "default": none)."""
    threads = environ.get(OVERRIDE, "1") if threads is None else threads
    if threads.strip().lower() == "default":
        return {}
    forced = OVERRIDE in environ
    return {v: threads for v in BLAS_THREAD_VARIABLES if forced or v not in environ}


def pin_for_cli() -> None:
    """Pin BLAS to one thread (or ``FKEV_BLAS_THREADS``) when this process is the command line and
    numpy is not loaded yet."""
    if is_cli() and "numpy" not in sys.modules:
        os.environ.update(blas_environment(os.environ))
