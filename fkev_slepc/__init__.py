"""fkev_slepc: free kineto-elastovibration of flexible planar linkages.

Finite-element model of linkages with elastic links (docs/theory.md), quadratic
eigenproblems solved by SLEPc (dense QZ as a cross-check), MPI sweeps, HDF5 archives.

The Python API (docs/api.md): :func:`load` a scene into a :class:`Study`, solve a
:meth:`Study.point` or run a :meth:`Study.sweep`, :func:`open` an archive as
:class:`SweepResults` or any group of it as xarray (:func:`open_dataset`, verified first).
Importing the package does not import PETSc (the command line must
initialise it with its options first) nor MPI.
"""

from fkev_slepc import _threads

_threads.pin_for_cli()  # before numpy is imported: one BLAS thread per process on the command line

from fkev_slepc._version import __version__  # noqa: E402
from fkev_slepc.api import PointResult, Study, SweepResults, load, open, open_dataset  # noqa: E402
from fkev_slepc.status import Status  # noqa: E402

__all__ = ["__version__", "load", "open", "open_dataset", "Study", "PointResult", "SweepResults", "Status"]
