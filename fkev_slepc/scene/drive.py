"""The ``[drive]`` section of a scene: the motor, the flywheel, the gear and the drive shaft
(docs/theory.md §20.1). Without it the crank turns at constant speed, as before.

The motor is a straight line through ``motor_stall_torque_n_m`` and ``motor_no_load_speed_rpm``
(or ``motor_no_load_speed_rad_s``), or a ``motor_torque_table`` of [speed rad/s, torque N m]
rows; speeds are the motor shaft's, which turns ``gear_ratio`` times as fast as the crank.
Every value is SI (also under ``[units]``: the key names carry their unit).
"""

from __future__ import annotations

from fkev_slepc.scene.model import Drive
from fkev_slepc.scene.schema import Reader, join, show
from fkev_slepc.scene.units import RAD_S_PER_RPM

DRIVE_KEYS = ("motor_stall_torque_n_m", "motor_no_load_speed_rpm", "motor_no_load_speed_rad_s",
              "motor_torque_table", "motor_inertia_kg_m2", "flywheel_inertia_kg_m2", "gear_ratio",
              "shaft_stiffness_n_m_per_rad", "shaft_damping_n_m_s_per_rad")
LINE_KEYS = ("motor_stall_torque_n_m", "motor_no_load_speed_rpm", "motor_no_load_speed_rad_s")


def read_drive(r: Reader, doc) -> Drive | None:
    """``[drive]`` (None when absent or bad; problems on ``r``)."""
    if "drive" not in doc:
        return None
    table = r.table(doc, "drive", "")
    if table is None:
        return None
    n_before = len(r.problems)
    r.check_keys(table, "drive", DRIVE_KEYS)
    curve = _motor(r, table)
    inertia = [r.number(table, k, "drive", default=0.0, minimum=0.0)
               for k in ("motor_inertia_kg_m2", "flywheel_inertia_kg_m2")]
    gear = r.number(table, "gear_ratio", "drive", default=1.0, positive=True)
    stiffness = r.number(table, "shaft_stiffness_n_m_per_rad", "drive", default=None, positive=True)
    damping = r.number(table, "shaft_damping_n_m_s_per_rad", "drive", default=0.0, minimum=0.0)
    if "shaft_damping_n_m_s_per_rad" in table and "shaft_stiffness_n_m_per_rad" not in table:
        r.add("drive.shaft_damping_n_m_s_per_rad", f"needs drive.shaft_stiffness_n_m_per_rad (got "
              f"{show(table['shaft_damping_n_m_s_per_rad'])} without a shaft stiffness: a rigid shaft has no damping)")
    if len(r.problems) > n_before or curve is None:
        return None
    return Drive(curve[0], curve[1], inertia[0], inertia[1], gear, stiffness, damping, table="motor_torque_table" in table)


def _motor(r: Reader, table) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """(speeds, torques) of the motor's characteristic, from the line or the table."""
    line = [k for k in LINE_KEYS if k in table]
    if "motor_torque_table" in table:
        if line:
            r.add(f"drive.{line[0]}", f"give drive.motor_torque_table or the stall torque and no-load speed, not "
                  f"both (got {line[0]} = {show(table[line[0]])})")
            return None
        return _table(r, table["motor_torque_table"], "drive.motor_torque_table")
    if not line:
        r.missing("drive.motor_stall_torque_n_m", "give the motor: motor_stall_torque_n_m and "
                  "motor_no_load_speed_rpm (or _rad_s), or motor_torque_table")
        return None
    stall = r.number(table, "motor_stall_torque_n_m", "drive", positive=True,
                     remark="the motor's torque at zero speed, with motor_no_load_speed_rpm")
    if "motor_no_load_speed_rpm" in table and "motor_no_load_speed_rad_s" in table:
        r.add("drive.motor_no_load_speed_rad_s", "give motor_no_load_speed_rpm or motor_no_load_speed_rad_s, not both")
        return None
    if "motor_no_load_speed_rad_s" in table:
        w0 = r.number(table, "motor_no_load_speed_rad_s", "drive", positive=True)
    else:
        w0 = r.number(table, "motor_no_load_speed_rpm", "drive", positive=True,
                      remark="the motor's speed at zero torque (or motor_no_load_speed_rad_s)")
        w0 = None if w0 is None else w0 * RAD_S_PER_RPM
    if stall is None or w0 is None:
        return None
    return (0.0, w0), (stall, 0.0)


def _table(r: Reader, value, where: str):
    """[[speed, torque], ...]: at least two rows, speeds >= 0 and increasing."""
    if not isinstance(value, list) or len(value) < 2:
        r.add(where, f"must be a list of at least two [speed_rad_s, torque_n_m] rows (got {show(value)})")
        return None
    speeds, torques = [], []
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != 2:
            r.add(join(where, i), f"must be a pair [speed_rad_s, torque_n_m] (got {show(row)})")
            return None
        w = r.check_number(row[0], join(join(where, i), 0), minimum=0.0)
        t = r.check_number(row[1], join(join(where, i), 1))
        if w is None or t is None:
            return None
        if speeds and w <= speeds[-1]:
            r.add(join(join(where, i), 0), f"speeds must increase from row to row (got {show(row[0])} after "
                  f"{show(value[i - 1][0])})")
            return None
        speeds.append(w)
        torques.append(t)
    return tuple(speeds), tuple(torques)
