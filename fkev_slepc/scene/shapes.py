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
"""

from __future__ import annotations

import math

from fkev_slepc.scene.schema import Reader, join, show

SECTION_KEY = "section"
FIBRE_KEY = "fibre_distance_m"
SHAPES = {  # shape -> its dimension keys (m, each finite and > 0)
    "circle": ("diameter_m",),
    "rectangle": ("width_m", "height_m"),
    "tube": ("outer_diameter_m", "inner_diameter_m"),
}
EXPLICIT = ("area_m2", "second_moment_m4", FIBRE_KEY)
# Marks a table whose section was bad and already reported: its readers take the three keys as
# absent-and-reported (None), so no "missing required key area_m2" follows the real problem.
REPORTED = "\0section reported"


def reported(table, key: str) -> bool:
    """True when ``key`` is one of the section's keys and the section was already reported bad."""
    return key in EXPLICIT and isinstance(table, dict) and table.get(REPORTED, False)


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
    """``table`` with its ``section`` (if any) replaced by ``area_m2``, ``second_moment_m4`` and
    ``fibre_distance_m``; problems are recorded on ``r`` with their dotted path (then the three
    keys are left out and the table is marked :data:`REPORTED`)."""
    if not isinstance(table, dict) or SECTION_KEY not in table:
        return table
    out = {k: v for k, v in table.items() if k != SECTION_KEY}
    out[REPORTED] = True  # until the section is read
    where = join(path, SECTION_KEY)
    sec = table[SECTION_KEY]
    clash = [k for k in EXPLICIT if k in table]
    if clash:
        r.add(join(path, clash[0]), f"give the section either as {SECTION_KEY} = {{shape = ...}} or as "
                                    f"area_m2/second_moment_m4/fibre_distance_m, not both")
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
    del out[REPORTED]
    return out
