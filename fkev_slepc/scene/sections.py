"""Readers for the sections of a scene file that define the linkage (links, joints, driver; the
general-linkage parts and masses are in :mod:`fkev_slepc.scene.parts`, the analysis and solver
settings in :mod:`fkev_slepc.scene.settings`).

Each reader validates one section with a :class:`~fkev_slepc.scene.schema.Reader`, which
records problems instead of raising, and returns the section's dataclasses (``None`` for a bad
item). Cross-references (joint ends, driver, masses) and the topology are checked here too.
The key names carry the units; this is the only place where values are converted.
"""

from __future__ import annotations

import difflib

from fkev_slepc.scene import materials, parts, shapes
from fkev_slepc.scene.damping import DAMPING_KEYS
from fkev_slepc.scene.drive import DRIVE_KEYS
from fkev_slepc.scene.model import END_NAMES, THIRD, Driver, Joint, Link, LinkEnd
from fkev_slepc.scene.schema import REQUIRED, Reader, join, show
from fkev_slepc.scene.settings import ANALYSIS_KEYS, SOLVER_KEYS
from fkev_slepc.scene.units import RAD_S_PER_RPM

# --------------------------------------------------------------------------------------------
# Schema: the keys of every section. Units live in the key names and are converted once, here.
# --------------------------------------------------------------------------------------------
LINK_PROPERTIES = {  # TOML key -> Link field; all must be finite and > 0
    "length_m": "length",
    "youngs_modulus_pa": "youngs_modulus",
    "density_kg_m3": "density",
    "area_m2": "area",
    "second_moment_m4": "second_moment",
}
OPTIONAL = parts.OPTIONAL  # optional section keys (TOML key -> Link/Segment field)
BUCKLING_KEY = "buckling_length_factor"
LINK_DEFAULT_KEYS = (*LINK_PROPERTIES, "elements", shapes.SECTION_KEY, *OPTIONAL, materials.MATERIAL_KEY, BUCKLING_KEY)
LINK_KEYS = ("name", *LINK_DEFAULT_KEYS, "segments", *parts.TERNARY_KEYS)
JOINT_KEYS = ("name", "type", "connects", "position_m", "assembly", *parts.PRISMATIC_KEYS, "bearing_stiffness_nm_rad")
JOINT_TYPES = ("revolute", "prismatic")
ASSEMBLIES = ("left", "right")
DRIVER_KEYS = ("link", "speeds_rad_s", "speeds_rpm", "acceleration_rad_s2")
TOP_KEYS = ("title", "materials", "link_defaults", "links", "joints", "driver", "masses", "analysis", "solver",
            "damping", "units", "loads", "drive")
GROUND = "ground"
# Where a misplaced key belongs (``modes`` under [solver] -> analysis.modes).
SECTIONS = {
    "link_defaults": LINK_DEFAULT_KEYS,
    "driver": DRIVER_KEYS,
    "analysis": ANALYSIS_KEYS,
    "solver": SOLVER_KEYS,
    "damping": DAMPING_KEYS,
    "drive": DRIVE_KEYS,
}


def read_links(r: Reader, doc, mats=None) -> tuple[list[Link | None], list[str] | None, set[str]]:
    """``[[links]]`` merged over ``[link_defaults]``: (links, None where bad; valid names;
    names of ternary links). ``mats`` are the ``[materials]`` (scene/materials.py).

    The names are returned separately so that references to a link whose *other* fields are
    bad do not also show up as "unknown link"; they are ``None`` if ``[[links]]`` itself is
    missing or malformed (then no reference is reported as unknown).
    """
    defaults: dict = {}
    table = r.table(doc, "link_defaults", "")
    if table:
        r.check_keys({k: v for k, v in table.items() if k != "name"}, "link_defaults", LINK_DEFAULT_KEYS)
        table = materials.expand(r, shapes.expand(r, table, "link_defaults"), "link_defaults", mats)
        if "name" in table:
            r.add("link_defaults.name", "links need their own names; set name in each [[links]]")
        # A bad default is reported once, here, and then stays silent (None) in every link.
        for key in LINK_PROPERTIES:
            if key in table or shapes.reported(table, key):
                defaults[key] = r.number(table, key, "link_defaults", positive=True, default=None)
        if "elements" in table:
            defaults["elements"] = r.integer(table, "elements", "link_defaults", minimum=1)
        for key in (*OPTIONAL, BUCKLING_KEY):
            if key in table or shapes.reported(table, key):
                defaults[key] = r.number(table, key, "link_defaults", positive=True)
        defaults[materials.MATERIAL_KEY] = table.get(materials.MATERIAL_KEY)
        defaults[shapes.SHAPE_MARK] = table.get(shapes.SHAPE_MARK)
    out: list[Link | None] = []
    seen: dict[str, str] = {}
    ternary: set[str] = set()
    remark = "set it here or in [link_defaults]"
    for path, item in r.tables(doc, "links", "", required=True):
        r.check_keys(item, path, LINK_KEYS)
        item = materials.expand(r, shapes.expand(r, item, path), path, mats)
        name = r.string(item, "name", path)
        if name is not None:
            name = _check_name(r, join(path, "name"), name, seen, "link")
            if "third_joint_m" in item:
                ternary.add(name)
        stepped = "segments" in item
        given = {}  # TOML key -> value (None: absent, or bad and already reported)
        for key in (*LINK_PROPERTIES, "elements"):
            # A stepped link's own section keys are optional defaults for its segments.
            default = defaults.get(key, None if stepped or shapes.reported(item, key) else REQUIRED)
            if key == "elements":
                given[key] = r.integer(item, key, path, default=default, minimum=1, remark=remark)
            elif not (stepped and key == "length_m"):
                given[key] = r.number(item, key, path, positive=True, remark=remark, default=default)
        optional_ok = parts.read_optional(r, item, path, given, defaults)
        given[materials.MATERIAL_KEY] = item.get(materials.MATERIAL_KEY, defaults.get(materials.MATERIAL_KEY))
        buckling = r.number(item, BUCKLING_KEY, path, positive=True, default=defaults.get(BUCKLING_KEY, 1.0))
        segments = ()
        if stepped:
            inherited = {k: k in item or k in defaults for k in given}
            segments = parts.read_segments(r, item, path, given, inherited, mats)
            if segments is not None:
                first = segments[0]
                given.update({k: getattr(first, f) for k, f in (*LINK_PROPERTIES.items(), *OPTIONAL.items())})
                given.update(length_m=parts.stepped_length(r, item, path, segments), material=first.material,
                             elements=sum(s.elements for s in segments))
        else:
            parts.complete(given, mats)
        third, third_el, third_ok = parts.read_third(r, item, path, given.get("length_m"), given.get("elements"))
        values = {field_: given.get(key) for key, field_ in LINK_PROPERTIES.items()}
        elements = given.get("elements")
        ok = name is not None and elements is not None and None not in values.values()
        ok = ok and segments is not None and third_ok and optional_ok and buckling is not None
        extras = {f: given[k] for k, f in OPTIONAL.items()}
        link = Link(name=name, elements=elements, segments=segments or (), third=third, third_elements=third_el or 2,
                    material=given[materials.MATERIAL_KEY], buckling_length_factor=buckling,
                    **extras, **values) if ok else None
        out.append(link)
    if not isinstance(doc.get("links"), list):
        return out, None, ternary  # no usable [[links]]: references to links cannot be judged
    return out, list(seen), ternary


def _check_name(r: Reader, where: str, name: str, seen: dict[str, str], kind: str) -> str | None:
    """Names are unique per kind; link names also appear in ``"<link>.<end>"`` references."""
    if not name.strip():
        r.add(where, f"must not be empty (got {show(name)})")
        return None
    if kind == "link" and ("." in name or name == GROUND):
        r.add(where, f"must not contain '.' or be '{GROUND}' (got {show(name)})")
        return None
    if name in seen:
        r.add(where, f"duplicate {kind} name {show(name)} (first used at {seen[name]})")
        return None
    seen[name] = where
    return name


def read_joints(r: Reader, doc, link_names: list[str] | None, ternary: set[str] = frozenset()
                ) -> tuple[list[Joint | None], list[str]]:
    """``[[joints]]``: (joints, None where bad; valid joint names)."""
    valid_refs = parts.end_names(link_names, ternary) + [GROUND]
    names: dict[str, str] = {}
    used: dict[LinkEnd, tuple[str, str]] = {}  # link end -> (joint name, path)
    out: list[Joint | None] = []
    for path, item in r.tables(doc, "joints", "", required=True):
        r.check_keys(item, path, JOINT_KEYS)
        name = r.string(item, "name", path)
        if name is not None:
            name = _check_name(r, join(path, "name"), name, names, "joint")
        jtype = r.string(item, "type", path, default="revolute", choices=JOINT_TYPES)
        sliding = jtype == "prismatic"
        branches = parts.PRISMATIC_ASSEMBLIES if sliding else ASSEMBLIES
        assembly = r.string(item, "assembly", path, default=branches[0], choices=branches)
        ends, grounded = _read_connects(r, item, join(path, "connects"), link_names, valid_refs)
        angle, slider_mass, prismatic_ok = parts.read_prismatic(r, item, path, jtype, ends, grounded)
        position = None
        if grounded:
            remark = "a point of the slider's guide" if sliding else "a ground joint needs its [x, y] position"
            position = r.point(item, "position_m", path, remark=remark)
        elif "position_m" in item and isinstance(item.get("connects"), list):
            r.add(join(path, "position_m"), f"only a joint with '{GROUND}' in connects takes a position")
        if ends is not None and name is not None:
            for k, end in enumerate(ends):
                if end in used:
                    other, other_path = used[end]
                    r.add(
                        join(join(path, "connects"), k),
                        f"link end '{end.link}.{end.end}' is already connected by joint {show(other)}"
                        f" ({other_path})",
                    )
                    ends = None
                else:
                    used[end] = (name, path)
        bearing = r.point(item, "bearing_stiffness_nm_rad", path, default=None)  # out of plane (theory §19.8)
        if bearing is not None and min(bearing) <= 0:
            r.add(join(path, "bearing_stiffness_nm_rad"), f"must be two stiffnesses > 0, N m/rad (got {show(list(bearing))})")
        bearing_ok = "bearing_stiffness_nm_rad" not in item or (bearing is not None and min(bearing) > 0)
        ok = None not in (name, jtype, assembly, ends) and (position is not None or not grounded)
        ok = ok and prismatic_ok and bearing_ok
        out.append(Joint(name, jtype, tuple(ends), position, assembly, angle, slider_mass, bearing) if ok else None)
    return out, list(names)


def _read_connects(r: Reader, item, where, link_names, valid_refs):
    """``connects`` -> (link ends or None if bad, whether 'ground' is one of them)."""
    if "connects" not in item:
        r.missing(where, f"list the link ends it joins, e.g. ['{GROUND}', 'crank.root']")
        return None, False
    value = item["connects"]
    if not isinstance(value, list) or len(value) < 2:
        form = f"'<link>.root', '<link>.tip', '{GROUND}'"
        r.add(where, f"must be a list of at least two of {form} (got {show(value)})")
        return None, False
    ends: list[LinkEnd] = []
    grounded, ok = False, True
    for k, ref in enumerate(value):
        at = join(where, k)
        if ref == GROUND:
            if grounded:
                r.add(at, f"'{GROUND}' listed twice")
                ok = False
            grounded = True
            continue
        end = _parse_end(r, at, ref, link_names, valid_refs)
        if end is None:
            ok = False
        elif end.link in [e.link for e in ends]:
            r.add(at, f"joint connects link '{end.link}' to itself (got {show(ref)})")
            ok = False
        else:
            ends.append(end)
    if ok and not ends:
        r.add(where, f"must name at least one link end (got {show(value)})")
        ok = False
    return (ends if ok else None), grounded


def _parse_end(r: Reader, at: str, ref, link_names, valid_refs) -> LinkEnd | None:
    third = f", '<link>.{THIRD}'" if any(v.endswith(f".{THIRD}") for v in valid_refs) else ""
    form = f"'<link>.root', '<link>.tip'{third} or '{GROUND}'"
    if not isinstance(ref, str):
        r.add(at, f"must be a string {form} (got {show(ref)})")
        return None
    link, dot, end = ref.rpartition(".")
    close = difflib.get_close_matches(ref, valid_refs, n=1)
    tip = f"; did you mean '{close[0]}'?" if close else ""
    if end == THIRD and link_names is not None and link in link_names and ref not in valid_refs:
        r.add(at, f"link '{link}' has no third joint point: give it third_joint_m (got {show(ref)})")
        return None
    if not dot or end not in (*END_NAMES, THIRD):
        r.add(at, f"must be {form} (got {show(ref)}{tip})")
        return None
    if link_names is None:
        return None
    if link not in link_names:
        r.add(at, f"unknown link '{link}' (got {show(ref)}{tip})")
        return None
    return LinkEnd(link, end)


def read_driver(r: Reader, doc, link_names: list[str] | None, joints: list[Joint] | None) -> Driver | None:
    """``[driver]``; ``joints`` is ``None`` when they had problems (no root-at-ground check)."""
    table = r.table(doc, "driver", "", required=True)
    if table is None:
        return None
    r.check_keys(table, "driver", DRIVER_KEYS)
    link = r.string(table, "link", "driver", choices=link_names, what="link")
    if link is not None and joints is not None:
        # The driver is clamped at its root, which must sit on a ground pivot (§9.3).
        root = [j for j in joints if LinkEnd(link, "root") in j.ends]
        if not root or root[0].ground is None or root[0].prismatic:
            where = f"joint {show(root[0].name)}" if root else "no joint"
            r.add("driver.link", f"the root of {show(link)} must be at a ground joint (it is at {where})")
    if "speeds_rad_s" in table and "speeds_rpm" in table:
        r.add("driver.speeds_rpm", "give speeds_rad_s or speeds_rpm, not both")
        speeds = None
    elif "speeds_rpm" in table:
        rpm = r.values(table, "speeds_rpm", "driver")
        speeds = None if rpm is None else tuple(v * RAD_S_PER_RPM for v in rpm)
    else:
        speeds = r.values(table, "speeds_rad_s", "driver", remark="or give speeds_rpm")
    accel = r.number(table, "acceleration_rad_s2", "driver", default=0.0)
    if None in (link, speeds, accel):
        return None
    return Driver(link=link, speeds=speeds, acceleration=accel, speed_unit="rpm" if "speeds_rpm" in table else "rad/s")


def check_topology(r: Reader, links: list[Link], joints: list[Joint]) -> None:
    """Every link reaches ground through joints, and the linkage has exactly one degree of
    freedom (Grübler: 3 per link, minus 2 per pin per extra body), which the driver takes."""
    index = {lk.name: i for i, lk in enumerate(links)}
    parent = list(range(len(links) + 1))  # union-find; the last entry is ground

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    constraints = 0
    for j in joints:
        bodies = [index[e.link] for e in j.ends] + ([len(links)] if j.ground is not None else [])
        # a pin: 2 per extra body; a slider on a guide: the link end stays on a line (1)
        constraints += 1 if j.prismatic else 2 * (len(bodies) - 1)
        for b in bodies[1:]:
            parent[find(b)] = find(bodies[0])
    ground = find(len(links))
    for i, lk in enumerate(links):
        if find(i) != ground:
            r.add(f"links[{i}]", f"link {show(lk.name)} is not connected to ground through any joint")
    dof = 3 * len(links) - constraints
    if dof != 1:
        r.add(
            "joints",
            f"the linkage has {dof} degrees of freedom (3 x {len(links)} links - {constraints} joint "
            "constraints); a single driver needs exactly 1",
        )
