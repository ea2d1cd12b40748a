"""The design check of a linkage at one crank speed (docs/design.md, "Design check"): per link
the peak |σ| of the steady periodic response along the whole link, the static factor against
yield, the fatigue factor (fkev_slepc/design/fatigue.py) at its critical point, the weak-axis
Euler margin (fkev_slepc/model/buckling.py) and the peak pin loads of the link's joints from the
rigid-body kinetostatics (fkev_slepc/model/joint_loads.py); for the whole linkage, where its links
have out-of-plane section data, the lowest out-of-plane frequency over the cycle and its margin to
the crank orders (fkev_slepc/design/out_of_plane.py).

The stresses are those of ``fkev response`` at the same point (the harmonic-balance solution;
the monodromy is not needed for them and is skipped): σ₊, σ₋ at both ends of every axis element
over the output angles (fkev_slepc/periodic/link_stress.py). A point's material is its segment's.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from fkev_slepc.design.fatigue import CRITERIA, fatigue_factor, missing_strengths, static_factor
from fkev_slepc.design.out_of_plane import NOT_CHECKED, OutOfPlaneCheck, out_of_plane_check
from fkev_slepc.model.buckling import WARN_BELOW, Buckling, weak_axis_buckling
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.periodic.link_stress import FACES
from fkev_slepc.status import json_number

STRENGTHS = ("yield_strength", "ultimate_strength", "endurance_limit")
FULL_CYCLE_MAX_GAP_DEG = 30.0  # σm and σa need the whole revolution: no wider gap between the angles around it


@dataclass(frozen=True)
class LinkCheck:
    """The design check of one link (None: not available, the reason in ``notes``)."""

    link: str
    materials: tuple[str, ...]
    peak: dict | None  # periodic.link_stress.LinkStress.peak
    static_sf: float | None
    fatigue_sf: float | None
    critical: dict | None  # the fatigue-critical point: s_m, face, sigma_mean_pa, sigma_alternating_pa
    buckling: Buckling
    pins: dict[str, dict]  # joint name -> {"peak_n", "crank_angle_deg"}: the force on this link there
    notes: tuple[str, ...]
    points: dict | None = None  # per point: s_m, and per face static_sf, fatigue_sf (lists)

    def as_dict(self, criterion: str) -> dict:
        crit = self.critical or {}
        return {"material": "/".join(self.materials) or None,
                "peak_stress_pa": None if self.peak is None else self.peak["stress_pa"], "peak": self.peak,
                "static_sf": json_number(self.static_sf), "fatigue_sf": json_number(self.fatigue_sf),
                "fatigue_criterion": criterion,
                "sigma_mean_pa": crit.get("sigma_mean_pa"), "sigma_alternating_pa": crit.get("sigma_alternating_pa"),
                "critical_point": self.critical, "buckling_sf": self.buckling.factor,
                "min_axial_force_n": self.buckling.min_axial_force_n, "buckling": self.buckling.as_dict(),
                "pin_loads": self.pins, "notes": list(self.notes), "points": self.points}


@dataclass(frozen=True)
class DesignCheck:
    title: str
    speed: float  # rad/s
    case: str
    criterion: str
    threshold: float  # weak-axis buckling warning below this factor
    links: tuple[LinkCheck, ...]
    out_of_plane: OutOfPlaneCheck | None = None  # None: no out-of-plane section (not checked)
    settings: object = None  # the response's periodic.settings.PeriodicSettings, whole (printed in as_dict)

    @property
    def warnings(self) -> list[str]:
        return [w for lc in self.links for w in [lc.buckling.warning(self.threshold)] if w]

    @property
    def failures(self) -> list[str]:
        """One line per safety factor below 1 (static, fatigue or weak-axis buckling): the link fails."""
        return [f"link {lc.link}: {what} SF {sf:.3g} < 1" for lc in self.links
                for what, sf in (("static", lc.static_sf), ("fatigue", lc.fatigue_sf), ("buckling", lc.buckling.factor))
                if sf is not None and sf < 1.0]

    def as_dict(self) -> dict:
        return {"scene": self.title, "speed_rad_s": self.speed, "case": self.case, "fatigue_criterion": self.criterion,
                "buckling_threshold": self.threshold, "warnings": self.warnings,
                "failures": self.failures,
                "links": {lc.link: lc.as_dict(self.criterion) for lc in self.links},
                "out_of_plane": ({"checked": False, "note": NOT_CHECKED} if self.out_of_plane is None
                                 else self.out_of_plane.as_dict()),
                "settings": None if self.settings is None else self.settings.as_json()}


def point_strengths(scene: Scene, mech, ls) -> SimpleNamespace:
    """Yield, ultimate and endurance strength (Pa; NaN: not given) of every point of ``ls``."""
    def strength(e, field):
        m = scene.material(mech.elem_piece[e].material)
        value = None if m is None else getattr(m, field)
        return np.nan if value is None else value

    return SimpleNamespace(**{f: np.array([strength(e, f) for e in ls.point_element], dtype=float) for f in STRENGTHS})


def link_check(scene, mech, ls, lk, criterion, buckling, jl) -> LinkCheck:
    sel = np.flatnonzero(ls.point_link == lk)
    names = sorted({mech.elem_piece[e].material for e in ls.point_element[sel]} - {None})
    notes = []
    peak = ls.peak(lk)
    static = fatigue = critical = None
    points = {"s_m": ls.point_s[sel].tolist()}
    if peak is None:
        notes.append("no stress: the section gives no fibre distance")
    elif not names:
        notes.append("no safety factors: the link has no material")
    else:
        hi, lo, mean, alt = (x[sel] for x in ls.parts())  # (n_pt, 2)
        st = SimpleNamespace(**{f: getattr(point_strengths(scene, mech, ls), f)[sel, None] for f in STRENGTHS})
        n_static = static_factor(np.maximum(np.abs(hi), np.abs(lo)), st.yield_strength)
        if np.isnan(n_static).all():
            notes.append("no static factor: the material has no yield_pa")
        else:
            static = float(np.nanmin(n_static))
            points["static_sf"] = _faces(n_static)
        lacking = sorted({k for n in names for k in missing_strengths(scene.material(n), criterion)})
        if lacking:
            notes.append(f"no {criterion} fatigue factor: the material lacks {', '.join(lacking)}")
        else:
            n_fat = fatigue_factor(mean, alt, st, criterion)
            k, f = np.unravel_index(np.nanargmin(n_fat), n_fat.shape)
            fatigue = float(n_fat[k, f])
            points["fatigue_sf"] = _faces(n_fat)
            critical = {"s_m": float(ls.point_s[sel[k]]), "face": FACES[f], "sigma_mean_pa": float(mean[k, f]),
                        "sigma_alternating_pa": float(alt[k, f]), "sigma_max_pa": float(hi[k, f]),
                        "sigma_min_pa": float(lo[k, f])}
    pins = {}
    for jj, here in enumerate(jl.attach):
        for link, point in here:
            if link == lk:
                mag = np.hypot(*np.moveaxis(jl.bearing_force[:, lk, point], -1, 0))  # at a slider: the wrist pin
                a = int(np.nanargmax(mag))
                pins[jl.joint_names[jj]] = {"peak_n": float(mag[a]), "crank_angle_deg": float(jl.crank_angle_deg[a])}
    return LinkCheck(mech.link_names[lk], tuple(names), peak, static, fatigue, critical, buckling, pins, tuple(notes),
                     points)


def _faces(x: np.ndarray) -> dict:
    """{face: list} of a (n_pt, 2) array; NaN and ∞ as None (JSON)."""
    return {face: [json_number(v) for v in x[:, f]] for f, face in enumerate(FACES)}


def check_links(scene: Scene, mech, ls, jl, criterion: str) -> tuple[LinkCheck, ...]:
    """The :class:`LinkCheck` of every link from the whole-link stress ``ls``
    (:class:`~fkev_slepc.periodic.link_stress.LinkStress`) and the kinetostatics ``jl``
    (:class:`~fkev_slepc.model.joint_loads.JointLoads`) at the same angles."""
    buckling = weak_axis_buckling(mech, jl)
    return tuple(link_check(scene, mech, ls, lk, criterion, buckling[lk], jl) for lk in range(mech.n_link))


def check_problems(criterion, threshold, names=None) -> list[Problem]:
    """Problems of a fatigue criterion (one of :data:`~fkev_slepc.design.fatigue.CRITERIA`) and
    a buckling warning threshold (finite, > 0)."""
    names = names or {}
    bad = []
    if criterion not in CRITERIA:
        bad.append(Problem(names.get("criterion", "criterion"), f"must be one of {', '.join(CRITERIA)} "
                           f"(got {criterion!r})"))
    if not (isinstance(threshold, (int, float)) and np.isfinite(threshold) and threshold > 0):
        bad.append(Problem(names.get("threshold", "threshold"), f"must be a finite number > 0 (got {threshold!r})"))
    return bad


def cycle_problems(scene: Scene, angles_deg, criterion: str, names=None) -> list[Problem]:
    """The problem of crank angles that do not go round the whole revolution (a gap between
    neighbours, modulo 360° and around the circle, wider than :data:`FULL_CYCLE_MAX_GAP_DEG`) when
    a fatigue factor is computed (a link's material has the strengths ``criterion`` needs): its
    σm and σa are the mean and half range over the angles, and a part of the cycle understates σa."""
    used = {lk.material for lk in scene.links} | {s.material for lk in scene.links for s in lk.segments}
    if not any(scene.material(n) is not None and not missing_strengths(scene.material(n), criterion)
               for n in used - {None}):
        return []
    try:
        a = np.unique(np.mod(np.asarray(angles_deg, float).ravel(), 360.0))
    except (TypeError, ValueError):
        return []  # bad angles: checked_point names them
    if not (a.size and np.isfinite(a).all()):
        return []
    gap = float(np.diff(np.r_[a, a[0] + 360.0]).max())
    if gap <= FULL_CYCLE_MAX_GAP_DEG + 1e-9:
        return []
    return [Problem((names or {}).get("angles_deg", "angles_deg"),
                    f"the fatigue factor needs σm and σa over the whole revolution: the angles leave a gap of {gap:g} deg "
                    f"(at most {FULL_CYCLE_MAX_GAP_DEG:g}; the default 0:355:5 covers it) "
                    f"(got {a.size} crank angle{'s' if a.size > 1 else ''})")]


def design_check(scene: Scene, speed_rad_s: float, *, criterion: str = "goodman", case: str = "full",
                 angles_deg=None, gravity_m_s2=None, harmonics=None, tol: float | None = None,
                 threshold: float = WARN_BELOW, names=None, settings=None, model_for=None) -> DesignCheck:
    """The :class:`DesignCheck` of ``scene`` at ``speed_rad_s``: the code path of
    ``fkev design-check``. ``criterion`` one of goodman, soderberg, gerber; ``threshold`` the
    weak-axis factor below which a warning is given. The out-of-plane lowest frequency is frozen-time
    over the same angles (fkev_slepc/design/out_of_plane.py). The response is that of ``fkev response``
    (fkev_slepc/periodic/steady.py, the monodromy skipped), the loads those of ``fkev loads``
    without crank acceleration. Raises SceneError naming a bad argument. ``settings``
    (:class:`~fkev_slepc.periodic.settings.PeriodicSettings`): harmonics, harmonic_tol and
    response_angles_deg, overridden by ``harmonics``, ``tol`` and ``angles_deg`` when given, and the
    response's reduction (full_max_dofs, link_modes); the result carries them whole (``settings``).
    The check's own knobs are ``criterion`` and ``threshold`` (arguments, checked and printed).
    ``model_for(scene, cases, plane)`` gives the in-plane and out-of-plane models (default ``Model``:
    new ones; ``Study.design_check``: the study's pool, fkev_slepc/api/pool.py)."""
    from fkev_slepc.model.joint_loads import joint_loads
    from fkev_slepc.periodic.steady import checked_point, point_settings, steady_solve, whole_link_stress

    bad = check_problems(criterion, threshold, names)
    if bad:
        raise SceneError(scene.source, bad)
    ps = point_settings(scene, settings, names, harmonics=harmonics, tol=tol, angles_deg=angles_deg)
    bad = cycle_problems(scene, ps.response_angles_deg if angles_deg is None else angles_deg, criterion, names)
    if bad:
        raise SceneError(scene.source, bad)
    harmonics = ps.harmonics or None if harmonics is None else harmonics
    model, case, a, gravity = checked_point(scene, speed_rad_s, case, ps.response_angles_deg if angles_deg is None
                                            else angles_deg, gravity_m_s2=gravity_m_s2, harmonics=harmonics, names=names,
                                            settings=ps, model_for=model_for)
    r = steady_solve(model, float(speed_rad_s), case, gravity, harmonics=harmonics, tol=ps.harmonic_tol, shoot=False,
                     names=names, settings=ps)
    ls = whole_link_stress(model, a, r.at(np.radians(a)), speed=float(speed_rad_s), gravity=gravity)
    mech = model.mechanism
    jl = joint_loads(mech, np.radians(a), float(speed_rad_s), 0.0, gravity)
    links = check_links(scene, mech, ls, jl, criterion)
    oop = out_of_plane_check(scene, float(speed_rad_s), case, a, [lc.buckling for lc in links], model_for)
    return DesignCheck(scene.title, float(speed_rad_s), case, criterion, float(threshold), links, oop, ps)
