"""``fkev design-check`` / ``Study.design_check``: the periodic response and the kinetostatics of one
operating point, composed into the per-link design check of :mod:`fkev_slepc.design.check` (docs/design.md)."""

from __future__ import annotations

import numpy as np

from fkev_slepc.api.loads import study_loads
from fkev_slepc.api.response import study_response
from fkev_slepc.design.check import DesignCheck, link_check
from fkev_slepc.design.fatigue import CRITERIA
from fkev_slepc.model.buckling import WARN_BELOW, weak_axis_buckling
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.scene import Problem, Scene, SceneError


def design_check(scene: Scene, speed_rad_s: float, *, criterion: str = "goodman", case: str = "full",
                 angles_deg=None, gravity_m_s2=None, harmonics=None, tol: float = 1e-8,
                 threshold: float = WARN_BELOW, names=None) -> DesignCheck:
    """The :class:`DesignCheck` of ``scene`` at ``speed_rad_s``: the code path of
    ``fkev design-check``. ``criterion`` one of goodman, soderberg, gerber; ``threshold`` the
    weak-axis factor below which a warning is given. Raises SceneError naming a bad argument."""
    names = names or {}
    bad = []
    if criterion not in CRITERIA:
        bad.append(Problem(names.get("criterion", "criterion"), f"must be one of {', '.join(CRITERIA)} "
                           f"(got {criterion!r})"))
    if not (isinstance(threshold, (int, float)) and np.isfinite(threshold) and threshold > 0):
        bad.append(Problem(names.get("threshold", "threshold"), f"must be a finite number > 0 (got {threshold!r})"))
    if bad:
        raise SceneError(scene.source, bad)
    res = study_response(scene, speed_rad_s, case, angles_deg, gravity_m_s2=gravity_m_s2, harmonics=harmonics,
                         tol=tol, shoot=False, names=names)
    jl = study_loads(scene, speed_rad_s, res.angle_deg, 0.0, res.gravity, names=names)
    mech = build_mechanism(scene)
    buckling = weak_axis_buckling(mech, jl)
    links = tuple(link_check(scene, mech, res.link_stress, lk, criterion, buckling[lk], jl)
                  for lk in range(mech.n_link))
    return DesignCheck(scene.title, float(speed_rad_s), res.case, criterion, float(threshold), links)
