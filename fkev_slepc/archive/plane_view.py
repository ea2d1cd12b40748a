"""One plane of a two-plane archive as :class:`~fkev_slepc.archive.reader.SweepResults`.

A two-plane archive (docs/archive.md, ``/planes/out``: fkev_slepc/archive/products_planes.py) holds the
in-plane sweep in its root group and the out-of-plane sweep (docs/theory.md §19) of the same grid under
``/planes/out``. :func:`plane_view` gives either as the same kind of object, so that every reader of a
sweep (figures, margins, the long table, xarray) reads the out-of-plane sweep as it reads a one-plane
``fkev run --plane out`` archive: the root attribute ``plane`` is ``out`` in the view, ``n_free`` and the
mesh's DOF map are the out-of-plane model's, mode shapes are read from ``/planes/out/modes/shape``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.verified import ArchiveError
from fkev_slepc.model.plane import PLANES, Plane


def plane_view(res, plane: str, root):
    """``res`` (a :class:`~fkev_slepc.archive.reader.SweepResults`) on ``plane``; ArchiveError naming
    ``plane`` when it is not one of :data:`PLANES` or not in the archive. ``root()``: the archive's
    root sweep read again (the in-plane sweep of a two-plane archive)."""
    if plane not in PLANES:
        raise ArchiveError(f"plane: must be one of {', '.join(PLANES)} (got {plane!r})")
    if plane not in res.planes:
        raise ArchiveError(f"plane: {plane!r} is not in {res.path} (it has: {', '.join(res.planes)}; both planes "
                           "in one archive: fkev run --plane both)")
    if plane == res.plane:
        return res
    if Plane.parse(plane).primary:  # back to the root sweep of a two-plane archive
        return root()
    import h5py

    with h5py.File(res.path, "r") as h5:
        def read(v, dtype):
            return np.asarray(h5[P.on_plane(v, "out").path][()], dtype=dtype)

        settings = {k: _plain(v) for k, v in h5[P.PLANE_OUT.name].attrs.items() if k != "description"}
        mesh = res.mesh
        if mesh is not None:
            mesh = replace(mesh, node_dofs=read(P.NODE_DOFS, int), node_axis=np.tile([1.0, 0.0], (mesh.node_s.size, 1)))
        return replace(
            res, status=read(P.STATUS_VAR, np.uint8), eigenvalue=read(P.EIGENVALUE, complex),
            frequency_hz=read(P.FREQUENCY, float), tracked_frequency_hz=read(P.TRACKED, float),
            residual=read(P.RESIDUAL, float), damping_ratio=read(P.DAMPING, float), max_real=read(P.MAX_REAL, float),
            mesh=mesh, has_mode_shapes=P.on_plane(P.SHAPE, "out").path in h5,
            attrs={**res.attrs, **settings, "plane": "out"}, table_plane="out")


def _plain(v):
    """An HDF5 attribute as a plain Python value (strings decoded, numpy scalars unwrapped)."""
    if isinstance(v, bytes):
        return v.decode("utf-8")
    return v.item() if isinstance(v, np.generic) else v
