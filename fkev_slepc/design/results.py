"""Reading a design study (fkev_slepc/design/study.py) as an xarray Dataset with the design keys
as dimensions.

``open_design(path)`` gives, over (``<key 1>``, ..., ``crank_angle_deg``, ``speed_rad_s``,
``case``, ``mode``): ``frequency_hz`` (NaN where a point did not converge), ``damping_ratio``,
``eigenvalue``, ``status`` (names), and derived over the crank cycle ``frequency_min_hz`` /
``frequency_max_hz`` (the band of each sorted mode at each speed, fkev_slepc/design/margins.py),
and per (keys, case) the lowest divergence speed ``divergence_speed_rad_s`` with its crank
angle ``divergence_angle_deg``. The design values are the coordinates of their dimensions.
"""

from __future__ import annotations

import warnings

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.reader import ArchiveError


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
    coords = {k: np.asarray(a) for k, a in zip(keys, axes)}
    coords.update({P.ANGLE: angles, P.SPEED: speeds, P.CASE: cases, P.MODE: modes})
    return xr.Dataset(data, coords=coords, attrs={"design_keys": list(keys), "source": str(path)})
