"""The steady periodic response of a scene at one crank speed, checked and solved: the one code
path of ``fkev response`` (fkev_slepc/api/response.py), the design check and the design study's
stress columns (fkev_slepc/design/check.py, docs/response.md §3-4).

:func:`checked_point` refuses a bad operating point (naming the caller's field) before any
work; :func:`steady_solve` is harmonic balance (and with ``shoot`` the monodromy);
:func:`whole_link_stress` the signed stress at both ends of every axis element over the output
angles (fkev_slepc/periodic/link_stress.py).
"""

from __future__ import annotations

import numpy as np

from fkev_slepc.model.operators import Model
from fkev_slepc.periodic import limits
from fkev_slepc.periodic.settings import DEFAULTS, PeriodicSettings, checked_settings
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.scene.cases import terms_used

DEFAULT_ANGLES_DEG = DEFAULTS.response_angles_deg  # output angles of a response


class SharedModel:
    """A ``model_for`` (:func:`checked_point`) of one scene: one Model for every speed and case asked
    (a design point's responses, fkev_slepc/design/point_checks.py; the response and its overflow
    check, the default of :func:`checked_point`). A Model
    depends on neither: the speed enters the coefficients (PeriodicSystem, the QEP) and the case
    the solves, which keep only the case's terms of a model that may assemble more
    (fkev_slepc/api/pool.py). ``model``: one already built (of ``cases``), else built at the
    first call (after the caller's checks) in its plane with the terms of ``cases``; another plane
    or a case outside them gets a Model of its own. Only for that scene and its copies at other speeds."""

    def __init__(self, cases, model: Model | None = None):
        self.cases, self.model = tuple(cases), model

    def __call__(self, scene: Scene, cases, plane: str = "in") -> Model:
        cases = tuple(cases)
        if self.model is None:
            self.model = Model(scene, tuple(dict.fromkeys((*self.cases, *cases))), plane)
        if plane == self.model.plane and terms_used(cases) <= terms_used(self.model.cases):
            return self.model
        return Model(scene, cases, plane)



def checked_point(scene: Scene, speed_rad_s, case: str = "full", angles_deg=None, *, gravity_m_s2=None,
                  harmonics=None, names=None, reduce=None, settings: PeriodicSettings = DEFAULTS, model_for=None):
    """``(model, case, angles_deg, gravity)`` of a response at ``speed_rad_s``, or one SceneError
    naming every bad argument: a speed or gravity that is not finite, over-critical damping or
    operators that overflow at the speed (:func:`fkev_slepc.periodic.limits.plausibility_problems`,
    once the sizes are checked, on ``model_for``'s model of every case of the scene), and every problem of
    :func:`checked_model` (``settings`` and ``model_for`` as there); then the output angles (default
    :data:`DEFAULT_ANGLES_DEG`) where the linkage does not assemble. ``case`` is returned by name."""
    from fkev_slepc.model.operating_point import checked_angles, operating_point_problems
    from fkev_slepc.scene.cases import case_name

    names = names or {}
    model_for = SharedModel(scene.analysis.cases) if model_for is None else model_for  # response and overflow
    gravity = scene.analysis.gravity_m_s2 if gravity_m_s2 is None else gravity_m_s2
    bad = operating_point_problems(speed_rad_s, 0.0, gravity, names)
    bad = bad or limits.plausibility_problems(scene, periodic=True, names=names)  # damping
    model = checked_model(scene, case, harmonics, names, bad, reduce=reduce, settings=settings, model_for=model_for)
    bad = limits.plausibility_problems(scene, [speed_rad_s], names=names, model_for=model_for)  # after the sizes
    if bad:
        raise SceneError(scene.source, bad)
    a = checked_angles(scene, model.mechanism, DEFAULT_ANGLES_DEG if angles_deg is None else angles_deg,
                       names.get("angles_deg", "angles_deg"))
    return model, case_name(case), a, np.asarray(gravity, float)


def checked_model(scene: Scene, case: str, harmonics, names=None, bad=None, reduce=None,
                  settings: PeriodicSettings = DEFAULTS, model_for=None):
    """The Model of a periodic response of ``case``, or SceneError listing ``bad`` and every problem
    found before any work (docs/response.md §3): the case, a constant crank speed, a crank that
    turns fully, ``harmonics`` an integer >= 2 (the error estimate compares H with H/2), ``reduce``
    (default, none, links, links:N), and the dense harmonic balance within
    ``periodic.harmonic_balance.MAX_UNKNOWNS`` ((2H + 1)·R unknowns at the fixed H, or at H = 16, the
    first level doubled from 8; R = n for the full model, the first level's basis on link
    components: :func:`fkev_slepc.periodic.component_response.first_level_size`; not asked of a
    lone rotating link, one static solve), after the mesh and memory limits of
    :func:`fkev_slepc.periodic.limits.size_problems`. ``settings``: its ``full_max_dofs`` and ``link_modes``
    decide the reduction and its first level. ``model_for(scene, cases, plane)`` gives the model once
    the arguments are checked (default ``Model``: a new one; a Study passes its pool's
    :meth:`~fkev_slepc.api.pool.ModelPool.model_for`, whose model may assemble more terms than the
    case keeps: it is solved for ``case``, never for ``model.cases``)."""
    from fkev_slepc.model.operating_point import full_turn_problems
    from fkev_slepc.scene.cases import case_name
    from fkev_slepc.periodic.system import PeriodicSystem
    from fkev_slepc.periodic.harmonic_balance import MAX_UNKNOWNS
    from fkev_slepc.periodic.component_response import first_level_size, response_reduction

    names, bad = names or {}, list(bad or [])
    if not isinstance(settings, PeriodicSettings):
        bad.append(Problem("settings", f"must be a PeriodicSettings (got {type(settings).__name__})"))
        settings = DEFAULTS
    h_name = names.get("harmonics", "harmonics")
    try:
        case = case_name(case)
    except ValueError as err:
        bad.append(Problem(names.get("case", "case"), str(err)))
    if scene.driver.acceleration != 0.0:
        bad.append(Problem("driver.acceleration_rad_s2", "the periodic response needs a constant crank speed "
                           f"(got {scene.driver.acceleration:g} rad/s²)"))
    if harmonics is not None and (isinstance(harmonics, bool) or not np.isfinite(harmonics)
                                  or int(harmonics) != harmonics or harmonics < 2):
        bad.append(Problem(h_name, f"must be an integer >= 2: the error estimate compares H with H/2 "
                           f"(got {harmonics!r})"))
        harmonics = None
    try:
        response_reduction(None, reduce)
    except ValueError as err:
        bad.append(Problem(names.get("reduce", "reduce"), str(err)))
        reduce = "none"
    bad += full_turn_problems(scene)
    if bad:
        raise SceneError(scene.source, bad)
    bad = limits.size_problems(scene, True, harmonics, "default" if reduce is None else reduce, names)
    if bad:  # the limits of fkev response, in its words (fkev_slepc/periodic/limits.py)
        raise SceneError(scene.source, bad)
    model = (Model if model_for is None else model_for)(scene, (case,), "in")
    H = 16 if harmonics is None else int(harmonics)
    mode = response_reduction(model, reduce, settings.full_max_dofs)
    R = int(model.n_free) if mode is None else first_level_size(model, mode, settings.link_modes)
    size = (2 * H + 1) * R
    if size > MAX_UNKNOWNS and PeriodicSystem(model, 1.0, case).link_frame() is None:
        gb = 16.0 * size * size / 1e9  # the complex LU
        what = f"{model.n_free} DOFs" if mode is None else f"{R} link-component unknowns"
        raise SceneError(scene.source, [Problem(
            h_name if harmonics is not None else names.get("elements", "elements"),
            f"the dense harmonic balance would solve {2 * H + 1} harmonics x {what} = {size} unknowns "
            f"({gb:.3g} GB of complex LU), past its limit of {MAX_UNKNOWNS}: use fewer harmonics or elements"
            + ("" if mode is not None else ", or --reduce links"))])
    return model


def steady_solve(model, speed_rad_s: float, case: str, gravity, *, harmonics=None, tol: float = DEFAULTS.harmonic_tol,
                 shoot: bool = True, names=None, shooting_tol: float = DEFAULTS.shooting_tol, reduce=None,
                 settings: PeriodicSettings = DEFAULTS):
    """:func:`fkev_slepc.periodic.response.periodic_response` of the model's
    :class:`~fkev_slepc.periodic.system.PeriodicSystem` (``reduce`` and ``settings`` as there); an
    exact resonance is a SceneError naming the speed."""
    from fkev_slepc.periodic.system import PeriodicSystem
    from fkev_slepc.periodic.response import periodic_response
    from fkev_slepc.periodic.shooting import ResonanceError

    system = PeriodicSystem(model, float(speed_rad_s), case, gravity=gravity)
    try:
        return periodic_response(system, float(speed_rad_s), case, harmonics=harmonics, tol=tol, shoot=shoot,
                                 shooting_tol=shooting_tol, reduce=reduce, settings=settings)
    except ResonanceError as err:
        name = (names or {}).get("speed_rad_s", "speed_rad_s")
        raise SceneError(model.mechanism.scene.source, [Problem(name, str(err))]) from None


def point_settings(scene: Scene, settings, names=None, **overrides) -> PeriodicSettings:
    """The settings of one response: ``settings`` (None: the defaults) with the options given
    (``harmonics``, ``tol``, ``shoot``, ``angles_deg``; None: not given) in place of harmonics,
    harmonic_tol, shoot and response_angles_deg, or SceneError naming a bad one as the caller
    calls it. A bad ``harmonics`` is left to :func:`checked_model` (it names the rule of the error
    estimate) and bad angles to :func:`checked_point`."""
    names = names or {}
    fields = {"harmonics": "harmonics", "tol": "harmonic_tol", "shoot": "shoot", "angles_deg": "response_angles_deg"}
    st = checked_settings(scene.source, settings, {fields[k]: v for k, v in overrides.items()
                                                   if k not in ("harmonics", "angles_deg")},
                          {f: names.get(k, k) for k, f in fields.items()})
    h, a = overrides.get("harmonics"), overrides.get("angles_deg")
    try:
        return st.with_overrides(harmonics=h, response_angles_deg=a)
    except ValueError:
        return st  # checked_model / checked_point name it


def whole_link_stress(model, angles_deg, q, *, speed=None, gravity=(0.0, 0.0)):
    """:class:`~fkev_slepc.periodic.link_stress.LinkStress` of the response ``q`` (n, n_free) at
    ``angles_deg``: σ₊, σ₋ at both ends of every axis element; with the response's crank ``speed``
    and ``gravity`` the internal forces by element equilibrium (stations.element_forces)."""
    from fkev_slepc.periodic.link_stress import LinkStress
    from fkev_slepc.periodic.stations import element_end_stations, station_response

    mech = model.mechanism
    theta = np.radians(angles_deg)
    return LinkStress.from_stations(station_response(model, theta, q, element_end_stations(mech), speed=speed,
                                                     gravity=gravity),
                                    mech.link_names, angles_deg)
