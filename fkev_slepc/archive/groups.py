"""Datasets made from their table rows (:mod:`fkev_slepc.archive.products`): the HDF5 details.

Every axis of every dataset has a dimension scale in its group (or the root group), and every
dataset has ``units`` and ``long_name``, so that xarray (h5netcdf) opens each group:
``xr.open_dataset(path, group="errors")``. Datasets written later by the ranks have their
storage allocated (and filled) at creation, so that ranks can write hyperslabs independently
without collective allocation.
"""

from __future__ import annotations

import h5py
import numpy as np

from fkev_slepc.archive.products import MESSAGE, MESSAGE_BYTES, STATUS, STRING, Product, Var
from fkev_slepc.status import Status

STATUS_DTYPE = h5py.enum_dtype({s.value: s.code for s in Status}, basetype="u1")
_STR = h5py.string_dtype("utf-8")


def h5_dtype(var: Var):
    """The HDF5 dtype of a table row."""
    return {STATUS: STATUS_DTYPE, STRING: _STR, MESSAGE: h5py.string_dtype("utf-8", MESSAGE_BYTES)}.get(
        var.dtype, var.dtype)


def _early():
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
    return dcpl


def present(product: Product, needs) -> tuple[Var, ...]:
    """The rows of ``product`` a run with the options ``needs`` (a set of names) has."""
    return tuple(v for v in product.variables if v.needs == "" or v.needs in needs)


def build(f, rows, values: dict, data: dict | None = None) -> None:
    """Create the datasets of ``rows`` in the open file ``f``: scales first, with their values
    from ``values`` (by path; fixed ones from the table), then the others, each filled with
    ``data[path]`` if given, else at full size with its fill value and storage allocated. The
    size of each axis is that of its scale (in ``values`` or already in the file). Groups are
    created as needed; a dataset already in the file is replaced."""
    data = data or {}
    scales = {}
    for v in rows:
        if v.scale:
            vals = v.values if v.values is not None else values.get(v.path, []) if v.growable else values[v.path]
            scales[v.path] = _make(f, v, data=list(vals) if v.dtype == STRING else np.asarray(vals, dtype=v.dtype))
    for v in rows:
        if not v.scale:
            dims = [scales.get(d) or f[d] for d in v.dims]
            _make(f, v, data.get(v.path), tuple(len(d) for d in dims))
    for v in rows:  # attach once every scale exists (a scale may be declared after its user)
        ds = f[v.path]
        if not v.scale:
            for i, d in enumerate(v.dims):
                ds.dims[i].attach_scale(scales.get(d) or f[d])


def _make(f, v: Var, data=None, shape=None):
    group = f.require_group(v.group) if v.group else f
    if v.name in group:
        del group[v.name]
    kw = {}
    if v.growable:
        n = len(data) if data is not None else 0
        shape = (n,) + tuple(shape[1:] if shape else ())
        kw = dict(maxshape=(None,) + shape[1:], chunks=v.chunks, dcpl=_early())
    if data is not None:
        if v.fill is not None:
            kw["fillvalue"] = v.fill
        ds = group.create_dataset(v.name, data=data, dtype=h5_dtype(v), **kw)
    else:
        ds = group.create_dataset(v.name, shape, h5_dtype(v), fillvalue=v.fill, dcpl=_early(),
                                  **{k: x for k, x in kw.items() if k != "dcpl"})
    if v.scale:
        ds.make_scale(v.name)
    ds.attrs.update(units=v.units, long_name=v.long_name, **v.attrs)
    if v.dtype == STATUS:
        flags(ds)
    return ds


def describe_groups(f, product: Product) -> None:
    """The ``description`` attribute of each group of ``product`` that is in ``f``."""
    for path, text in product.groups.items():
        if path in f:
            f[path].attrs["description"] = text


def flags(ds) -> None:
    """CF ``flag_values``/``flag_meanings`` of a status dataset (decoded by the reader)."""
    ds.attrs["flag_values"] = np.array([s.code for s in Status], dtype="u1")
    ds.attrs["flag_meanings"] = " ".join(s.value for s in Status)


def number_error_rows(f, product: Product) -> None:
    """Size the row scale of ``product``'s error table like its rows (archives of format 1 without it: nothing)."""
    e = product.errors
    if e.row.path in f:
        n = f[e.index.path].shape[0]
        f[e.row.path].resize((n,))
        f[e.row.path][...] = np.arange(n, dtype="i4")
