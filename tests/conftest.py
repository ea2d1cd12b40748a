"""The test session computes with one BLAS thread per process, as the command line does
(fkev_slepc/_threads.py, docs/engine.md "BLAS threads"), set here before anything imports numpy.

OpenBLAS's default of a thread per core turns the many small dense products of the tests into
thread hand-offs: on the shared 2-core machine tests/test_floquet_steps.py and
tests/test_periodic_system.py took 20.5–23.4 s with the library default against 6.7 s pinned
(load average 5.8, alternated). The pin is the one of the command line: the variables already set
in the environment (``OPENBLAS_NUM_THREADS=2 make test``) or ``FKEV_BLAS_THREADS`` are honoured.
The module is loaded by its path: importing the package would import numpy first.
"""

import importlib.util
import os
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "_fkev_threads", Path(__file__).resolve().parents[1] / "fkev_slepc" / "_threads.py")
_threads = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_threads)
os.environ.update(_threads.blas_environment(os.environ))
