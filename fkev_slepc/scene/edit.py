"""Editing a scene by key path: ``links[1].length_m = 0.35`` -> a new, validated :class:`Scene`.

The value is set in the scene's TOML document (``Scene.source_text``), the document is written
back to TOML text and read again by :func:`~fkev_slepc.scene.reader.parse_scene`: the edited
scene is validated exactly as a file with that value would be (every problem named with its
dotted key and value), and its ``source_text`` -- the text archives keep -- says what it is.
Values are SI (a scene written with ``[units]`` is held in SI: scene/units.py).

Key paths: dotted keys, with ``[i]`` for an item of an array (``joints[3].position_m[0]``,
``links[2].segments[0].length_m``) or ``[name]`` for the item of an array of tables with that
``name`` (``links[rod].length_m``). Missing tables on the way are created
(``damping.mass_proportional_1_s`` in a scene without ``[damping]``); ``None`` removes a key.

What a :class:`Scene` holds beyond its text -- a re-mesh (``elements=``), another element type
or grid set from Python -- is kept unless the edit sets that key itself.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import replace as _replace
from typing import Any
import difflib

from fkev_slepc.scene.model import Problem, Scene, SceneError
from fkev_slepc.scene.schema import join, show
from fkev_slepc.scene.toml_text import dumps
from fkev_slepc.scene.reader import parse_scene

__all__ = ["parse_key", "set_key", "canonical_key", "replace_values", "dumps"]
_PART = re.compile(r"(?P<key>[A-Za-z_][A-Za-z0-9_-]*)(?P<index>(?:\[[^\[\]]*\])*)")
_INDEX = re.compile(r"\[([^\[\]]*)\]")


def parse_key(path: str) -> list[str | int]:
    """``"links[rod].segments[0].length_m"`` -> ``['links', 'rod', 'segments', 0, 'length_m']``
    (an integer for a numeric index, the string for a name index).

    Raises
    ------
    ValueError
        For a path that is not dotted keys with ``[index]`` parts.

    Examples
    --------
    >>> parse_key("joints[3].position_m[0]")
    ['joints', 3, 'position_m', 0]
    """
    return [part for part, _ in _parts(path)]


def _parts(path: str) -> list[tuple[str | int, bool]]:
    """(part, whether it was written as an ``[index]``) for each part of ``path``."""
    bad = f"must be a dotted key path such as 'links[1].length_m' (got {show(path)})"
    if not isinstance(path, str) or not path.strip():
        raise ValueError(bad)
    out: list[tuple[str | int, bool]] = []
    for part in path.strip().split("."):
        m = _PART.fullmatch(part.strip())
        if m is None:
            raise ValueError(bad)
        out.append((m["key"], False))
        for idx in _INDEX.findall(m["index"]):
            idx = idx.strip().strip("'\"")
            if not idx:
                raise ValueError(f"empty [] in key path (got {show(path)})")
            out.append((int(idx) if re.fullmatch(r"-?\d+", idx) else idx, True))
    return out


def _plain(value: Any) -> Any:
    """Python / numpy values as the types tomllib gives (numpy scalars, tuples -> float, list)."""
    if hasattr(value, "item") and getattr(value, "ndim", 1) == 0:
        value = value.item()
    if isinstance(value, (tuple, list)) or hasattr(value, "tolist"):
        return [_plain(v) for v in (value.tolist() if hasattr(value, "tolist") else value)]
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    return value


def set_key(doc: dict, path: str, value: Any) -> None:
    """Set (``None``: remove) the value at key ``path`` in the TOML document ``doc``, in place.

    Raises
    ------
    SceneError
        The path does not lead to a value (an index beyond an array, a name no item has, a key
        inside a number), the problem named by the part of the path that fails.
    """
    try:
        parts = _parts(path)
    except ValueError as err:
        raise SceneError("key", [Problem("key", str(err))]) from None
    node: Any = doc
    where = ""
    for i, (part, indexed) in enumerate(parts):
        last = i == len(parts) - 1
        if isinstance(node, list):
            if not indexed:
                raise SceneError("key", [Problem(where, f"is an array: index it, {where}[0] or {where}[<name>]")])
            k = _item(node, part, where)
            if last:
                if value is None:
                    raise SceneError("key", [Problem(join(where, k), "an array item cannot be removed; set the array")])
                node[k] = _plain(value)
                return
            node, where = node[k], join(where, k)
            continue
        if not isinstance(node, dict):
            raise SceneError("key", [Problem(where, f"is a value, not a table (got {show(node)}); cannot set {path}")])
        if indexed:
            raise SceneError("key", [Problem(join(where, part), f"{where or 'the scene'} is a table, not an array")])
        if last:
            if value is None:
                node.pop(part, None)
            else:
                node[part] = _plain(value)
            return
        if part not in node:
            if parts[i + 1][1]:
                raise SceneError("key", [Problem(join(where, part), "no such array in the scene")])
            node[part] = {}
        node, where = node[part], join(where, part)


def _item(items: list, part: str | int, where: str) -> int:
    if isinstance(part, int):
        if not -len(items) <= part < len(items):
            raise SceneError("key", [Problem(join(where, part),
                                             f"no such item ({where} has {len(items)}: 0-{len(items) - 1})")])
        return part % len(items)
    names = [it.get("name") if isinstance(it, dict) else None for it in items]
    if part in names:
        return names.index(part)

    close = difflib.get_close_matches(part, [n for n in names if isinstance(n, str)], n=1)
    tip = f"; did you mean '{close[0]}'?" if close else ""
    known = ", ".join(repr(n) for n in names if isinstance(n, str))
    raise SceneError("key", [Problem(f"{where}[{part}]", f"no item named {part!r}{tip} (known: {known})")])


def canonical_key(doc: dict, path: str) -> str:
    """``path`` with name indices replaced by positions: ``links[rod].area_m2`` -> ``links[1].area_m2``."""
    node: Any = doc
    where = ""
    for part in parse_key(path):
        if isinstance(node, list):
            k = _item(node, part, where)
            node, where = node[k], join(where, k)
        else:
            node, where = (node.get(part) if isinstance(node, dict) else None), join(where, part)
    return where


# -- the edit ----------------------------------------------------------------------------------
def replace_values(scene: Scene, changes: dict[str, Any]) -> Scene:
    """``scene`` with the values at the key paths of ``changes`` set, validated like a file.

    Raises
    ------
    SceneError
        Listing every problem of the edited scene (``links[1].length_m: must be > 0 (got -0.3)``),
        or a key path that leads nowhere; its source names the edit.

    Examples
    --------
    >>> from fkev_slepc.scene import load_scene
    >>> bw = load_scene(RUNS / "bahgat-willmert-1976.toml")
    >>> replace_values(bw, {"links[coupler].length_m": 0.3}).links[1].length
    0.3
    >>> replace_values(bw, {"links[1].length_m": -0.3})
    Traceback (most recent call last):
    ...
    fkev_slepc.scene.model.SceneError: ... with links[1].length_m = -0.3: 1 problem
      links[1].length_m: must be > 0 (got -0.3)
    """
    if not scene.source_text:
        raise SceneError(scene.source, [Problem("scene", "has no TOML text to edit (build it with load or from_text)")])
    doc = tomllib.loads(scene.source_text)
    said = ", ".join(f"{k} = {show(_plain(v))}" for k, v in changes.items())
    source = f"{scene.source} with {said}"
    keys = []
    for key, value in changes.items():
        try:
            set_key(doc, key, value)
            keys.append(canonical_key(doc, key))
        except SceneError as err:
            raise SceneError(source, err.problems) from None
    header = f"# {scene.source} with {said} (scene/edit.py)\n"
    new = parse_scene(header + dumps(doc), source)
    return _carry_overrides(scene, new, keys)


def _carry_overrides(old: Scene, new: Scene, keys: list[str]) -> Scene:
    """Keep what ``old`` holds beyond its text (a re-mesh, an element type, a grid set from Python)
    in ``new``, except what the edit set itself."""
    base = parse_scene(old.source_text, old.source)
    touched = lambda prefix: any(k == prefix or k.startswith(prefix + ".") or k.startswith(prefix + "[")  # noqa: E731
                                 for k in keys)
    if base.analysis != old.analysis and not touched("analysis"):
        fields = {f: getattr(old.analysis, f) for f in old.analysis.__dataclass_fields__
                  if getattr(old.analysis, f) != getattr(base.analysis, f)}
        new = _replace(new, analysis=_replace(new.analysis, **fields))
    if base.driver != old.driver and not touched("driver"):
        new = _replace(new, driver=_replace(new.driver, speeds=old.driver.speeds))
    links = list(new.links)
    for i, (was, now) in enumerate(zip(old.links, base.links)):
        if (i >= len(links) or was.elements == now.elements or "link_defaults.elements" in keys
                or touched(f"links[{i}].elements") or touched(f"links[{i}].segments")):
            continue
        lk = links[i]
        if lk.segments and len(lk.segments) == len(was.segments):
            segs = tuple(_replace(s, elements=w.elements) for s, w in zip(lk.segments, was.segments))
            links[i] = _replace(lk, segments=segs, elements=sum(s.elements for s in segs))
        elif not lk.segments:
            links[i] = _replace(lk, elements=was.elements)
    return _replace(new, links=tuple(links))
