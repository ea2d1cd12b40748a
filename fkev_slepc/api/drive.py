"""``Study.drive``: the rigid machine's steady cycle with the scene's ``[drive]`` (``fkev drive``,
docs/theory.md §20): speed, acceleration and time over the revolution, the mean speed, the
coefficient of speed fluctuation and, for a requested one, the flywheel. The physics is in
:mod:`fkev_slepc.model.drive_cycle`; this module checks the arguments and wraps the result
(``as_dict()``, ``save(path)``: HDF5 with checksums, ``plot()``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.drive_cycle import DriveCycle, DriveError, DriveProblem, flywheel_for
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.operating_point import full_turn_problems
from fkev_slepc.scene import Problem, Scene, SceneError

DRIVE_FORMAT = "fkev-drive"


@dataclass(frozen=True)
class DriveResult:
    """A :class:`~fkev_slepc.model.drive_cycle.DriveCycle` of a scene, with the flywheel for a
    requested fluctuation (``flywheel`` None when none was asked)."""

    cycle: DriveCycle
    title: str = ""
    scene_text: str = ""
    fluctuation_requested: float | None = None
    flywheel: float | None = None  # kg m², motor shaft

    def as_dict(self) -> dict:
        """The JSON of ``fkev drive --json`` (SI units; arrays over the mesh nodes of the revolution)."""
        c = self.cycle
        out = {
            "scene": self.title, "crank_angle_deg": np.degrees(c.theta).tolist(), "speed_rad_s": c.speed.tolist(),
            "accel_rad_s2": c.accel.tolist(), "time_s": c.time.tolist(), "mean_speed_rad_s": c.mean_speed,
            "coefficient_of_fluctuation": c.fluctuation, "motor_torque_n_m": c.motor_torque.tolist(),
            "crank_torque_n_m": c.crank_torque.tolist(), "load_torque_n_m": c.load_torque.tolist(),
            "inertia_kg_m2": c.inertia.tolist(), "period_s": c.period, "speed_min_rad_s": c.speed_min,
            "speed_max_rad_s": c.speed_max, "reference_speed_rad_s": c.reference_speed,
            "energy_method_fluctuation": c.energy_estimate, "gear_ratio": c.drive.gear_ratio,
            "flywheel_inertia_kg_m2": c.drive.flywheel_inertia,
        }
        if self.fluctuation_requested is not None:
            out.update(fluctuation_requested=self.fluctuation_requested, flywheel_for_fluctuation_kg_m2=self.flywheel)
        return out

    def save(self, path, attrs: dict | None = None):
        """HDF5 (``xarray.open_dataset(path, engine="h5netcdf")``), checksummed: ``fkev verify`` checks it."""
        from fkev_slepc.archive.labelled import write_labelled

        c, dim = self.cycle, ("crank_angle_deg",)
        coords = {"crank_angle_deg": (np.degrees(c.theta), "deg", "crank angle (mesh nodes of the revolution)")}
        variables = {
            "speed_rad_s": (dim, c.speed, "rad/s", "crank speed in the steady cycle"),
            "accel_rad_s2": (dim, c.accel, "rad/s2", "crank acceleration"),
            "time_s": (dim, c.time, "s", "time from crank angle 0"),
            "motor_torque_n_m": (dim, c.motor_torque, "N m", "motor torque on the motor shaft"),
            "crank_torque_n_m": (dim, c.crank_torque, "N m", "torque the drive puts into the crank"),
            "load_torque_n_m": (dim, c.load_torque, "N m", "torque of gravity and process loads (virtual work)"),
            "inertia_kg_m2": (dim, c.inertia, "kg m2", "equivalent inertia J at the crank, drive included"),
        }
        scalars = {k: v for k, v in self.as_dict().items() if not isinstance(v, list)}
        meta = {"title": self.title, "scene_toml": self.scene_text,
                **{k: (math.nan if v is None else v) for k, v in scalars.items() if k != "scene"}, **(attrs or {})}
        return write_labelled(path, DRIVE_FORMAT, coords, variables, meta, checksums=True)

    def plot(self):
        """Speed and torques over the revolution (a matplotlib Figure)."""
        from fkev_slepc.plots.drive import draw_drive

        return draw_drive(self)


def study_drive(scene: Scene, fluctuation: float | None = None, gravity_m_s2=None, progress=None,
                names=None) -> DriveResult:
    """The code path of ``Study.drive`` and ``fkev drive``: the steady cycle of the scene's
    ``[drive]`` (docs/theory.md §20.3) and, with ``fluctuation`` δ, the flywheel inertia (motor
    shaft, kg m²) for it (§20.4; ``progress(k, J_f, δ)`` told each iteration). Bad input (no
    ``[drive]``, a crank that cannot turn fully, δ outside (0, 1), a motor that cannot carry
    the load) raises SceneError naming the field before any iteration."""
    names = names or {}
    flag = names.get("fluctuation", "fluctuation")
    bad = []
    if scene.drive is None:
        bad.append(Problem("drive", "missing: the scene has no [drive] section (its crank turns at constant speed); "
                           "give the motor, e.g. [drive] motor_stall_torque_n_m, motor_no_load_speed_rpm, "
                           "flywheel_inertia_kg_m2 (docs/theory.md §20.1)"))
    if fluctuation is not None and not (0.0 < fluctuation < 1.0):
        bad.append(Problem(flag, f"must be > 0 and < 1 (got {fluctuation!r}): δ = (ω_max − ω_min)/ω_mean"))
    mech = build_mechanism(scene)
    bad += full_turn_problems(scene, mech)
    if bad:
        raise SceneError(scene.source, bad)
    gravity = scene.analysis.gravity_m_s2 if gravity_m_s2 is None else gravity_m_s2
    try:
        problem = DriveProblem(mech, gravity)
        cycle = problem.solve(scene.drive)
        flywheel = None
        if fluctuation is not None:
            flywheel = flywheel_for(problem, scene.drive, float(fluctuation), progress)[0]
    except DriveError as err:
        raise SceneError(scene.source, [Problem(names.get(err.key, err.key), str(err))]) from None
    return DriveResult(cycle, scene.title, scene.source_text, fluctuation, flywheel)


__all__ = ["DriveResult", "study_drive", "DRIVE_FORMAT"]
