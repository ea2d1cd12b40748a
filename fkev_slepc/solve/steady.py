"""The steady periodic response of a scene at one crank speed, checked and solved: the one code
path of ``fkev response`` (fkev_slepc/api/response.py), the design check and the design study's
stress columns (fkev_slepc/design/check.py, docs/response.md §3-4).

:func:`checked_point` refuses a bad operating point (naming the caller's field) before any
work; :func:`steady_solve` is harmonic balance (and with ``shoot`` the monodromy);
:func:`whole_link_stress` the signed stress at both ends of every axis element over the output
angles (fkev_slepc/solve/link_stress.py).
"""

from __future__ import annotations

import numpy as np

from fkev_slepc.scene import Problem, Scene, SceneError

DEFAULT_ANGLES_DEG = tuple(float(a) for a in np.arange(0.0, 360.0, 5.0))  # output angles of a response


def checked_point(scene: Scene, speed_rad_s, case: str = "full", angles_deg=None, *, gravity_m_s2=None,
                  harmonics=None, names=None):
    """``(model, case, angles_deg, gravity)`` of a response at ``speed_rad_s``, or one SceneError
    naming every bad argument: a speed or gravity that is not finite, an unknown case, a crank
    acceleration (constant speed only), a harmonics count below 1, output angles (default
    :data:`DEFAULT_ANGLES_DEG`) where the linkage does not assemble, or a crank that does not
    turn fully."""
    from fkev_slepc.model.operating_point import checked_angles, operating_point_problems
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene.cases import case_name

    names = names or {}
    gravity = scene.analysis.gravity_m_s2 if gravity_m_s2 is None else gravity_m_s2
    bad = operating_point_problems(speed_rad_s, 0.0, gravity, names)
    try:
        case = case_name(case)
    except ValueError as err:
        bad.append(Problem(names.get("case", "case"), str(err)))
    if scene.driver.acceleration != 0.0:
        bad.append(Problem("driver.acceleration_rad_s2", "the periodic response needs a constant crank speed "
                           f"(got {scene.driver.acceleration:g} rad/s²)"))
    if harmonics is not None and (int(harmonics) != harmonics or harmonics < 1):
        bad.append(Problem(names.get("harmonics", "harmonics"), f"must be an integer >= 1 (got {harmonics!r})"))
    if bad:
        raise SceneError(scene.source, bad)
    model = Model(scene, cases=(case,))
    name = names.get("angles_deg", "angles_deg")
    a = checked_angles(scene, model.mechanism, DEFAULT_ANGLES_DEG if angles_deg is None else angles_deg, name)
    checked_angles(scene, model.mechanism, np.arange(0.0, 360.0, 1.0), name)  # the crank must turn fully
    return model, case, a, np.asarray(gravity, float)


def steady_solve(model, speed_rad_s: float, case: str, gravity, *, harmonics=None, tol: float = 1e-8,
                 shoot: bool = True, names=None):
    """:func:`fkev_slepc.solve.response.periodic_response` of the model's
    :class:`~fkev_slepc.solve.periodic_system.PeriodicSystem`; an exact resonance is a SceneError
    naming the speed."""
    from fkev_slepc.solve.periodic_system import PeriodicSystem
    from fkev_slepc.solve.response import periodic_response
    from fkev_slepc.solve.response_shooting import ResonanceError

    system = PeriodicSystem(model, float(speed_rad_s), case, gravity=gravity)
    try:
        return periodic_response(system, float(speed_rad_s), case, harmonics=harmonics, tol=tol, shoot=shoot)
    except ResonanceError as err:
        name = (names or {}).get("speed_rad_s", "speed_rad_s")
        raise SceneError(model.mechanism.scene.source, [Problem(name, str(err))]) from None


def whole_link_stress(model, angles_deg, q):
    """:class:`~fkev_slepc.solve.link_stress.LinkStress` of the response ``q`` (n, n_free) at
    ``angles_deg``: σ₊, σ₋ at both ends of every axis element."""
    from fkev_slepc.solve.link_stress import LinkStress
    from fkev_slepc.solve.response_stations import element_end_stations, station_response

    mech = model.mechanism
    theta = np.radians(angles_deg)
    return LinkStress.from_stations(station_response(model, theta, q, element_end_stations(mech)),
                                    mech.link_names, angles_deg)
