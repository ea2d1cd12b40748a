"""Tracking results in the archive: ``/tracking`` attributes and flags, ``/tracking/refined``.

The writer side of what :mod:`fkev_slepc.sweep.tracking` computes after a sweep (the per-point
eigenvector entries ``/tracking/signature`` are written with the points, by
:mod:`fkev_slepc.archive.writer`); the layout is in docs/tracking.md and docs/archive.md, the
datasets are rows of :mod:`fkev_slepc.archive.products`.
"""

from __future__ import annotations

from types import SimpleNamespace

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.groups import build, describe_groups


def read_refined(path, plane: str = "in") -> SimpleNamespace | None:
    """Arrays of ``/tracking/refined`` (the extra angles solved for tracking) as attributes named
    by their table ``source`` (``angles_deg``, ``freq``, ``tracked``, ``eigenvalue``, ``status``,
    ``sig``: the fields of :class:`fkev_slepc.sweep.tracking_angles.Samples`), or None (always out of plane:
    ``plane`` "out", the ``/planes/out`` sweep of a two-plane archive, has no refined angles)."""
    with h5py.File(path, "r") as f:
        if P.R_ANGLE not in f or plane != "in":
            return None
        return SimpleNamespace(**{v.source: f[v.path][()] for v in P.REFINED})


def write_tracking(path, tracked: np.ndarray, fallback: np.ndarray, attrs: dict, speed_tracked: np.ndarray,
                   refined: dict | None = None, speed_fallback: np.ndarray | None = None) -> None:
    """Rank 0, before :func:`finalize`: store what tracking found (docs/tracking.md).

    ``tracked`` goes to ``tracked_frequency_hz`` and ``speed_tracked`` to
    ``speed_tracked_frequency_hz``; ``fallback`` (speed, case) and ``speed_fallback`` (angle,
    case) flag the lines left in sorted order; ``attrs`` (thresholds, counts) become attributes
    of ``/tracking``; ``refined`` (the extra angles: an object with the attributes named by the
    ``source`` of :data:`~fkev_slepc.archive.products.REFINED`, as :func:`read_refined` returns) is
    written to ``/tracking/refined``, its own angle scale first. Earlier tracking results are replaced."""
    with h5py.File(path, "r+") as f:
        f[P.TRACKED.path][...] = tracked
        if P.SPEED_TRACKED.path not in f:  # archives created before it existed
            build(f, (P.SPEED_TRACKED,), {})
        f[P.SPEED_TRACKED.path][...] = speed_tracked
        group = f.require_group(P.FALLBACK.group)
        for old in (P.FALLBACK.path, P.SPEED_FALLBACK.path, P.R_ANGLE.rpartition("/")[0]):
            if old in f:
                del f[old]
        given = {P.FALLBACK.source: fallback, P.SPEED_FALLBACK.source: speed_fallback}
        rows = [v for v in (P.FALLBACK, P.SPEED_FALLBACK) if given[v.source] is not None]
        build(f, rows, {}, {v.path: np.asarray(given[v.source], dtype=v.dtype) for v in rows})
        group.attrs.update(attrs)
        if refined is None or len(getattr(refined, P.REFINED[0].source)) == 0:
            return
        values = {P.R_ANGLE: np.asarray(getattr(refined, P.REFINED[0].source), "f8")}
        build(f, P.REFINED, values, {v.path: np.asarray(getattr(refined, v.source)) for v in P.REFINED if not v.scale})
        describe_groups(f, P.SWEEP)


def read_tracking(path, plane: str = "in") -> dict:
    """What figures need of tracking: ``attrs`` of ``/tracking``, ``fallback`` (speed, case)
    and ``speed_fallback`` (angle, case) flags (None when absent), ``speed_tracked`` (angle,
    speed, case, mode) or None. Archives without tracking give empty attrs and Nones.
    ``plane`` "out": those of the ``/planes/out`` sweep of a two-plane archive (along angle only)."""
    fallback = P.on_plane(P.FALLBACK, plane)
    with h5py.File(path, "r") as f:
        g = f[fallback.group] if fallback.group in f else None
        out = {"attrs": dict(g.attrs) if g is not None else {}}
        along_speed = plane == "in"  # out of plane: tracked along crank angle only
        for v in (fallback, P.SPEED_FALLBACK):
            out[v.source] = f[v.path][()].astype(bool) if v.path in f and (along_speed or v is fallback) else None
        out["speed_tracked"] = f[P.SPEED_TRACKED.path][()] if P.SPEED_TRACKED.path in f and along_speed else None
    return out


def read_signature(path, speed: int | None = None, plane: str = "in") -> np.ndarray | None:
    """``/tracking/signature`` (angle, speed, case, n_sig, mode), or one speed of it; None if absent
    (``plane`` "out": ``/planes/out/tracking/signature``)."""
    sig = P.on_plane(P.SIGNATURE, plane).path
    with h5py.File(path, "r") as f:
        if sig not in f:
            return None
        ds = f[sig]
        return ds[()] if speed is None else ds[:, speed]
