"""Self-describing HDF5 files of one labelled result (``fkev loads``, ``fkev response``).

A result is a set of coordinates (1-D, each a dimension scale with ``units`` and ``long_name``)
and variables on them, plus root attributes (the scene text, the operating point, versions).
Every axis of every variable is attached to its scale, which is what xarray's h5netcdf engine
needs: ``xarray.open_dataset(path, engine="h5netcdf")`` opens the file as one Dataset.
The file is written under a temporary name and moved into place, so a crash never leaves a
half-written result under the final name.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.archive.verify import stamp

_STR = h5py.string_dtype("utf-8")


def write_labelled(path, kind: str, coords: dict, variables: dict, attrs: dict, checksums: bool = False) -> Path:
    """Write ``coords`` {name: (values, units, long_name)} and ``variables`` {name: (dims,
    data, units, long_name)} to ``path``; ``attrs`` become root attributes (dicts as JSON).
    ``kind`` is stored as the ``format`` attribute (e.g. ``fkev-loads``). ``checksums``: mark
    the file complete and stamp the SHA-256 of every dataset and of the root attributes
    (archive/verify.py), so that ``fkev verify`` checks it (``fkev drive -o``)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs["format"] = kind
        f.attrs["format_version"] = 1
        for key, value in attrs.items():
            f.attrs[key] = json.dumps(value) if isinstance(value, (dict, list, tuple)) else value
        scales = {}
        for name, (values, units, long_name) in coords.items():
            values = list(values) if isinstance(values, (list, tuple)) and values and isinstance(values[0], str) \
                else np.asarray(values)
            ds = f.create_dataset(name, data=values, dtype=_STR if isinstance(values, list) else None)
            ds.make_scale(name)
            ds.attrs.update(units=units, long_name=long_name)
            scales[name] = ds
        for name, (dims, data, units, long_name) in variables.items():
            data = np.asarray(data)
            want = tuple(len(scales[d]) for d in dims)
            if data.shape != want:
                raise ValueError(f"{name}: shape {data.shape}, dims {dims} are {want}")
            ds = f.create_dataset(name, data=data, fillvalue=np.nan if data.dtype.kind == "f" else None)
            ds.attrs.update(units=units, long_name=long_name)
            for i, d in enumerate(dims):
                ds.dims[i].attach_scale(scales[d])
        if checksums:
            f.attrs["complete"] = 1
            stamp(f)
    os.replace(tmp, path)
    return path
