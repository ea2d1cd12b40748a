"""Crank speeds in rev/min: the conversion, and whether a scene (or a command line) used rpm.

Scenes store speeds in rad/s; when the user wrote them in rpm (``driver.speeds_rpm``,
``--speeds-rpm``, ``--speed-rpm``) the outputs show rpm beside rad/s.
"""

from __future__ import annotations

import math
import tomllib
from fkev_slepc.scene.process_loads import split_station

RAD_S_PER_RPM = 2.0 * math.pi / 60.0


def speeds_given_in_rpm(scene_toml: str, command_line: str = "") -> bool:
    """True when ``driver.speeds_rpm`` is in the scene text or ``--speeds-rpm``/``--speed-rpm``
    is on the command line.

    Examples
    --------
    >>> speeds_given_in_rpm('[driver]\\nspeeds_rpm = [600]')
    True
    """
    if "--speeds-rpm" in command_line or "--speed-rpm" in command_line:
        return True
    try:
        doc = tomllib.loads(scene_toml) if scene_toml else {}
    except tomllib.TOMLDecodeError:
        return False
    driver = doc.get("driver")
    return isinstance(driver, dict) and "speeds_rpm" in driver


def with_rpm(rad_s: float, show: bool) -> str:
    """``104.72 rad/s`` or ``104.72 rad/s (1000 rpm)``."""
    return f"{rad_s:g} rad/s" + (f" ({rad_s / RAD_S_PER_RPM:.6g} rpm)" if show else "")


# -- [units]: a scene written in another coherent system, converted to SI once, on reading ----
LBF_N = 4.4482216152605  # pound-force, N (exact by definition)
INCH_M = 0.0254
LENGTHS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": INCH_M, "ft": 0.3048}
FORCES = {"N": 1.0, "kN": 1e3, "lbf": LBF_N}
MASSES = {"kg": 1.0, "t": 1e3, "g": 1e-3, "lbf_s2_per_in": LBF_N / INCH_M, "lb": 0.45359237}
# the usual coherent systems (force = mass x length / s²): mm-N-t (t·mm/s² = 1 N), in-lbf-s
SYSTEMS = {"SI": ("m", "N", "kg"), "mm-N-t": ("mm", "N", "t"), "in-lbf-s": ("in", "lbf", "lbf_s2_per_in")}
UNITS_KEYS = ("system", "length", "force", "mass")
# key -> exponents of (length, force, mass) of its value; time is always in s, angles in deg/rad
DIMENSIONS = {
    "length_m": (1, 0, 0), "position_m": (1, 0, 0), "third_joint_m": (1, 0, 0), "fibre_distance_m": (1, 0, 0),
    "diameter_m": (1, 0, 0), "width_m": (1, 0, 0), "height_m": (1, 0, 0), "outer_diameter_m": (1, 0, 0),
    "inner_diameter_m": (1, 0, 0), "area_m2": (2, 0, 0), "second_moment_m4": (4, 0, 0),
    "youngs_modulus_pa": (-2, 1, 0), "density_kg_m3": (-3, 0, 1),
    "second_moment_out_of_plane_m4": (4, 0, 0), "torsion_constant_m4": (4, 0, 0), "polar_moment_m4": (4, 0, 0),
    "fibre_distance_out_of_plane_m": (1, 0, 0), "shear_modulus_pa": (-2, 1, 0), "yield_pa": (-2, 1, 0),
    "ultimate_pa": (-2, 1, 0), "endurance_pa": (-2, 1, 0),
    "mass_kg": (0, 0, 1), "slider_mass_kg": (0, 0, 1), "inertia_kg_m2": (2, 0, 1),
    "bearing_stiffness_nm_rad": (1, 1, 0),
    "fx_n": (0, 1, 0), "fy_n": (0, 1, 0), "moment_n_m": (1, 1, 0),
}
CONVERTED_SECTIONS = ("materials", "link_defaults", "links", "joints", "masses", "loads")  # where dimensional keys live


def read_units(r, doc) -> tuple[float, float, float] | None:
    """The ``[units]`` table of a scene document as SI factors (length, force, mass), problems on ``r``.

    ``system = "mm-N-t"`` (or ``"in-lbf-s"``, ``"SI"``), or any of ``length`` (m, mm, cm, in,
    ft), ``force`` (N, kN, lbf), ``mass`` (kg, t, g, lb, lbf_s2_per_in), the others SI.

    Examples
    --------
    >>> from fkev_slepc.scene.schema import Reader
    >>> length, force, mass = read_units(Reader(), {"units": {"system": "in-lbf-s"}})
    >>> length, force, round(mass, 6)   # m, N, kg per lbf·s²/in
    (0.0254, 4.4482216152605, 175.126835)
    """
    table = r.table(doc, "units", "")
    if table is None:
        return None
    r.check_keys(table, "units", UNITS_KEYS)
    if "system" in table:
        system = r.string(table, "system", "units", choices=tuple(SYSTEMS))
        extra = [k for k in ("length", "force", "mass") if k in table]
        if extra:
            r.add(f"units.{extra[0]}", "give units.system or length/force/mass, not both")
            return None
        if system is None:
            return None
        names = SYSTEMS[system]
    else:
        names = tuple(r.string(table, key, "units", default=SYSTEMS["SI"][i], choices=tuple(choices))
                      for i, (key, choices) in enumerate((("length", LENGTHS), ("force", FORCES), ("mass", MASSES))))
        if None in names:
            return None
    return LENGTHS[names[0]], FORCES[names[1]], MASSES[names[2]]


def units_label(doc) -> str:
    """``mm-N-t`` or ``length mm, force N, mass t`` for a document's ``[units]`` table."""
    t = doc.get("units", {})
    if "system" in t:
        return str(t["system"])
    return ", ".join(f"{k} {t.get(k, d)}" for k, d in zip(("length", "force", "mass"), SYSTEMS["SI"]))


def to_si(doc: dict, factors: tuple[float, float, float]) -> dict:
    """A copy of ``doc`` without ``[units]``, every dimensional value (:data:`DIMENSIONS`) of the
    linkage sections multiplied by its SI factor; values of the wrong type are left for the
    reader to report."""
    length, force, mass = factors

    def factor(key):
        a, b, c = DIMENSIONS[key]
        return length**a * force**b * mass**c

    def convert(node, key=None):
        if isinstance(node, dict):
            return {k: convert(v, k) for k, v in node.items()}
        if isinstance(node, list):
            return [convert(v, key) for v in node]
        if key in DIMENSIONS and isinstance(node, (int, float)) and not isinstance(node, bool):
            return float(f"{node * factor(key):.15g}")  # 7.87e-9 t/mm³ -> 7870.0, not 7869.999999999999
        station = split_station(node) if key == "at" and isinstance(node, str) else None
        if station is not None:  # [[loads]] at = "LINK:S": S in the length unit
            try:
                return f"{station[0]}:{float(station[1]) * length:.15g}"
            except ValueError:
                return node  # reported by the reader
        return node

    return {k: (convert(v) if k in CONVERTED_SECTIONS else v) for k, v in doc.items() if k != "units"}
