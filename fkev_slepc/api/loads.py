"""``Study.loads``: the rigid-body kinetostatics of a scene over the crank cycle, as a result
that can be printed, saved (HDF5) and drawn (docs/response.md §1). The physics is in
:mod:`fkev_slepc.model.joint_loads`; this module checks the arguments (API names) and wraps
the result."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from fkev_slepc.model.joint_loads import POINT_NAMES, JointLoads, joint_loads
from fkev_slepc.model.operating_point import (  # noqa: F401 (re-exported)
    checked_angles, operating_point_problems,
)
from fkev_slepc.scene import Scene, SceneError
from fkev_slepc.model.mechanism import build_mechanism

LOADS_FORMAT = "fkev-loads"


@dataclass(frozen=True)
class LoadsResult(JointLoads):
    """:class:`~fkev_slepc.model.joint_loads.JointLoads` of a scene, with :meth:`save` and :meth:`plot`."""

    title: str = ""
    scene_text: str = ""

    def as_dict(self) -> dict:
        return {"scene": self.title, **super().as_dict()}

    def save(self, path, attrs: dict | None = None):
        """Write the loads to an HDF5 file readable by ``xarray.open_dataset(path, engine="h5netcdf")``."""
        from fkev_slepc.archive.labelled import write_labelled

        ends = [(lk, k) for here in self.attach for lk, k in here]
        ef, ea, en = (_at(x, ends) for x in (self.end_force, self.end_along, self.end_normal))
        guides = [j for j in range(len(self.joint_names)) if not np.isnan(self.guide_reaction[:, j]).all()]
        coords = {
            "crank_angle_deg": (self.crank_angle_deg, "deg", "crank angle"),
            "joint": (list(self.joint_names), "1", "joint names in scene order"),
            "link_end": ([self.end_label(lk, k) for lk, k in ends], "1", "link point held by a joint"),
            "component": (["x", "y"], "1", "ground-frame component"),
            "element": (np.arange(self.elem_link.size), "1", "element number"),
            "element_end": (["left", "right"], "1", "element end (xi = 0, 1)"),
        }
        variables = {
            "joint_force_n": (("crank_angle_deg", "joint", "component"), self.joint_force, "N",
                              "joint force: bearing reaction of the ground on the linkage at a ground joint, "
                              "force on the first link end named in connects at a moving joint"),
            "joint_force_magnitude_n": (("crank_angle_deg", "joint"), self.joint_magnitude, "N", "|joint force|"),
            "end_force_n": (("crank_angle_deg", "link_end", "component"), ef, "N",
                            "force of the joint on the link point"),
            "end_force_along_n": (("crank_angle_deg", "link_end"), ea, "N", "end force along the link (root to tip)"),
            "end_force_normal_n": (("crank_angle_deg", "link_end"), en, "N", "end force along the link's left normal"),
            "driving_torque_n_m": (("crank_angle_deg",), self.torque, "N m", "driving torque on the crank"),
            "power_w": (("crank_angle_deg",), self.power, "W", "driving power torque x speed"),
            "energy_rate_w": (("crank_angle_deg",), self.energy_rate, "W", "dE_kinetic/dt + dE_potential/dt"),
            "kinetic_energy_j": (("crank_angle_deg",), self.kinetic_energy, "J", "rigid-body kinetic energy"),
            "axial_force_n": (("crank_angle_deg", "element", "element_end"), self.axial_force(), "N",
                              "axial force at the element's ends, tension > 0"),
            "element_link": (("element",), self.elem_link, "1", "link index of the element (scene order)"),
            "element_s_m": (("element", "element_end"), self.elem_s, "m", "station along the element's beam"),
        }
        variables["bearing_force_along_n"] = (("crank_angle_deg", "link_end"), _at(self.bearing_along, ends), "N",
                                              "the pin's force on the link point along the link (root to tip); at a "
                                              "slider the wrist pin's")
        variables["bearing_force_normal_n"] = (("crank_angle_deg", "link_end"), _at(self.bearing_normal, ends), "N",
                                               "the pin's force on the link point along the link's left normal")
        if guides:
            coords["guide_joint"] = ([self.joint_names[j] for j in guides], "1", "prismatic joints")
            variables["guide_reaction_n"] = (("crank_angle_deg", "guide_joint"), self.guide_reaction[:, guides],
                                             "N", "guide reaction along the guide's left normal")
            variables["pin_force_n"] = (("crank_angle_deg", "guide_joint", "component"), self.pin_force[:, guides],
                                        "N", "wrist-pin force: the link end's force on the slider block")
        if self.process_names:
            coords["process_load"] = (list(self.process_names), "1", "[[loads]] names")
            variables["process_force_n"] = (("crank_angle_deg", "process_load", "component"), self.process_force,
                                            "N", "process load force, ground frame")
            variables["process_moment_n_m"] = (("crank_angle_deg", "process_load"), self.process_moment, "N m",
                                               "process load moment")
        variables["process_power_w"] = (("crank_angle_deg",), self.process_power, "W",
                                        "power of the process loads (sum of F.v + M.omega)")
        meta = {"title": self.title, "scene_toml": self.scene_text, "speed_rad_s": self.speed,
                "acceleration_rad_s2": self.accel, "gravity_m_s2": self.gravity.tolist(),
                "link_names": list(self.link_names), "power_residual": self.power_residual, **(attrs or {})}
        return write_labelled(path, LOADS_FORMAT, coords, variables, meta)

    def plot(self, polar: str = "ground"):
        """Joint-force polar plot and driving torque vs crank angle (a matplotlib Figure);
        ``polar="link"``: every pin's force on each link it joins, relative to that link."""
        from fkev_slepc.plots.loads import draw_loads

        return draw_loads(self, polar)


def _at(x: np.ndarray, ends) -> np.ndarray:
    """Per-link-point data (n, n_link, 3, ...) at the (link, point) pairs ``ends``: (n, n_end, ...)."""
    return np.stack([x[:, lk, k] for lk, k in ends], axis=1)


def study_loads(scene: Scene, speed_rad_s: float, angles_deg=None, accel_rad_s2=None, gravity_m_s2=None,
                names=None) -> LoadsResult:
    """Rigid-body kinetostatics over the crank cycle: the code path of ``Study.loads`` and ``fkev loads``.

    Joint forces (ground frame, and along/normal to each link), guide reactions, link axial
    forces and the driving torque with the power check τΩ = dE/dt (docs/response.md §1) at
    crank speed ``speed_rad_s``, crank acceleration ``accel_rad_s2`` (default the scene's)
    and gravity ``gravity_m_s2`` ([gx, gy], default the scene's ``analysis.gravity_m_s2``),
    at ``angles_deg`` (default the scene's). ``names`` maps argument names to the caller's
    (flags) in messages. Returns a :class:`LoadsResult` (``as_dict()``, ``save(path)``, ``plot()``).

    Examples
    --------
    >>> from fkev_slepc import load
    >>> sc = load(RUNS / "slider-crank.toml").loads(314.16, [45])
    >>> round(float(sc.torque[0]), 3), sc.power_residual < 1e-12
    (74.896, True)
    """
    names = names or {}
    accel = scene.driver.acceleration if accel_rad_s2 is None else accel_rad_s2
    gravity = scene.analysis.gravity_m_s2 if gravity_m_s2 is None else gravity_m_s2
    bad = operating_point_problems(speed_rad_s, accel, gravity, names)
    if bad:
        raise SceneError(scene.source, bad)
    mech = build_mechanism(scene)
    a = checked_angles(scene, mech, angles_deg, names.get("angles_deg", "angles_deg"))
    jl = joint_loads(mech, np.radians(a), float(speed_rad_s), float(accel), gravity)
    jl = LoadsResult(**{f.name: getattr(jl, f.name) for f in fields(JointLoads) if f.name != "angle_deg"},
                     angle_deg=a, title=scene.title,
                     scene_text=scene.source_text)
    return jl


__all__ = ["LoadsResult", "study_loads", "POINT_NAMES"]
