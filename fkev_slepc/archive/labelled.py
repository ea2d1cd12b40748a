"""A sweep archive as a labelled ``xarray.Dataset`` (xarray is optional: imported on use)."""

from __future__ import annotations

import numpy as np

from fkev_slepc.status import STATUS_CODES

_UNITS = {"frequency_hz": "Hz", "tracked_frequency_hz": "Hz", "eigenvalue": "1/s", "residual": "1",
          "max_real": "1/s", "damping_ratio": "1"}


def to_xarray(res):
    """``res`` (a :class:`~fkev_slepc.archive.reader.SweepResults`) as an ``xarray.Dataset``.

    Frequencies and eigenvalues are the archive's, masked (NaN) where the point did not
    converge; ``status`` holds the status names; ``damping_ratio`` is -Re λ / |λ|.
    """
    import xarray as xr

    dims3 = ("crank_angle_deg", "speed_rad_s", "case")
    dims4 = dims3 + ("mode",)
    conv = res.converged
    lam = np.where(conv[..., None], res.eigenvalue, complex(np.nan, np.nan))
    names = np.array([s.value for s in sorted(STATUS_CODES, key=STATUS_CODES.get)], dtype=object)
    data = {
        "frequency_hz": (dims4, res.frequency(order="sorted")),
        "tracked_frequency_hz": (dims4, res.frequency(order="tracked")),
        "eigenvalue": (dims4, lam),
        "damping_ratio": (dims4, -lam.real / np.abs(lam)),
        "residual": (dims4, np.where(conv[..., None], res.residual, np.nan)),
        "max_real": (dims3, res.max_real),
        "status": (dims3, names[res.status.astype(np.int64)].astype(str)),
    }
    ds = xr.Dataset(
        {k: xr.Variable(d, v, attrs={"units": _UNITS[k]} if k in _UNITS else {}) for k, (d, v) in data.items()},
        coords={"crank_angle_deg": res.crank_angle_deg, "speed_rad_s": res.speed_rad_s,
                "case": list(res.cases), "mode": res.modes},
    )
    ds.attrs.update(title=res.title, source=str(res.path))
    return ds
