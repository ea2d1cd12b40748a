"""The archive's groups (``/errors``, ``/mesh``, ``/tracking``, ``/modes``) and the HDF5
details shared with the root group: every axis of every dataset has a dimension scale in its
group (or the root group), and every dataset has ``units`` and ``long_name``, so that xarray
(h5netcdf) opens each group: ``xr.open_dataset(path, group="errors")``.
"""

from __future__ import annotations

import h5py
import numpy as np

from fkev_slepc.archive.writer import MESSAGE_BYTES
from fkev_slepc.status import Status

STATUS_DTYPE = h5py.enum_dtype({s.value: s.code for s in Status}, basetype="u1")
_STR = h5py.string_dtype("utf-8")


def _early():
    """Dataset creation properties: storage allocated (and filled) at creation, so that
    ranks can later write hyperslabs independently without collective allocation."""
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
    return dcpl


def _plain(group, name, shape, dtype, fill):
    return group.create_dataset(name, shape, dtype, fillvalue=fill, dcpl=_early())


def gridded(f, name, shape, dtype, fill, units, long_name, dims):
    """A dataset on the root grid (pre-filled, storage allocated), attached to the named scales."""
    ds = _plain(f, name, shape, dtype, fill)
    _describe(ds, units, long_name, *(f[d] for d in dims))
    return ds


def create_groups(f, grid, mesh, n_free, mode_shapes, tracking_dofs) -> None:
    """Create ``/errors`` (empty, growable), ``/mesh``, ``/tracking`` and ``/modes`` (see store.create)."""
    na, ns, nc = grid.shape
    nm = grid.n_modes
    err = f.create_group("errors")
    err.attrs["description"] = "messages of failed and not-converged points (one row per point)"
    row = scale(err, "error", np.zeros(0, "i4"), "1", "row number", maxshape=(None,), chunks=(256,),
                dcpl=_early())  # allocated early like the rows: mpio resizes it collectively
    axis = scale(err, "point_axis", ["angle", "speed", "case"], "1", "axis of the (angle, speed, case) index")
    ds = err.create_dataset("index", (0, 3), "i4", maxshape=(None, 3), chunks=(256, 3), dcpl=_early())
    _describe(ds, "1", "(angle, speed, case) indices of the point", row, axis)
    ds = err.create_dataset("status", (0,), STATUS_DTYPE, maxshape=(None,), chunks=(256,), dcpl=_early())
    flags(ds)
    _describe(ds, "1", "outcome of the point (failed or not_converged)", row)
    ds = err.create_dataset("message", (0,), h5py.string_dtype("utf-8", MESSAGE_BYTES),
                            maxshape=(None,), chunks=(64,), dcpl=_early())
    _describe(ds, "1", f"the solver's message (cut at {MESSAGE_BYTES} bytes)", row)

    if mesh is not None:
        g = f.create_group("mesh")
        links = g.create_dataset("link_names", data=list(mesh["link_names"]), dtype=_STR)
        links.make_scale("link_names")
        links.attrs.update(units="1", long_name="link names in scene order")
        n_node, n_el = len(mesh["node_link"]), len(mesh["elem_nodes"])
        dims = {"node": scale(g, "node", np.arange(n_node, dtype="i4"), "1", "node number"),
                "element": scale(g, "element", np.arange(n_el, dtype="i4"), "1", "element number"),
                "component": scale(g, "component", ["U", "V", "Phi"], "1", "nodal DOF (translations, rotation)"),
                "end": scale(g, "end", ["left", "right"], "1", "element end")}
        for key, units, long_name, axes in (
            ("node_link", "1", "link of each node (index into link_names)", ("node",)),
            ("node_s", "m", "station of the node along its link, from the link's root", ("node",)),
            ("node_dofs", "1", "free DOF index of (U, V, Phi) at each node, -1 if constrained", ("node", "component")),
            ("elem_nodes", "1", "(left, right) node of each element", ("element", "end")),
        ):
            ds = g.create_dataset(key, data=np.asarray(mesh[key]))
            _describe(ds, units, long_name, *(dims[a] for a in axes))
    grid4 = [f[name] for name in ("crank_angle_deg", "speed_rad_s", "case")]
    if tracking_dofs is not None:
        g = f.create_group("tracking")
        g.attrs["description"] = ("eigenvector entries at the free DOFs `dofs`, used to follow modes "
                                  "between neighbouring crank angles by MAC")
        dofs = scale(g, "dofs", np.asarray(tracking_dofs, dtype="i4"), "1", "free DOF index of the kept entries")
        ds = _plain(g, "signature", (na, ns, nc, len(tracking_dofs), nm), "c16", complex(np.nan, np.nan))
        _describe(ds, "1", "eigenvector entries of each sorted mode at `dofs`", *grid4, dofs, f["mode"])
    if mode_shapes:
        if mesh is None:
            raise ValueError("an archive with mode shapes needs the mesh (node positions)")
        g = f.create_group("modes")
        free = scale(g, "free_dof", np.arange(n_free, dtype="i4"), "1", "free DOF index")
        node = scale(g, "node", np.arange(len(mesh["node_link"]), dtype="i4"), "1", "node number")
        xy = scale(g, "xy", ["x", "y"], "1", "coordinate")
        ds = _plain(g, "shape", (na, ns, nc, n_free, nm), "c16", complex(np.nan, np.nan))
        _describe(ds, "1", "mode shape over the free DOFs, max |entry| = 1 and real", *grid4, free, f["mode"])
        ds = _plain(g, "node_xy", (na, len(mesh["node_link"]), 2), "f8", np.nan)
        _describe(ds, "m", "undeformed node positions at each crank angle", grid4[0], node, xy)


def scale(group, name, data, units, long_name, **kw):
    """A dimension scale (coordinate) ``name`` in ``group``: every axis of every dataset of
    the archive has one, which is what xarray (h5netcdf) needs to open any group."""
    dtype = _STR if isinstance(data, list) else None
    ds = group.create_dataset(name, data=data, dtype=dtype, **kw)
    ds.make_scale(name)
    ds.attrs.update(units=units, long_name=long_name)
    return ds


def _describe(ds, units, long_name, *scales):
    """Units, long name, and the dimension scales of each axis of ``ds``."""
    ds.attrs.update(units=units, long_name=long_name)
    for i, sc in enumerate(scales):
        ds.dims[i].attach_scale(sc)


def flags(ds) -> None:
    """CF ``flag_values``/``flag_meanings`` of a status dataset (decoded by the reader)."""
    ds.attrs["flag_values"] = np.array([s.code for s in Status], dtype="u1")
    ds.attrs["flag_meanings"] = " ".join(s.value for s in Status)



def number_error_rows(g) -> None:
    """Size the ``error`` row scale like the rows (archives of format 1 without it: nothing)."""
    if "error" in g:
        n = g["index"].shape[0]
        g["error"].resize((n,))
        g["error"][...] = np.arange(n, dtype="i4")
