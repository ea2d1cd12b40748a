"""fkev_slepc: free kineto-elastovibration of flexible planar linkages.

Finite-element model of linkages with elastic links (docs/theory.md), quadratic
eigenproblems solved by SLEPc (dense QZ as a cross-check), MPI sweeps, HDF5 archives.
"""

__version__ = "0.1.0"
