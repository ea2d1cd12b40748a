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
from fkev_slepc.model.plane import Plane


def read_refined(path, plane: str = "in") -> SimpleNamespace | None:
    """Arrays of ``/tracking/refined`` (the extra angles solved for tracking) as attributes named
    by their table ``source`` (``angles_deg``, ``freq``, ``tracked``, ``eigenvalue``, ``status``,
    ``sig``: the fields of :class:`fkev_slepc.sweep.tracking_angles.Samples`), or None.
    ``plane`` "out": those of the ``/planes/out`` sweep of a two-plane archive (likewise below)."""
    rows = [P.on_plane(v, plane) for v in P.REFINED]
    with h5py.File(path, "r") as f:
        if rows[0].path not in f:
            return None
        return SimpleNamespace(**{v.source: f[v.path][()] for v in rows})


def write_tracking(path, tracked: np.ndarray, fallback: np.ndarray, attrs: dict, speed_tracked: np.ndarray,
                   refined: dict | None = None, speed_fallback: np.ndarray | None = None, plane: str = "in") -> None:
    """Rank 0, before :func:`finalize`: store what tracking found (docs/tracking.md).

    ``tracked`` goes to ``tracked_frequency_hz`` and ``speed_tracked`` to
    ``speed_tracked_frequency_hz``; ``fallback`` (speed, case) and ``speed_fallback`` (angle,
    case) flag the lines left in sorted order; ``attrs`` (thresholds, counts) become attributes
    of ``/tracking``; ``refined`` (the extra angles: an object with the attributes named by the
    ``source`` of :data:`~fkev_slepc.archive.products.REFINED`, as :func:`read_refined` returns) is
    written to ``/tracking/refined``, its own angle scale first. Earlier tracking results are replaced.
    ``plane`` "out": into the ``/planes/out`` sweep of a two-plane archive."""
    on = {v: P.on_plane(v, plane) for v in (P.TRACKED, P.SPEED_TRACKED, P.FALLBACK, P.SPEED_FALLBACK) + P.REFINED}
    with h5py.File(path, "r+") as f:
        f[on[P.TRACKED].path][...] = tracked
        if on[P.SPEED_TRACKED].path not in f:  # archives created before it existed
            build(f, (on[P.SPEED_TRACKED],), {})
        f[on[P.SPEED_TRACKED].path][...] = speed_tracked
        group = f.require_group(on[P.FALLBACK].group)
        for old in (on[P.FALLBACK].path, on[P.SPEED_FALLBACK].path, on[P.REFINED[0]].group):
            if old in f:
                del f[old]
        given = {P.FALLBACK.source: fallback, P.SPEED_FALLBACK.source: speed_fallback}
        rows = [on[v] for v in (P.FALLBACK, P.SPEED_FALLBACK) if given[v.source] is not None]
        build(f, rows, {}, {v.path: np.asarray(given[v.source], dtype=v.dtype) for v in rows})
        group.attrs.update(attrs)
        if refined is None or len(getattr(refined, P.REFINED[0].source)) == 0:
            return
        refined_rows = [on[v] for v in P.REFINED]
        values = {refined_rows[0].path: np.asarray(getattr(refined, P.REFINED[0].source), "f8")}
        build(f, refined_rows, values, {v.path: np.asarray(getattr(refined, v.source)) for v in refined_rows
                                        if not v.scale})
        describe_groups(f, P.SWEEP if Plane.parse(plane).primary else P.PLANE_OUT)


def read_tracking(path, plane: str = "in") -> dict:
    """What figures need of tracking: ``attrs`` of ``/tracking``, ``fallback`` (speed, case)
    and ``speed_fallback`` (angle, case) flags (None when absent), ``speed_tracked`` (angle,
    speed, case, mode) or None. Archives without tracking give empty attrs and Nones."""
    fallback, speed_fallback, speed_tracked = (P.on_plane(v, plane) for v in (P.FALLBACK, P.SPEED_FALLBACK,
                                                                               P.SPEED_TRACKED))
    with h5py.File(path, "r") as f:
        g = f[fallback.group] if fallback.group in f else None
        out = {"attrs": dict(g.attrs) if g is not None else {}}
        for v in (fallback, speed_fallback):
            out[v.source] = f[v.path][()].astype(bool) if v.path in f else None
        out["speed_tracked"] = f[speed_tracked.path][()] if speed_tracked.path in f else None
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
