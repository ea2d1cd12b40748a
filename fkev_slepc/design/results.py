"""Reading a design study (fkev_slepc/design/study.py) as an xarray Dataset with the design keys
as dimensions.

``open_design(path)`` gives, over (``<key 1>``, ..., ``crank_angle_deg``, ``speed_rad_s``,
``case``, ``mode``): ``frequency_hz`` (NaN where a point did not converge), ``damping_ratio``,
``eigenvalue``, ``status`` (names), and derived over the crank cycle ``frequency_min_hz`` /
``frequency_max_hz`` (the band of each sorted mode at each speed, fkev_slepc/design/margins.py),
and per (keys, case) the lowest divergence speed ``divergence_speed_rad_s`` with its crank
angle ``divergence_angle_deg``. The design values are the coordinates of their dimensions.

The design check's columns (fkev_slepc/design/point_checks.py) over (keys, ``speed_rad_s``, ...):
``torque_min_n_m``, ``torque_max_n_m``; over ``joint``: ``peak_joint_force_n``,
``peak_pin_force_n``; over ``link``: ``buckling_sf``, ``min_axial_force_n``; with ``--stress``
over (``case``, ``link``): ``peak_stress_pa``, ``static_sf``, ``fatigue_sf``; with
``--sensitivity`` ``sensitivity_<column>`` over a leading ``design_key`` dimension.
"""

from __future__ import annotations

import warnings

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.reader import ArchiveError
from fkev_slepc.status import json_number


_CHECKS = (P.D_TORQUE_MIN, P.D_TORQUE_MAX, P.D_JOINT_PEAK, P.D_PIN_PEAK, P.D_BUCKLING, P.D_MIN_AXIAL,
           P.D_PEAK_STRESS, P.D_STATIC_SF, P.D_FATIGUE_SF) + P.D_SENSITIVITY


def _strings(ds) -> list[str]:
    return [v.decode() if isinstance(v, bytes) else str(v) for v in ds[()]]


def open_design(path):
    """The ``/design`` group of an archive of ``fkev design`` as an ``xarray.Dataset``.

    Verified first (``archive.reader.checked``): a damaged archive warns (DamagedArchiveWarning).

    Raises
    ------
    ArchiveError
        Not an archive, one without a design study, one whose metadata cannot be decoded, or
        one a live run is writing.
    """
    import xarray as xr

    from fkev_slepc.archive.verified import checked
    from fkev_slepc.status import Status, converged_codes

    checked(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ArchiveError(f"{path}: cannot be read as an archive ({exc})") from None
    with f:
        if P.D_KEY not in f:
            raise ArchiveError(f"{path}: has no design study (/design): write one with `fkev design`")
        keys = _strings(f[P.D_KEY])
        values = f[P.D_VALUE.path][()]
        axes = [list(dict.fromkeys(values[:, k].tolist())) for k in range(len(keys))]
        shape = tuple(len(a) for a in axes)
        if int(np.prod(shape)) != len(values):
            raise ArchiveError(f"{path}: the design points are not a grid over {', '.join(keys)}")
        angles, speeds = f[P.ANGLE][()], f[P.SPEED][()]
        cases, modes = _strings(f[P.CASE]), f[P.MODE][()]
        status = np.asarray(f[P.D_STATUS.path][()], np.uint8)
        ok = np.isin(status, converged_codes())
        get = {v: f[v.path][()] for v in (P.D_FREQUENCY, P.D_DAMPING, P.D_EIGENVALUE, P.D_DIVERGENCE,
                                          P.D_DIVERGENCE_ANGLE)}
        checks = {v: (f[v.path][()], dict(f[v.path].attrs)) for v in _CHECKS if v.path in f}
        names = {d: _strings(f[d]) for d in (P.D_LINK, P.D_JOINT) if d in f}
    lookup = {s.code: s.value for s in Status}
    status_names = np.vectorize(lambda c: lookup.get(int(c), f"unknown_{c}"))(status)
    grid = keys + [P.ANGLE, P.SPEED, P.CASE]
    freq = np.where(ok[..., None], get[P.D_FREQUENCY], np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN bands stay NaN
        fmin, fmax = np.nanmin(freq, axis=1), np.nanmax(freq, axis=1)
    r = lambda a: a.reshape(shape + a.shape[1:])  # noqa: E731 - design point -> the key dims
    data = {
        P.D_FREQUENCY.name: (grid + [P.MODE], r(freq), {"units": "Hz", "long_name": P.D_FREQUENCY.long_name}),
        P.D_DAMPING.name: (grid + [P.MODE], r(np.where(ok[..., None], get[P.D_DAMPING], np.nan)), {"units": "1"}),
        P.D_EIGENVALUE.name: (grid + [P.MODE], r(get[P.D_EIGENVALUE]), {"units": "1/s"}),
        P.D_STATUS.name: (grid, r(status_names), {}),
        "frequency_min_hz": (keys + [P.SPEED, P.CASE, P.MODE], r(fmin),
                             {"units": "Hz", "long_name": "lowest frequency of the sorted mode over the crank cycle"}),
        "frequency_max_hz": (keys + [P.SPEED, P.CASE, P.MODE], r(fmax),
                             {"units": "Hz", "long_name": "highest frequency of the sorted mode over the crank cycle"}),
        "divergence_speed_rad_s": (keys + [P.CASE], r(get[P.D_DIVERGENCE]),
                                   {"units": "rad/s", "long_name": P.D_DIVERGENCE.long_name}),
        "divergence_angle_deg": (keys + [P.CASE], r(get[P.D_DIVERGENCE_ANGLE]), {"units": "degree"}),
    }
    dim = {P.D_KEY: "design_key", P.D_LINK: "link", P.D_JOINT: "joint", P.SPEED: P.SPEED, P.CASE: P.CASE}
    for v, (x, attrs) in checks.items():
        name = ("sensitivity_" if v.group.endswith("sensitivity") else "") + v.name
        extra = {k: str(a) for k, a in attrs.items() if k == "fatigue_criterion"}
        data[name] = (keys + [dim[d] for d in v.dims[1:]], r(x),
                      {"units": v.units, "long_name": v.long_name, **extra})
    coords = {k: np.asarray(a) for k, a in zip(keys, axes)}
    coords.update({P.ANGLE: angles, P.SPEED: speeds, P.CASE: cases, P.MODE: modes})
    coords.update({dim[d]: n for d, n in names.items()})
    if any(v in checks for v in P.D_SENSITIVITY):
        coords["design_key"] = list(keys)
    return xr.Dataset(data, coords=coords, attrs={"design_keys": list(keys), "source": str(path)})


ROW_VARS = ("frequency_min_hz", "frequency_max_hz", "divergence_speed_rad_s") + tuple(v.name for v in _CHECKS[:9])


def design_rows(ds) -> list[dict]:
    """One row per (design point, speed) of a design Dataset (:func:`open_design`): the key
    values, ``speed_rad_s`` and every per-speed column flattened as ``name.label...`` (e.g.
    ``peak_stress_pa.full.rod``, ``frequency_min_hz.full.1``,
    ``sensitivity_torque_max_n_m.links[rod].length_m``), None for NaN; a column NaN in every row
    is left out. The rows of ``fkev design --json`` and ``--csv``."""
    keys = list(ds.attrs["design_keys"])
    names = [n for n in ds.data_vars if n in ROW_VARS or n.startswith("sensitivity_")]
    rows = []
    for idx in np.ndindex(*[ds.sizes[k] for k in keys]):
        point = ds.isel(dict(zip(keys, idx)))
        for w in ds[P.SPEED].values:
            row = {k: float(point[k]) for k in keys} | {P.SPEED: float(w)}
            for name in names:
                da = point[name].sel({P.SPEED: w}) if P.SPEED in point[name].dims else point[name]
                for j in np.ndindex(*da.shape):
                    label = ".".join([name] + [str(da[d].values[i]) for d, i in zip(da.dims, j)])
                    row[label] = json_number(da.values[j])
            rows.append(row)
    kept = [c for c in rows[0] if any(r[c] is not None for r in rows)] if rows else []
    return [{c: r[c] for c in kept} for r in rows]
