"""Views of a sweep archive (:class:`~fkev_slepc.archive.reader.SweepResults`): a labelled
``xarray.Dataset`` (xarray is optional: imported on use), the failed points, the run settings."""

from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.model.plane import Plane
from fkev_slepc.status import Status

_RUN_ATTRS = ("imag_tol", "damping_tol", "n_free", "mode_shapes", "n_ranks", "wall_time_s", "fkev_version",
              "petsc_version", "slepc_version", "h5py_version", "hdf5_version", "mpi_version")


class PointError(NamedTuple):
    """A point that failed or did not converge, with the solver's message."""

    angle_deg: float
    speed_rad_s: float
    case: str
    status: Status
    message: str


def errors(res) -> list[PointError]:
    """The ``/errors`` rows of ``res`` (one per point that is still failed or not converged)."""
    import h5py

    e = (P.SWEEP if Plane.parse(res.table_plane).primary else P.PLANE_OUT).errors
    with h5py.File(res.path, "r") as f:
        if e.index.path not in f:
            return []
        index, codes = f[e.index.path][()], f[e.status.path][()]
        msgs = [m.decode("utf-8", "replace") if isinstance(m, bytes) else str(m) for m in f[e.message.path][()]]
    return [PointError(float(res.crank_angle_deg[a]), float(res.speed_rad_s[s]), res.cases[c],
                       Status.from_code(code), m) for (a, s, c), code, m in zip(index, codes, msgs)]


def settings(res) -> dict:
    """Effective solver settings (``solver``; ``last_solver``: those of the latest resumed run),
    elements per link, thresholds, size, ranks, wall time and software versions."""
    out = {"solver": json_attr(res.attrs.get("solver_settings")), "elements": res.elements_per_link()}
    last = json_attr(res.attrs.get("last_solver_settings"))
    if last:
        out["last_solver"] = last
    for key in _RUN_ATTRS:
        if key in res.attrs:
            v = res.attrs[key]
            out[key] = v.item() if isinstance(v, np.generic) else v
    return out


def json_attr(raw) -> dict:
    """A JSON-valued archive attribute as a dict (empty when absent or unreadable)."""
    try:
        return json.loads(raw) if raw else {}
    except (TypeError, json.JSONDecodeError):
        return {}


PLANE_DIM = "plane"


def to_xarray(res):
    """``res`` as an ``xarray.Dataset`` on (crank_angle_deg, speed_rad_s, case, mode), with a leading
    ``plane`` dimension ("in", "out") when the archive holds both planes (``fkev run --plane both``;
    the out-of-plane sweep is on the same grid, so every variable has both) and ``res`` is its root
    sweep (``res.on_plane("out")`` gives the out-of-plane sweep alone). Mode shapes are not in the
    Dataset: their length is each plane's number of free DOFs (read them per plane with
    ``res.on_plane(p).mode_shape``).

    Frequencies, eigenvalues and residuals are masked (NaN) where the point did not converge;
    ``status`` holds the status names; ``damping_ratio`` is -Re λ / |λ|.
    """
    import xarray as xr

    if len(res.planes) > 1 and Plane.parse(res.table_plane).primary:
        parts = [_one_plane(res.on_plane(p)) for p in res.planes]
        ds = xr.concat(parts, dim=PLANE_DIM, combine_attrs="override")
        return ds.assign_coords({PLANE_DIM: list(res.planes)})
    return _one_plane(res)


def _one_plane(res):
    import xarray as xr

    conv = res.converged
    lam = np.where(conv[..., None], res.eigenvalue, complex(np.nan, np.nan))
    data = {
        P.FREQUENCY: res.frequency(order="sorted"),
        P.TRACKED: res.frequency(order="tracked"),
        P.EIGENVALUE: lam,
        P.DAMPING: np.where(conv[..., None], res.damping_ratio, np.nan),
        P.RESIDUAL: np.where(conv[..., None], res.residual, np.nan),
        P.MAX_REAL: res.max_real,
        P.STATUS_VAR: res.status_names.astype(str),
    }
    units = {v: {"units": v.units} for v in data if v is not P.STATUS_VAR}
    ds = xr.Dataset(
        {v.path: xr.Variable(v.dims, a, attrs=units.get(v, {})) for v, a in data.items()},
        coords={P.ANGLE: res.crank_angle_deg, P.SPEED: res.speed_rad_s, P.CASE: list(res.cases), P.MODE: res.modes},
    )
    ds.attrs.update(title=res.title, source=str(res.path))
    return ds
