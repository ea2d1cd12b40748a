"""``[[loads]]``: process loads, external forces and moments given as periodic piecewise-linear
tables over the crank angle (docs/response.md §1.2), e.g. a cutting force on a slider over
part of the stroke.

Each item names its point of application ``at``: a joint (a slider's block at a prismatic
joint; at a revolute joint the first link end its ``connects`` names), ``LINK.root``,
``LINK.tip``, ``LINK.third``, or ``LINK:S`` (S metres from the link's root along its axis);
``frame`` (``ground``, or ``link``: components along the link's axis and its left normal,
turning with it; at a slider the guide's frame); and ``crank_angle_deg``, ``fx_n``, ``fy_n``,
``moment_n_m`` (lists of one length; linear in between, periodic over one revolution).
Like the rest of the scene, every problem is recorded with its dotted path and value.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from fkev_slepc.scene.model import END_NAMES, THIRD, Joint, Link
from fkev_slepc.scene.parts import STATION_TOL
from fkev_slepc.scene.schema import Reader, is_number, join, show

LOAD_KEYS = ("name", "at", "frame", "crank_angle_deg", "fx_n", "fy_n", "moment_n_m")
FRAMES = ("ground", "link")
_STATION = re.compile(r"(?P<link>.+):(?P<s>[^:]+)")


@dataclass(frozen=True)
class ProcessLoad:
    """One ``[[loads]]`` item, SI units. ``link`` and ``point`` locate it: ``point`` is
    ``root``/``tip``/``third`` or a station (m along the axis from the root); ``joint`` is the
    joint name when ``at`` named one (a slider's block when that joint is prismatic)."""

    name: str
    at: str  # as written
    link: str
    point: str | float
    joint: str | None
    frame: str  # "ground" | "link"
    crank_angle_deg: tuple[float, ...]
    fx: tuple[float, ...]  # N
    fy: tuple[float, ...]  # N
    moment: tuple[float, ...]  # N m (zeros when not given)


def split_station(at: str) -> tuple[str, str] | None:
    """``("rod", "0.05")`` for ``"rod:0.05"``, else None (used by [units] to convert S)."""
    m = _STATION.fullmatch(at)
    return None if m is None else (m["link"], m["s"])


def read_process_loads(r: Reader, doc, links: list[Link | None], joints: list[Joint | None]) -> list[ProcessLoad]:
    """``[[loads]]`` of a scene: every problem on ``r`` (field path and value), bad items dropped."""
    link_by = {lk.name: lk for lk in links if lk is not None}
    joint_by = {j.name: j for j in joints if j is not None}
    out, seen = [], set()
    for path, item in r.tables(doc, "loads", ""):
        r.check_keys(item, path, LOAD_KEYS)
        name = r.string(item, "name", path)
        if name is not None and name in seen:
            r.add(join(path, "name"), f"duplicate load name {show(name)}")
            name = None
        seen.add(name)
        frame = r.string(item, "frame", path, default="ground", choices=FRAMES)
        where = _locate(r, item, path, link_by, joint_by)
        table = _table(r, item, path)
        if where is not None and table is not None and where[2] is not None and any(table[3]):
            if joint_by[where[2]].prismatic:
                r.add(join(path, "moment_n_m"), f"a slider block cannot turn: its guide takes a moment; put it on a "
                      f"link point, not on prismatic joint {show(where[2])} (got {show(item['moment_n_m'])})")
                table = None
        if None not in (name, frame, where, table):
            out.append(ProcessLoad(name, item["at"], *where, frame, *table))
    return out


def _locate(r: Reader, item, path, link_by, joint_by):
    """(link, point, joint) of ``at``, or None (reported)."""
    at = r.string(item, "at", path, remark="a joint name, LINK.root, LINK.tip or LINK:S (S m from the root)")
    if at is None:
        return None
    where = join(path, "at")
    if at in joint_by:
        end = joint_by[at].ends[0]
        return end.link, end.end, at
    station = split_station(at)
    if station is not None and station[0] in link_by:
        lk = link_by[station[0]]
        try:
            s = float(station[1])
        except ValueError:
            s = float("nan")
        if not -STATION_TOL * lk.length <= s <= lk.length * (1 + STATION_TOL):
            r.add(where, f"the station S of LINK:S must be a number of metres, 0 <= S <= {lk.length:g} "
                  f"(the length of {show(lk.name)}) (got {show(at)})")
            return None
        return lk.name, min(max(s, 0.0), lk.length), None
    link, _, end = at.rpartition(".")
    if link in link_by and (end in END_NAMES or (end == THIRD and link_by[link].third is not None)):
        return link, end, None
    known = ", ".join(map(repr, [*joint_by, *(f"{n}.{e}" for n in link_by for e in END_NAMES)]))
    r.add(where, f"must be a joint name, LINK.root, LINK.tip, LINK.third (ternary) or LINK:S (got {show(at)}; "
          f"known: {known})")
    return None


def _table(r: Reader, item, path):
    """(angles, fx, fy, moment) as tuples of floats, or None (reported)."""
    angles = _numbers(r, item, "crank_angle_deg", path)
    columns = [_numbers(r, item, key, path, optional=key == "moment_n_m") for key in ("fx_n", "fy_n", "moment_n_m")]
    if angles is None or None in columns:
        return None
    ok = True
    for i in range(1, len(angles)):
        if angles[i] <= angles[i - 1]:
            r.add(join(join(path, "crank_angle_deg"), i), f"breakpoints must increase (got {show(angles[i])} after "
                  f"{show(angles[i - 1])})")
            ok = False
            break
    if ok and angles[-1] - angles[0] >= 360.0:
        r.add(join(path, "crank_angle_deg"), f"breakpoints span one revolution at most, last - first < 360 "
              f"(got {show(angles[0])} .. {show(angles[-1])}); the table is periodic")
        ok = False
    for key, col in zip(("fx_n", "fy_n", "moment_n_m"), columns):
        if col and len(col) != len(angles):
            r.add(join(path, key), f"needs one value per crank_angle_deg breakpoint ({len(angles)}) "
                  f"(got {len(col)})")
            ok = False
    if not ok:
        return None
    fx, fy, m = (tuple(c) if c else (0.0,) * len(angles) for c in columns)
    return tuple(angles), fx, fy, m


def _numbers(r: Reader, item, key, path, optional=False):
    """A non-empty list of finite numbers; () when optional and absent; None (reported) if bad."""
    where = join(path, key)
    if key not in item:
        if optional:
            return ()
        r.missing(where, "a list with one value per crank_angle_deg breakpoint")
        return None
    value = item[key]
    if is_number(value):
        value = [value]
    if not isinstance(value, list) or not value:
        r.add(where, f"must be a non-empty list of numbers (got {show(value)})")
        return None
    out = [r.check_number(v, join(where, i)) for i, v in enumerate(value)]
    return None if None in out else out
