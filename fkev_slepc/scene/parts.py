"""Readers for the general-linkage parts of a scene (docs/linkages.md): stepped links
(``[[links.segments]]``), ternary links (``third_joint_m``), prismatic joints (slider on a ground
guide) and lumped masses anywhere along a link (``position_m``, ``inertia_kg_m2``).

Like :mod:`fkev_slepc.scene.sections`, every reader records problems with their dotted path
on a :class:`~fkev_slepc.scene.schema.Reader` and returns ``None`` for a bad item.
"""

from __future__ import annotations

import math

from fkev_slepc.scene.model import THIRD, Joint, Link, LumpedMass, Segment, END_NAMES
from fkev_slepc.scene import materials, shapes
from fkev_slepc.scene.schema import REQUIRED, Reader, join, show

SEGMENT_PROPERTIES = {  # TOML key -> Segment field (finite, > 0)
    "youngs_modulus_pa": "youngs_modulus",
    "density_kg_m3": "density",
    "area_m2": "area",
    "second_moment_m4": "second_moment",
}
# optional keys of a link and its segments (TOML key -> Link/Segment field)
OPTIONAL = {shapes.FIBRE_KEY: "fibre_distance", **shapes.OUT_KEYS, materials.SHEAR_KEY: "shear_modulus",
            shapes.KAPPA_KEY: "shear_coefficient"}
SEGMENT_KEYS = ("length_m", *SEGMENT_PROPERTIES, "elements", shapes.SECTION_KEY, *OPTIONAL, materials.MATERIAL_KEY)
TERNARY_KEYS = ("third_joint_m", "third_elements")
PRISMATIC_KEYS = ("guide_angle_deg", "slider_mass_kg")
PRISMATIC_ASSEMBLIES = ("ahead", "behind")
MASS_KEYS = ("joint", "link", "position_m", "mass_kg", "inertia_kg_m2")
# Relative tolerance for "the same station" (segment lengths vs length_m, points on the axis).
STATION_TOL = 1e-9


def read_optional(r: Reader, item, path: str, values: dict, defaults: dict) -> bool:
    """Read the :data:`OPTIONAL` keys of ``item`` into ``values`` (``defaults`` where absent);
    False if one of them is bad (or its section was)."""
    ok = True
    for key in OPTIONAL:
        values[key] = r.number(item, key, path, positive=True, default=defaults.get(key))
        ok = ok and (values[key] is not None or (key not in item and not shapes.reported(item, key)))
    own = shapes.SHAPE_MARK in item or any(k in item for k in shapes.EXPLICIT)
    values[shapes.SHAPE_MARK] = item.get(shapes.SHAPE_MARK) if own else defaults.get(shapes.SHAPE_MARK)
    return ok


def complete(values: dict, mats) -> None:
    """Fill the derived optional values of one uniform piece: I_p = I + I_out, G from ν."""
    shapes.polar_default(values)
    values[materials.SHEAR_KEY] = materials.shear_modulus(values, mats)
    if values.get(shapes.KAPPA_KEY) is None:
        values[shapes.KAPPA_KEY] = shapes.cowper(values.get(shapes.SHAPE_MARK), materials.poisson(values, mats))


def read_segments(r: Reader, item, path: str, link_values: dict, inherited: dict, mats=None) -> tuple | None:
    """``[[links.segments]]`` of one link: a tuple of :class:`Segment`, or ``None`` if bad.

    ``link_values`` holds the link's own (or default) section values, ``None`` where absent or
    already reported; ``inherited`` tells which of those keys were given at all; ``mats`` are
    the ``[materials]`` (scene/materials.py).
    """
    out, ok = [], True
    for spath, seg in r.tables(item, "segments", path, required=True):
        r.check_keys(seg, spath, SEGMENT_KEYS)
        seg = materials.expand(r, shapes.expand(r, seg, spath), spath, mats)
        values = {}
        for key in ("length_m", *SEGMENT_PROPERTIES, "elements"):
            given = link_values.get(key)
            default = given if given is not None else (None if inherited.get(key) or shapes.reported(seg, key)
                                                        else REQUIRED)
            if key == "length_m":
                default = REQUIRED
            remark = "set it here, in the link or in [link_defaults]" if key != "length_m" else ""
            if key == "elements":
                values[key] = r.integer(seg, key, spath, default=default, minimum=1, remark=remark)
            else:
                values[key] = r.number(seg, key, spath, positive=True, default=default, remark=remark)
        optional_ok = read_optional(r, seg, spath, values, link_values)
        if None in (values[k] for k in ("length_m", *SEGMENT_PROPERTIES, "elements")) or not optional_ok:
            ok = False
            continue
        values[materials.MATERIAL_KEY] = seg.get(materials.MATERIAL_KEY, link_values.get(materials.MATERIAL_KEY))
        complete(values, mats)
        out.append(Segment(values["length_m"], values["elements"], values["youngs_modulus_pa"],
                           values["density_kg_m3"], values["area_m2"], values["second_moment_m4"],
                           material=values[materials.MATERIAL_KEY], **{f: values[k] for k, f in OPTIONAL.items()}))
    return tuple(out) if ok and out else None


def stepped_length(r: Reader, item, path: str, segments: tuple[Segment, ...]) -> float | None:
    """Total length of a stepped link; ``length_m``, if given, must agree with it."""
    total = math.fsum(s.length for s in segments)
    if "length_m" in item:
        given = r.number(item, "length_m", path, positive=True)
        if given is not None and abs(given - total) > STATION_TOL * total:
            r.add(join(path, "length_m"), f"must equal the sum of the segment lengths {total:g} (got {show(item['length_m'])})")
            return None
    return total


def read_third(r: Reader, item, path: str, length: float | None, default_elements) -> tuple:
    """``third_joint_m`` / ``third_elements`` of a ternary link: (point or None, elements, ok)."""
    if "third_joint_m" not in item:
        if "third_elements" in item:
            r.add(join(path, "third_elements"), "only a ternary link (with third_joint_m) takes it")
            return None, 0, False
        return None, 0, True
    where = join(path, "third_joint_m")
    point = r.point(item, "third_joint_m", path)
    elements = r.integer(item, "third_elements", path, default=default_elements or 2, minimum=1)
    if point is None or elements is None or length is None:
        return None, 0, False
    x, y = point
    if not -STATION_TOL * length <= x <= length * (1 + STATION_TOL):
        r.add(where, f"x must lie along the link, 0 <= x <= {length:g} (got {show(item['third_joint_m'])})")
        return None, 0, False
    if abs(y) <= STATION_TOL * length and min(abs(x), abs(x - length)) <= STATION_TOL * length:
        r.add(where, f"coincides with the link's root or tip (got {show(item['third_joint_m'])})")
        return None, 0, False
    return (min(max(x, 0.0), length), y), elements, True


def read_prismatic(r: Reader, item, path: str, jtype, ends, grounded) -> tuple[float, float, bool]:
    """Guide angle (rad), slider mass and validity of a joint's prismatic keys."""
    if jtype != "prismatic":
        for key in PRISMATIC_KEYS:
            if key in item:
                r.add(join(path, key), f"only a prismatic joint takes it (type is {show(jtype)})")
        return 0.0, 0.0, all(k not in item for k in PRISMATIC_KEYS)
    ok = True
    if ends is not None and (not grounded or len(ends) != 1):
        r.add(join(path, "connects"), "a prismatic joint connects 'ground' (its guide) and exactly one link end "
              f"(got {show(item.get('connects'))})")
        ok = False
    angle = r.number(item, "guide_angle_deg", path, default=0.0)
    mass = r.number(item, "slider_mass_kg", path, default=0.0, minimum=0.0)
    if angle is None or mass is None:
        return 0.0, 0.0, False
    return math.radians(angle), mass, ok


def carriers(joint: Joint | None) -> list[str] | None:
    return None if joint is None else [e.link for e in joint.ends]


def read_masses(r: Reader, doc, joints: list[Joint | None], joint_names: list[str],
                links: list[Link | None], link_names: list[str] | None) -> list[LumpedMass]:
    """``[[masses]]``: at a joint (carried by one link of it), or at ``position_m`` along a link."""
    by_name = {j.name: j for j in joints if j is not None}
    link_by_name = {lk.name: lk for lk in links if lk is not None}
    out = []
    for path, item in r.tables(doc, "masses", ""):
        r.check_keys(item, path, MASS_KEYS)
        mass = r.number(item, "mass_kg", path, minimum=0.0)
        inertia = r.number(item, "inertia_kg_m2", path, default=0.0, minimum=0.0)
        if mass is not None and inertia is not None and mass == 0.0 and inertia == 0.0:
            r.add(join(path, "mass_kg"), "a mass of 0 needs an inertia_kg_m2 > 0")
            mass = None
        joint = position = link = None
        if "joint" in item and "position_m" in item:
            r.add(join(path, "position_m"), "give joint or position_m (along the link), not both")
        elif "position_m" in item:
            link = r.string(item, "link", path, choices=link_names, what="link",
                            remark="the link that carries the mass at position_m")
            position = r.number(item, "position_m", path, minimum=0.0)
            lk = link_by_name.get(link)
            if position is not None and lk is not None and position > lk.length * (1 + STATION_TOL):
                r.add(join(path, "position_m"), f"must be <= the length {lk.length:g} of link {show(link)} "
                      f"(got {show(item['position_m'])})")
                position = None
            if position is not None and lk is not None:
                position = min(position, lk.length)
            elif lk is None:
                position = None
        else:
            remark = "or give link and position_m"
            joint = r.string(item, "joint", path, choices=joint_names, what="joint", remark=remark)
            held = carriers(by_name.get(joint))
            if held is not None and len(held) == 1 and "link" not in item:
                link = held[0]  # unambiguous: the joint holds one link end
            else:
                remark = "the link that carries the mass"
                link = r.string(item, "link", path, choices=held, what="link for this joint", remark=remark)
            if joint is not None and "position_m" not in item:
                position = 0.0  # unused: a joint mass sits at the joint's point of the link
        if None not in (link, mass, inertia, position):
            out.append(LumpedMass(joint=joint, link=link, mass=mass, position=None if joint else position,
                                  inertia=inertia))
    return out


def end_names(link_names, ternary) -> list[str]:
    """Valid joint references ``<link>.<end>`` ('third' for ternary links)."""
    refs = [f"{n}.{e}" for n in link_names or () for e in END_NAMES]
    return refs + [f"{n}.{THIRD}" for n in link_names or () if n in ternary]
