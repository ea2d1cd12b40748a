"""``Study.response``: the steady periodic elastic response at a crank speed, with its stations
(deflection, moment, axial force, stress), saved (HDF5) and drawn (docs/response.md §3-4).
The physics is in fkev_slepc/periodic/ (response, harmonic_balance, shooting, stations); this module checks the arguments and wraps."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.mechanism import node_displacement
from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.status import json_list, json_number

RESPONSE_FORMAT = "fkev-response"


@dataclass(frozen=True)
class ResponseResult:
    """The periodic response of one (speed, case) at the output angles."""

    title: str
    scene_text: str
    speed: float
    case: str
    gravity: np.ndarray
    angle_deg: np.ndarray  # (n,)
    q: np.ndarray  # (n, n_free) global DOFs
    node_positions: np.ndarray  # (n, n_node, 2) undeformed (rigid-body) positions
    node_displacement: np.ndarray  # (n, n_node, 2) elastic displacement, ground frame
    link_names: tuple[str, ...]
    stations: object  # periodic.stations.StationResponse
    harmonics: int
    hb_error: float
    hb_condition: float
    max_abs_multiplier: float  # NaN without shooting
    multiplier_error: float
    methods_difference: float  # max |q_HB - q_shooting| / max |q|
    closure: float  # ‖x(2π) − x(0)‖ / ‖x(0)‖ of the shooting trajectory
    elem_nodes: np.ndarray  # (n_el, 2) for drawing
    link_stress: object = None  # periodic.link_stress.LinkStress: σ₊, σ₋ at every element end
    truncation: object = None  # periodic.component_response.ResponseTruncation (None: the full model)
    attract_tol: float = DEFAULTS.attract_tol  # PeriodicSettings.attract_tol of the run (the verdict's rule)
    method: str = "harmonic balance"  # or "shooting": the balance abandoned (periodic/response.py)
    error: float = float("nan")  # estimated relative error of the response, by ``method``
    hb_levels: tuple = ()  # (H, estimate) of every harmonic-balance level, coarse to fine
    shooting_steps: int = 0  # Magnus steps of the shooting that gave the response (0: harmonic balance)
    tol: float = float("nan")  # the tolerance asked of the response (harmonic_tol)

    @property
    def converged(self) -> bool:
        """The response's error estimate ≤ ``tol`` (and, on link components, their truncation converged)."""
        return bool(self.error <= self.tol and (self.truncation is None or self.truncation.converged))

    def solution(self) -> dict:
        """How the response was solved and its truncation: ``method``, ``response_error`` (by that method),
        ``tol``, ``converged``, the balance's ``harmonics``, ``harmonic_balance_error`` and ``levels``
        ([H, estimate], coarse to fine; abandoned where the method is shooting), ``shooting_steps``,
        and the link-component ``truncation`` (None on the full model)."""
        return {"method": self.method, "response_error": json_number(self.error), "tol": json_number(self.tol),
                "converged": self.converged, "harmonics": self.harmonics,
                "harmonic_balance_error": json_number(self.hb_error),
                "levels": [[int(h), json_number(e)] for h, e in self.hb_levels], "shooting_steps": int(self.shooting_steps),
                "truncation": None if self.truncation is None else self.truncation.as_dict()}

    def plot(self, kind: str = "deflected", **options):
        """``deflected`` (the linkage at several angles, magnified, scale stated), ``stations``
        (stress, or bending moment without fibre distances, vs crank angle per station) or
        ``stress`` (the signed stress range along each link, and σ over the cycle at the peak)."""
        from fkev_slepc.plots import response as plots

        draw = {"deflected": plots.draw_deflected, "stations": plots.draw_stations, "stress": plots.draw_link_stress}
        return draw[kind](self, **options)

    def animate(self, path, scale=None, fps: int = 12):
        """A GIF of the deflected linkage over the output angles (matplotlib PillowWriter)."""
        from fkev_slepc.plots.response import animate

        return animate(self, path, scale, fps)

    @property
    def verdict(self) -> str | None:
        """``attracts`` (every |μ| < 1 beyond its error), ``neutral`` (max |μ| = 1 within its
        error: undamped), ``does not attract`` (some |μ| > 1); None without shooting
        (:func:`fkev_slepc.periodic.response.response_verdict`, the one rule)."""
        from fkev_slepc.periodic.response import response_verdict

        return response_verdict(self.max_abs_multiplier, self.multiplier_error, self.attract_tol)

    @property
    def attracting(self) -> bool | None:
        """False where some |μ| > 1 beyond its error: the periodic response does not attract."""
        from fkev_slepc.periodic.response import DOES_NOT_ATTRACT

        v = self.verdict
        return None if v is None else v != DOES_NOT_ATTRACT

    def peak_stress(self) -> dict | None:
        s = self.stations.stress
        if not np.isfinite(s).any():
            return None
        a, k = np.unravel_index(np.nanargmax(s), s.shape)
        st = self.stations.stations[k]
        return {"stress_pa": float(s[a, k]), "link": self.link_names[st.link], "s_m": st.s,
                "crank_angle_deg": float(self.angle_deg[a])}

    def as_dict(self) -> dict:
        from fkev_slepc.periodic.link_stress import FACES
        from fkev_slepc.periodic.stations import cycle_parts

        sr = self.stations
        _, _, mean, alternating = cycle_parts(np.stack([sr.stress_plus, sr.stress_minus], axis=-1))
        stations = []
        for k, st in enumerate(sr.stations):
            stations.append({
                "link": self.link_names[st.link], "s_m": st.s,
                "axial_m": json_list(sr.axial[:, k]), "transverse_m": json_list(sr.transverse[:, k]),
                "transverse_chord_m": json_list(sr.transverse_chord[:, k]),
                "moment_n_m": json_list(sr.moment[:, k]), "axial_force_n": json_list(sr.axial_force[:, k]),
                "axial_force_rigid_n": json_list(sr.axial_force_rigid[:, k]), "shear_n": json_list(sr.shear[:, k]),
                "stress_pa": json_list(sr.stress[:, k]), "stress_plus_pa": json_list(sr.stress_plus[:, k]),
                "stress_minus_pa": json_list(sr.stress_minus[:, k]),
                "stress_mean_pa": {face: json_number(mean[k, f]) for f, face in enumerate(FACES)},
                "stress_alternating_pa": {face: json_number(alternating[k, f]) for f, face in enumerate(FACES)},
                "envelope": {key: [float(np.nanmin(x[:, k])), float(np.nanmax(x[:, k]))] for key, x in (
                    ("transverse_m", sr.transverse), ("transverse_chord_m", sr.transverse_chord), ("axial_m", sr.axial), ("moment_n_m", sr.moment),
                    ("axial_force_n", sr.axial_force))},
            })
        return {
            "scene": self.title, "speed_rad_s": self.speed, "case": self.case, "gravity_m_s2": json_list(self.gravity),
            "crank_angle_deg": json_list(self.angle_deg), "stations": stations, "peak_stress": self.peak_stress(),
            "links": {} if self.link_stress is None else self.link_stress.as_dict(),
            "max_abs_multiplier": json_number(self.max_abs_multiplier), "attracting": self.attracting,
            "floquet_verdict": self.verdict,
            "multiplier_error": json_number(self.multiplier_error), "harmonics": self.harmonics,
            "harmonic_balance_error": json_number(self.hb_error), "methods_difference": json_number(self.methods_difference),
            "periodicity_closure": json_number(self.closure),
            "reduction": "none" if self.truncation is None else "links", **self.solution(),
            "max_deflection_m": float(np.nanmax(np.hypot(*np.moveaxis(self.node_displacement, -1, 0)))),
        }

    def save(self, path, attrs: dict | None = None):
        """HDF5 with dimension scales (``xarray.open_dataset(path, engine="h5netcdf")``)."""
        from fkev_slepc.archive.labelled import write_labelled

        sr = self.stations
        n_st = len(sr.stations)
        coords = {
            "crank_angle_deg": (self.angle_deg, "deg", "crank angle"),
            "station": (np.arange(n_st), "1", "station number"),
            "dof": (np.arange(self.q.shape[1]), "1", "free DOF (model numbering)"),
            "node": (np.arange(self.node_positions.shape[1]), "1", "node number"),
            "component": (["x", "y"], "1", "ground-frame component"),
        }
        st = sr.stations
        variables = {
            "q": (("crank_angle_deg", "dof"), self.q, "m or rad", "elastic DOFs, global frame"),
            "node_xy_m": (("crank_angle_deg", "node", "component"), self.node_positions, "m",
                          "rigid-body node positions"),
            "node_displacement_m": (("crank_angle_deg", "node", "component"), self.node_displacement, "m",
                                    "elastic node displacement, ground frame"),
            "station_link": (("station",), np.array([s.link for s in st]), "1", "link index (scene order)"),
            "station_s_m": (("station",), np.array([s.s for s in st]), "m", "distance from the link's root"),
        }
        for name, x, units, long in (("axial_m", sr.axial, "m", "axial elastic displacement (link frame)"),
                                     ("transverse_m", sr.transverse, "m", "transverse elastic displacement"),
                                     ("transverse_chord_m", sr.transverse_chord, "m",
                                      "transverse displacement from the chord through the link's deflected ends"),
                                     ("moment_n_m", sr.moment, "N m", "bending moment EI v''"),
                                     ("axial_force_n", sr.axial_force, "N", "axial force EA u', tension > 0"),
                                     ("axial_force_rigid_n", sr.axial_force_rigid, "N", "rigid-body axial force"),
                                     ("shear_n", sr.shear, "N", "shear force -dM/ds"),
                                     ("stress_pa", sr.stress, "Pa", "extreme-fibre stress max |N/A +- M c/I|"),
                                     ("stress_plus_pa", sr.stress_plus, "Pa",
                                      "signed stress N/A - M c/I of the face at +c along the left normal"),
                                     ("stress_minus_pa", sr.stress_minus, "Pa",
                                      "signed stress N/A + M c/I of the face at -c along the left normal")):
            variables[name] = (("crank_angle_deg", "station"), x, units, long)
        meta = {"title": self.title, "scene_toml": self.scene_text, "speed_rad_s": self.speed, "case": self.case,
                "gravity_m_s2": self.gravity.tolist(), "link_names": list(self.link_names),
                "harmonics": self.harmonics, "harmonic_balance_error": self.hb_error,
                "method": self.method, "response_error": self.error, "shooting_steps": self.shooting_steps,
                "max_abs_multiplier": self.max_abs_multiplier, "methods_difference": self.methods_difference,
                "reduction": "none" if self.truncation is None else "links",
                **({} if self.truncation is None else {"truncation": self.truncation.as_dict()}), **(attrs or {})}
        return write_labelled(path, RESPONSE_FORMAT, coords, variables, meta)


def study_response(scene: Scene, speed_rad_s: float, case: str = "full", angles_deg=None, *, gravity_m_s2=None,
                   harmonics: int | None = None, tol: float | None = None, shoot: bool | None = None, stations=None,
                   names=None, settings=None, reduce=None, model_for=None) -> ResponseResult:
    """The steady periodic response at ``speed_rad_s`` for ``case``: the code path of
    ``Study.response`` and ``fkev response`` (docs/response.md §3-4).

    Harmonic balance (``harmonics`` fixed, or doubled until the estimated error <= ``tol``)
    gives the response (one static solve where the system is constant in the link frame: a lone
    rotating link), or shooting to ``tol`` where the doubling on the full model is abandoned
    (``method``, fkev_slepc/periodic/response.py); with ``shoot`` (opt-in) the monodromy gives the
    Floquet multipliers (some |μ| > 1: the response exists but does not attract) and the shooting
    solution, whose difference from harmonic balance is reported. ``reduce``: default (the full model up to
    ``periodic.component_response.FULL_MAX_DOFS`` free DOFs, else links), none, links (the link-frame
    component basis, modes per link doubled until stress and deflection converge, static correction
    of the dropped modes; the truncation measured and stated) or links:N. ``stations``: {link name: [s_m, ...]}
    (default every link's root, midspan and tip). Raises SceneError for a bad argument, a
    crank acceleration (constant speed only) or an exact resonance ((I − Φ) singular).
    ``settings`` (:class:`~fkev_slepc.periodic.settings.PeriodicSettings`, default its defaults):
    harmonics, harmonic_tol (1e-8), shoot (False), shooting_tol and response_angles_deg; ``harmonics``,
    ``tol``, ``shoot`` and ``angles_deg``, when given, override them. ``model_for``: where the model
    comes from (:func:`fkev_slepc.periodic.steady.checked_model`; ``Study.response``: the study's pool).
    """
    from fkev_slepc.model.joint_loads import joint_loads
    from fkev_slepc.model.kinematics import point_local
    from fkev_slepc.periodic.stations import station_response
    from fkev_slepc.periodic.steady import checked_point, point_settings, steady_solve, whole_link_stress

    ps = point_settings(scene, settings, names, harmonics=harmonics, tol=tol, shoot=shoot, angles_deg=angles_deg)
    harmonics = ps.harmonics or None if harmonics is None else harmonics
    model, case, a, gravity = checked_point(scene, speed_rad_s, case, ps.response_angles_deg if angles_deg is None
                                            else angles_deg, gravity_m_s2=gravity_m_s2, harmonics=harmonics, names=names,
                                            reduce=reduce, settings=ps, model_for=model_for)
    mech = model.mechanism
    chosen = chosen_stations(scene, mech, stations, names)
    r = steady_solve(model, float(speed_rad_s), case, gravity, harmonics=harmonics, tol=ps.harmonic_tol, shoot=ps.shoot,
                     names=names, shooting_tol=ps.shooting_tol, reduce=reduce, settings=ps)
    theta = np.radians(a)
    q = r.at(theta)
    rigid = joint_loads(mech, theta, float(speed_rad_s), 0.0, gravity).axial_coef
    st = station_response(model, theta, q, chosen, rigid, speed=float(speed_rad_s), gravity=gravity)
    whole = whole_link_stress(model, a, q, speed=float(speed_rad_s), gravity=gravity)
    kin = model.angle_state(theta, with_loads=False).kinematics
    pos = point_local(kin, mech.node_link, mech.node_local)[0]
    disp = node_displacement(mech, q, mech.node_axis)[..., :2]  # (n, n_node, 2): x, y
    sh = r.shoot
    return ResponseResult(
        scene.title, scene.source_text, float(speed_rad_s), case, np.asarray(gravity, float), a, q, pos, disp,
        mech.link_names, st, r.hb.harmonics.shape[0] - 1, r.hb.error, r.hb.condition,
        r.max_abs_multiplier, float("nan") if sh is None else sh.error, r.methods_difference,
        float("nan") if sh is None else sh.closure, mech.elem_nodes, whole, r.truncation, ps.attract_tol, r.method,
        r.error, r.hb.levels, 0 if r.periodic is None else r.periodic.steps, float(ps.harmonic_tol))


def chosen_stations(scene: Scene, mech, stations, names=None):
    """The :class:`~fkev_slepc.periodic.stations.Station` s of ``stations`` ({link name: [s_m, ...]}),
    None for the default ones; SceneError naming ``stations`` for an unknown link or a distance off it."""
    from fkev_slepc.periodic.stations import stations_at

    if stations is None:
        return None
    name = (names or {}).get("stations", "stations")
    chosen = []
    for link, s_list in stations.items():
        if link not in mech.link_names:
            raise SceneError(scene.source, [Problem(name, f"unknown link {link!r}")])
        try:
            chosen += stations_at(mech, mech.link_names.index(link), s_list)
        except ValueError as err:
            raise SceneError(scene.source, [Problem(name, str(err))]) from None
    return chosen
