"""Tracking results in the archive: ``/tracking`` attributes and flags, ``/tracking/refined``.

The writer side of what :mod:`fkev_slepc.sweep.tracking` computes after a sweep (the per-point
eigenvector entries ``/tracking/signature`` are written with the points, by
:mod:`fkev_slepc.archive.writer`); the layout is in docs/tracking.md and docs/archive.md.
"""

from __future__ import annotations

import h5py
import numpy as np

from fkev_slepc.archive.groups import STATUS_DTYPE, _describe, flags, gridded, scale
from fkev_slepc.archive.store import _GRIDDED

_REFINED = ("crank_angle_deg", "frequency_hz", "tracked_frequency_hz", "status", "signature", "eigenvalue")


def read_refined(path) -> dict | None:
    """Arrays of ``/tracking/refined`` (the extra angles solved for tracking), or None."""
    with h5py.File(path, "r") as f:
        if "tracking/refined" not in f:
            return None
        g = f["tracking/refined"]
        return {k: g[k][()] for k in _REFINED}


def write_tracking(path, tracked: np.ndarray, fallback: np.ndarray, attrs: dict, speed_tracked: np.ndarray,
                   refined: dict | None = None, speed_fallback: np.ndarray | None = None) -> None:
    """Rank 0, before :func:`finalize`: store what tracking found (docs/tracking.md).

    ``tracked`` goes to ``tracked_frequency_hz`` and ``speed_tracked`` to
    ``speed_tracked_frequency_hz``; ``fallback`` (speed, case) and ``speed_fallback`` (angle,
    case) flag the lines left in sorted order; ``attrs`` (thresholds, counts) become attributes
    of ``/tracking``; ``refined`` (``crank_angle_deg``, ``frequency_hz``, ``tracked_frequency_hz``,
    ``status``, ``signature``, ``eigenvalue`` of the extra angles) is written to
    ``/tracking/refined``, its own angle scale first. Earlier tracking results are replaced."""
    with h5py.File(path, "r+") as f:
        f["tracked_frequency_hz"][...] = tracked
        if "speed_tracked_frequency_hz" not in f:  # archives created before it existed
            gridded(f, "speed_tracked_frequency_hz", tracked.shape, *_GRIDDED["speed_tracked_frequency_hz"],
                     ("crank_angle_deg", "speed_rad_s", "case", "mode"))
        f["speed_tracked_frequency_hz"][...] = speed_tracked
        g = f.require_group("tracking")
        for name in ("fallback", "speed_fallback", "refined"):
            if name in g:
                del g[name]
        root = {k: f[k] for k in ("crank_angle_deg", "speed_rad_s", "case", "mode")}
        ds = g.create_dataset("fallback", data=np.asarray(fallback, dtype="u1"))
        _describe(ds, "1", "1: the (speed, case) line is in sorted order in tracked_frequency_hz (ambiguous MAC)",
                  root["speed_rad_s"], root["case"])
        if speed_fallback is not None:
            ds = g.create_dataset("speed_fallback", data=np.asarray(speed_fallback, dtype="u1"))
            _describe(ds, "1", "1: the (angle, case) line is in sorted order in speed_tracked_frequency_hz "
                      "(ambiguous MAC)", root["crank_angle_deg"], root["case"])
        g.attrs.update(attrs)
        if refined is None or len(refined["crank_angle_deg"]) == 0:
            return
        r = g.create_group("refined")
        r.attrs["description"] = ("extra crank angles solved only for mode tracking, where the MAC between "
                                  "neighbouring grid angles was ambiguous; points of lines that were not refined "
                                  "at an angle are pending")
        sc = scale(r, "crank_angle_deg", np.asarray(refined["crank_angle_deg"], "f8"), "degree",
                   "extra crank angle (tracking refinement)")
        grid3 = (sc, root["speed_rad_s"], root["case"])
        for name, dtype, units, long_name, dims in (
            ("frequency_hz", "f8", "Hz", "natural frequency, sorted", grid3 + (root["mode"],)),
            ("tracked_frequency_hz", "f8", "Hz", "natural frequency, tracked along crank angle",
             grid3 + (root["mode"],)),
            ("eigenvalue", "c16", "1/s", "eigenvalue lambda of the sorted mode", grid3 + (root["mode"],)),
            ("status", STATUS_DTYPE, "1", "outcome of the point (pending: line not refined here)", grid3),
            ("signature", "c16", "1", "eigenvector entries of each sorted mode at /tracking/dofs",
             grid3 + (g["dofs"], root["mode"])),
        ):
            ds = r.create_dataset(name, data=np.asarray(refined[name]), dtype=dtype)
            _describe(ds, units, long_name, *dims)
            if name == "status":
                flags(ds)


def read_tracking(path) -> dict:
    """What figures need of tracking: ``attrs`` of ``/tracking``, ``fallback`` (speed, case)
    and ``speed_fallback`` (angle, case) flags (None when absent), ``speed_tracked`` (angle,
    speed, case, mode) or None. Archives without tracking give empty attrs and Nones."""
    with h5py.File(path, "r") as f:
        g = f["tracking"] if "tracking" in f else None
        out = {"attrs": dict(g.attrs) if g is not None else {}}
        for key in ("fallback", "speed_fallback"):
            out[key] = g[key][()].astype(bool) if g is not None and key in g else None
        out["speed_tracked"] = f["speed_tracked_frequency_hz"][()] if "speed_tracked_frequency_hz" in f else None
    return out


def read_signature(path, speed: int | None = None) -> np.ndarray | None:
    """``/tracking/signature`` (angle, speed, case, n_sig, mode), or one speed of it; None if absent."""
    with h5py.File(path, "r") as f:
        if "tracking/signature" not in f:
            return None
        ds = f["tracking/signature"]
        return ds[()] if speed is None else ds[:, speed]
