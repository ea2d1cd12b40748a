"""Link cross-sections given by shape (docs/response.md §2): ``section = {shape = "circle",
diameter_m = 0.006}``, ``{shape = "rectangle", width_m, height_m}`` or ``{shape = "tube",
outer_diameter_m, inner_diameter_m}``, wherever ``area_m2``/``second_moment_m4`` may stand
(``[link_defaults]``, a ``[[links]]`` item, a ``[[links.segments]]`` item).

A shape is converted here, once, to the SI values the rest of the code reads: area A, second
moment of area I about the axis normal to the plane of motion, and the extreme-fibre distance c
(the largest distance from that axis to the section's edge, which the stress σ = N/A ± M c/I
needs). ``height_m`` of a rectangle lies in the plane of motion (the bending direction),
``width_m`` normal to it. The explicit form stays: ``area_m2``, ``second_moment_m4`` and the
optional ``fibre_distance_m``. A shape and an explicit value in the same table are refused.

A shape also gives the out-of-plane data (docs/response.md §2): the second moment I_out about
the in-plane axis normal to the link (weak-axis buckling, out-of-plane bending), the St-Venant
torsion constant J, the polar second moment I_p = I + I_out (torsional rotary inertia ρ I_p) and
the out-of-plane fibre distance; explicitly ``second_moment_out_of_plane_m4``,
``torsion_constant_m4``, ``polar_moment_m4`` (default I + I_out, the perpendicular-axis theorem)
and ``fibre_distance_out_of_plane_m``.
"""

from __future__ import annotations

import math

import numpy as np

from fkev_slepc.scene.schema import Reader, join, show

SECTION_KEY = "section"
FIBRE_KEY = "fibre_distance_m"
SHAPES = {  # shape -> its dimension keys (m, each finite and > 0)
    "circle": ("diameter_m",),
    "rectangle": ("width_m", "height_m"),
    "tube": ("outer_diameter_m", "inner_diameter_m"),
}
# the optional out-of-plane keys (TOML key -> Link/Segment field)
OUT_KEYS = {
    "second_moment_out_of_plane_m4": "second_moment_out",
    "torsion_constant_m4": "torsion_constant",
    "polar_moment_m4": "polar_moment",
    "fibre_distance_out_of_plane_m": "fibre_distance_out",
}
KAPPA_KEY = "shear_coefficient"  # κ of the Timoshenko element (docs/theory.md §22.1)
# the shape a section was given by, (shape, inner/outer diameter ratio), kept for Cowper's κ
SHAPE_MARK = "\0shape"
EXPLICIT = ("area_m2", "second_moment_m4", FIBRE_KEY, *OUT_KEYS)
# Marks a table whose section (or material, scene/materials.py) was bad and already reported:
# it holds the keys its readers take as absent-and-reported (None), so no "missing required key
# area_m2" follows the real problem.
REPORTED = "\0reported"
# odd n of the series of the rectangle's torsion constant: the n = 201 term is < 1e-11 of the sum
_ODD = np.arange(1, 202, 2, dtype=float)


def reported(table, key: str) -> bool:
    """True when ``key`` is one of the keys of a section or material already reported bad."""
    return isinstance(table, dict) and key in table.get(REPORTED, ())


def mark_reported(table: dict, keys) -> None:
    """Record on ``table`` that ``keys`` were reported bad (see :func:`reported`)."""
    table[REPORTED] = (*table.get(REPORTED, ()), *keys)


def rectangle_torsion_constant(a: float, b: float) -> float:
    """St-Venant torsion constant J of an a x b rectangle (m⁴), any order of the sides.

    The exact series (Timoshenko & Goodier, *Theory of Elasticity*, §109; docs/response.md §2)
    with a >= b: J = (a b³ / 3) [1 - (192 b / π⁵ a) Σ_{n odd} tanh(n π a / 2b) / n⁵].

    Examples
    --------
    >>> round(rectangle_torsion_constant(1.0, 1.0), 6)   # the square: 0.1406 a⁴
    0.140577
    """
    a, b = max(a, b), min(a, b)
    series = np.sum(np.tanh(_ODD * math.pi * a / (2 * b)) / _ODD**5)
    return float(a * b**3 / 3 * (1 - 192 * b / (math.pi**5 * a) * series))


def out_of_plane(shape: str, dims: dict[str, float]) -> tuple[float, float, float, float]:
    """(I_out m⁴, J m⁴, I_p m⁴, c_out m) of a shape: the second moment about the in-plane axis
    normal to the link, the St-Venant torsion constant, the polar second moment and the
    out-of-plane extreme-fibre distance (docs/response.md §2).

    Examples
    --------
    >>> i_out, j, ip, c = out_of_plane("rectangle", {"width_m": 0.008, "height_m": 0.02})
    >>> i_out == 0.02 * 0.008**3 / 12, c
    (True, 0.004)
    """
    if shape == "rectangle":
        b, h = dims["width_m"], dims["height_m"]
        return h * b**3 / 12, rectangle_torsion_constant(b, h), b * h * (b * b + h * h) / 12, b / 2
    if shape == "circle":
        d = dims["diameter_m"]
        return math.pi * d**4 / 64, math.pi * d**4 / 32, math.pi * d**4 / 32, d / 2
    D, d = dims["outer_diameter_m"], dims["inner_diameter_m"]
    return math.pi * (D**4 - d**4) / 64, math.pi * (D**4 - d**4) / 32, math.pi * (D**4 - d**4) / 32, D / 2


def polar_default(values: dict) -> None:
    """Fill ``polar_moment_m4`` of a table of section values with I + I_out when both are known
    and it is not given (the perpendicular-axis theorem, exact for any section)."""
    inplane, out = values.get("second_moment_m4"), values.get("second_moment_out_of_plane_m4")
    if values.get("polar_moment_m4") is None and inplane is not None and out is not None:
        values["polar_moment_m4"] = inplane + out


def properties(shape: str, dims: dict[str, float]) -> tuple[float, float, float]:
    """(A m², I m⁴, c m) of a shape with its dimensions (m).

    Examples
    --------
    >>> a, i, c = properties("circle", {"diameter_m": 0.006})
    >>> f"{a:.6e} {i:.6e} {c:g}"
    '2.827433e-05 6.361725e-11 0.003'
    >>> properties("rectangle", {"width_m": 0.01, "height_m": 0.018})[1] == 0.01 * 0.018**3 / 12
    True
    """
    if shape == "circle":
        d = dims["diameter_m"]
        return math.pi * d**2 / 4, math.pi * d**4 / 64, d / 2
    if shape == "rectangle":
        b, h = dims["width_m"], dims["height_m"]
        return b * h, b * h**3 / 12, h / 2
    D, d = dims["outer_diameter_m"], dims["inner_diameter_m"]
    return math.pi * (D**2 - d**2) / 4, math.pi * (D**4 - d**4) / 64, D / 2


def expand(r: Reader, table, path: str):
    """``table`` with its ``section`` (if any) replaced by ``area_m2``, ``second_moment_m4``,
    ``fibre_distance_m`` and the out-of-plane keys (:data:`OUT_KEYS`); problems are recorded on
    ``r`` with their dotted path (then those keys are left out and marked :data:`REPORTED`)."""
    if not isinstance(table, dict) or SECTION_KEY not in table:
        return table
    out = {k: v for k, v in table.items() if k != SECTION_KEY}
    mark_reported(out, EXPLICIT)  # until the section is read
    where = join(path, SECTION_KEY)
    sec = table[SECTION_KEY]
    clash = [k for k in EXPLICIT if k in table]
    if clash:
        r.add(join(path, clash[0]), f"give the section either as {SECTION_KEY} = {{shape = ...}} or as "
                                    f"{'/'.join(EXPLICIT)}, not both")
        return out
    if not isinstance(sec, dict):
        r.add(where, f"must be a table {{shape = \"circle\", diameter_m = ...}} (got {show(sec)})")
        return out
    shape = r.string(sec, "shape", where, choices=tuple(SHAPES))
    if shape is None:
        return out
    r.check_keys(sec, where, ("shape", *SHAPES[shape]))
    dims = {k: r.number(sec, k, where, positive=True) for k in SHAPES[shape]}
    if None in dims.values():
        return out
    if shape == "tube" and dims["inner_diameter_m"] >= dims["outer_diameter_m"]:
        r.add(join(where, "inner_diameter_m"), f"must be < outer_diameter_m = {show(sec['outer_diameter_m'])} "
                                               f"(got {show(sec['inner_diameter_m'])})")
        return out
    try:
        props = properties(shape, dims)
    except OverflowError:
        props = (math.inf,)
    if not all(math.isfinite(v) for v in props):  # a height of 1e155 m: h³ overflows double precision
        big = max(SHAPES[shape], key=lambda k: dims[k])
        r.add(join(where, big), f"gives a section whose area or second moment overflows double precision "
                                f"(got {show(sec[big])} m)")
        return out
    out["area_m2"], out["second_moment_m4"], out[FIBRE_KEY] = props
    for key, value in zip(OUT_KEYS, out_of_plane(shape, dims)):
        out[key] = value
    out[REPORTED] = tuple(k for k in out[REPORTED] if k not in EXPLICIT)
    out[SHAPE_MARK] = (shape, dims["inner_diameter_m"] / dims["outer_diameter_m"] if shape == "tube" else 0.0)
    return out


def cowper(mark, nu: float | None) -> float | None:
    """Cowper's shear coefficient κ (J. Appl. Mech. 33, 1966; docs/theory.md §22.1) of a section
    shape ``mark`` = (shape, inner/outer diameter ratio) at Poisson ratio ``nu``; None if either
    is unknown.

    Examples
    --------
    >>> round(cowper(("rectangle", 0.0), 0.3), 6), round(cowper(("circle", 0.0), 0.3), 6)
    (0.849673, 0.886364)
    """
    if mark is None or nu is None:
        return None
    shape, m = mark
    if shape == "rectangle":
        return 10 * (1 + nu) / (12 + 11 * nu)
    q = (1 + m * m) ** 2
    return 6 * (1 + nu) * q / ((7 + 6 * nu) * q + (20 + 12 * nu) * m * m)
