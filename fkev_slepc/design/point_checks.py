"""The design check of every design point of a design study (docs/design.md, "Design sweeps"):
the columns of ``fkev design`` beside the frequencies, over the study's crank angles at each of
its speeds.

- Always, from the rigid-body kinetostatics (fkev_slepc/model/joint_loads.py, ``fkev loads``;
  no elastic solve): the driving-torque range (min, max), the peak |force| of every joint, the
  peak wrist-pin force of every prismatic joint, and per link the weak-axis Euler factor
  P_cr/|N_min| (fkev_slepc/model/buckling.py) with its N_min.
- With ``stress`` (one periodic response per speed and case: far more than the frozen sweep of a
  point; all of them, and their checks, on the point's one Model:
  :class:`~fkev_slepc.periodic.steady.SharedModel`), per link the design check's peak |σ|, static
  and fatigue factors (:func:`fkev_slepc.design.check.check_links`, the code path of ``fkev design-check``).
- With ``sensitivity``, d/dp of the kinetostatic columns for every design key p: central
  differences of the whole kinetostatics of the scene at p ± h, h = 10⁻⁶|p| (10⁻⁶ for p = 0;
  truncation O(h²) ~ 10⁻¹² relative). A peak is the largest of the sampled angles, so its
  derivative is that of the value at the angle where it is reached (one-sided where two angles tie).

Every column comes from the functions ``fkev loads`` and ``fkev design-check`` call; nothing here
is a second stress, load or safety-factor formula.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.design.check import check_links, check_problems, cycle_problems
from fkev_slepc.model.buckling import weak_axis_buckling
from fkev_slepc.model.joint_loads import joint_loads
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.operators import Model
from fkev_slepc.periodic.steady import SharedModel, checked_point, steady_solve, whole_link_stress
from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.scene.edit import replace_values

REL_STEP = 1e-6  # the sensitivities' relative step (as fkev_slepc/solve/sensitivity.py)


@dataclass(frozen=True)
class CheckOptions:
    """What a design study computes besides the frequencies (the kinetostatic columns always)."""

    stress: bool = False
    sensitivity: bool = False
    criterion: str = "goodman"
    harmonics: int | None = None
    tol: float = DEFAULTS.harmonic_tol

    @property
    def needs(self) -> tuple[str, ...]:
        """The archive options (:attr:`fkev_slepc.archive.products.Var.needs`) of these columns."""
        return tuple(n for n, on in (("stress", self.stress), ("sensitivity", self.sensitivity)) if on)


def _factor(x) -> float:
    """A factor of the check as a float: NaN for None (not available) and ∞ (nothing stressed)."""
    return np.nan if x is None or not np.isfinite(x) else float(x)


def kinetostatic_columns(scene: Scene, angles_deg, speeds) -> dict[str, np.ndarray]:
    """Torque range, joint and wrist-pin peaks, weak-axis factors and N_min of ``scene`` at every
    speed over ``angles_deg`` (the scene's crank acceleration and gravity, as ``fkev loads``),
    keyed by the design product's dataset paths (without the design-point axis)."""

    mech = build_mechanism(scene)
    theta = np.radians(np.asarray(angles_deg, float))
    rows = []
    for w in np.asarray(speeds, float):
        jl = joint_loads(mech, theta, float(w), scene.driver.acceleration, scene.analysis.gravity_m_s2)
        if not jl.ok.any():  # assembles at none of the angles: nothing to report
            rows.append((np.nan, np.nan, np.full(len(mech.joint_names), np.nan), np.full(len(mech.joint_names), np.nan),
                         np.full(mech.n_link, np.nan), np.full(mech.n_link, np.nan)))
            continue
        pin = np.hypot(jl.pin_force[..., 0], jl.pin_force[..., 1])  # NaN at joints that are not prismatic
        b = weak_axis_buckling(mech, jl)
        rows.append((np.nanmin(jl.torque), np.nanmax(jl.torque), np.nanmax(jl.joint_magnitude, axis=0),
                     np.max(pin, axis=0), [_factor(x.factor) for x in b], [x.min_axial_force_n for x in b]))
    cols = (P.D_TORQUE_MIN, P.D_TORQUE_MAX, P.D_JOINT_PEAK, P.D_PIN_PEAK, P.D_BUCKLING, P.D_MIN_AXIAL)
    return {v.path: np.array([r[i] for r in rows], dtype=float) for i, v in enumerate(cols)}


def stress_columns(scene: Scene, angles_deg, speeds, cases, options: CheckOptions,
                   model: Model | None = None) -> dict[str, np.ndarray]:
    """Per (speed, case, link) the design check's peak |σ|, static and fatigue factors (NaN where
    the check gives none, or at an exact resonance, where the response has no periodic solution),
    keyed by the design product's dataset paths; every response on ``model`` (the point's sweep
    model; default one built for them all, :class:`~fkev_slepc.periodic.steady.SharedModel`)."""

    n_link = len(scene.links)
    out = {v.path: np.full((len(speeds), len(cases), n_link), np.nan)
           for v in (P.D_PEAK_STRESS, P.D_STATIC_SF, P.D_FATIGUE_SF)}
    models = SharedModel(cases, model)
    for js, w in enumerate(np.asarray(speeds, float)):
        for jc, case in enumerate(cases):
            model, case, a, gravity = checked_point(scene, float(w), case, angles_deg, harmonics=options.harmonics,
                                                    model_for=models)
            try:
                r = steady_solve(model, float(w), case, gravity, harmonics=options.harmonics, tol=options.tol,
                                 shoot=False)
            except SceneError:  # (I − Φ) singular: an exact resonance at this speed
                continue
            theta = np.radians(a)
            ls = whole_link_stress(model, a, r.at(theta), speed=float(w), gravity=gravity)
            jl = joint_loads(model.mechanism, theta, float(w), 0.0, gravity)
            for lk, c in enumerate(check_links(scene, model.mechanism, ls, jl, options.criterion)):
                out[P.D_PEAK_STRESS.path][js, jc, lk] = np.nan if c.peak is None else c.peak["stress_pa"]
                out[P.D_STATIC_SF.path][js, jc, lk] = _factor(c.static_sf)
                out[P.D_FATIGUE_SF.path][js, jc, lk] = _factor(c.fatigue_sf)
    return out


def sensitivity_columns(scene: Scene, keys, values, angles_deg, speeds, base: dict) -> dict[str, np.ndarray]:
    """d/dp of the kinetostatic columns ``base`` (:data:`fkev_slepc.archive.products.D_SMOOTH`)
    for every design key p at ``values`` (central differences, module docstring), stacked over
    the keys; NaN for a key whose p ± h is not a valid scene."""

    here = dict(zip(keys, (float(v) for v in values)))
    out = {v.path: [] for v in P.D_SENSITIVITY}
    for key, p in here.items():
        h = REL_STEP * abs(p) if p != 0 else REL_STEP
        try:
            plus, minus = (kinetostatic_columns(replace_values(scene, {**here, key: p + d}), angles_deg, speeds)
                           for d in (h, -h))
        except SceneError:  # an integer key, a value at a bound
            plus = minus = {v.path: np.full_like(base[v.path], np.nan) for v in P.D_SMOOTH}
        for v, d in zip(P.D_SMOOTH, P.D_SENSITIVITY):
            out[d.path].append((plus[v.path] - minus[v.path]) / (2 * h))
    return {path: np.stack(rows) for path, rows in out.items()}


def point_named(i: int, points: int, problems) -> list[Problem]:
    """``problems`` of design point ``i`` of ``points``, their paths prefixed with the point where there are several."""
    return [Problem(f"design point {i}: {p.path}" if points > 1 else p.path, p.message) for p in problems]


def stress_option_problems(scenes, angles_deg, options: CheckOptions, names=None) -> list[Problem]:
    """With ``stress``, what no design point can mend: a bad fatigue criterion, or crank angles that do
    not go round the revolution where a point's fatigue factor needs it (the first such point's words)."""

    if not options.stress:
        return []
    names = names or {}
    bad = check_problems(options.criterion, 1.0, names)
    return bad or next((p for p in (cycle_problems(sc, angles_deg, options.criterion, names) for sc in scenes)
                        if p), [])


def stress_point_problems(scene: Scene, angles_deg, cases, options: CheckOptions, names=None,
                          model_for=None) -> list[Problem]:
    """With ``stress``: why the periodic responses of one design point cannot start
    (:func:`fkev_slepc.periodic.steady.checked_point` of every case, up to the first refused), on
    ``model_for``'s model (default one :class:`SharedModel` for all its cases)."""

    if not options.stress:
        return []
    models = model_for or SharedModel(cases)
    for case in cases:
        try:
            checked_point(scene, 0.0, case, angles_deg, harmonics=options.harmonics, names=names or {},
                          model_for=models)
        except SceneError as err:
            return list(err.problems)
    return []
