"""Checks of an operating point shared by the kinetostatics (``fkev loads``), the periodic
response (``fkev response``) and the design check and study (docs/response.md §1, §3): a finite
speed, acceleration and gravity vector, and crank angles at which the linkage assembles. Each
gives problems naming the caller's field, before any work starts."""

from __future__ import annotations

import numpy as np

from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.model.mechanism import build_mechanism


def operating_point_problems(speed_rad_s, accel_rad_s2, gravity_m_s2, names=None) -> list[Problem]:
    """Problems of a speed (finite), acceleration (finite) and gravity (a finite [gx, gy])."""
    names = names or {}
    bad = []
    for key, v in (("speed_rad_s", speed_rad_s), ("accel_rad_s2", accel_rad_s2)):
        if not (isinstance(v, (int, float, np.floating)) and np.isfinite(v)):
            bad.append(Problem(names.get(key, key), f"must be a finite number (got {v!r})"))
    g = np.asarray(gravity_m_s2, dtype=float) if np.ndim(gravity_m_s2) == 1 else None
    if g is None or g.shape != (2,) or not np.isfinite(g).all():
        bad.append(Problem(names.get("gravity_m_s2", "gravity_m_s2"),
                           f"must be a ground-frame vector [gx, gy] of finite numbers, m/s² (got {gravity_m_s2!r})"))
    return bad


def checked_angles(scene: Scene, mech, angles_deg, name="angles_deg") -> np.ndarray:
    """The crank angles (deg; default the scene's), refused where not finite or not assemblable."""
    a = np.atleast_1d(np.asarray(scene.analysis.crank_angles_deg if angles_deg is None else angles_deg, float))
    if a.size == 0 or not np.isfinite(a).all():
        raise SceneError(scene.source, [Problem(name, f"must be finite crank angles, deg (got {list(a)})")])
    ok = solve_kinematics(mech, np.radians(a)).ok
    if not ok.all():
        shown = ", ".join(f"{v:g}" for v in a[~ok][:5])
        raise SceneError(scene.source, [Problem(name, f"the linkage cannot be assembled at {shown} deg "
                                                      f"({int((~ok).sum())} of {a.size} angles)")])
    return a


FULL_TURN_STEP_DEG = 0.25  # the crank angles at which a full revolution is checked before a periodic analysis


def full_turn_problems(scene: Scene, mech=None) -> list[Problem]:
    """[] where the linkage assembles at every crank angle of a revolution (every
    ``FULL_TURN_STEP_DEG``), else the one Problem naming the scene's driver: the periodic analyses
    (``fkev floquet``, ``fkev response``) need a crank that turns fully, refused before any work."""
    a = np.arange(0.0, 360.0, FULL_TURN_STEP_DEG)
    ok = solve_kinematics(build_mechanism(scene) if mech is None else mech, np.radians(a)).ok
    if ok.all():
        return []
    edges = np.flatnonzero(np.diff(np.r_[True, ok, True].astype(int)))  # starts and ends of the failed runs
    spans = ", ".join(f"{a[i]:g}-{a[j - 1]:g}" for i, j in zip(edges[0::2], edges[1::2]))
    return [Problem("driver.link", f"the crank cannot turn fully: the linkage cannot be assembled at crank angles "
                                  f"{spans} deg; the periodic analyses need a full revolution (check the link lengths "
                                  "against Grashof's condition, or use fkev run/point over the angles it reaches)")]
