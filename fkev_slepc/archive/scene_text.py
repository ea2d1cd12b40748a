"""What an archive's stored scene text (root attribute ``scene_toml``) declares: its title and
the elements per link it asked for (read with tomllib, so archives of any fkev version work), and
the heading that names a re-meshed run's mesh (:func:`heading`)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from fkev_slepc.scene.model import REMESHED, mesh_tag


def scene_title(scene_toml: str, fallback: str) -> str:
    """The scene's ``title`` (top level or under ``[scene]``); the source file stem otherwise."""
    try:
        doc = tomllib.loads(scene_toml) if scene_toml else {}
    except tomllib.TOMLDecodeError:
        doc = {}
    for table in (doc, doc.get("scene", {}) if isinstance(doc.get("scene"), dict) else {}):
        if isinstance(table.get("title"), str) and table["title"].strip():
            return table["title"].strip()
    return Path(str(fallback)).stem


def declared_elements(scene_toml: str) -> tuple[int, ...] | None:
    """Elements per link as the scene text declares them (``links[].elements`` or
    ``link_defaults.elements``); None if the text does not say. Compared with the archive's
    ``elements`` attribute, it tells whether the run re-meshed the scene (``--elements``)."""
    try:
        doc = tomllib.loads(scene_toml) if scene_toml else {}
    except tomllib.TOMLDecodeError:
        return None
    links = doc.get("links")
    defaults = doc.get("link_defaults")
    default = defaults.get("elements") if isinstance(defaults, dict) else None
    if not isinstance(links, list) or not links:
        return None
    counts = [_declared(lk, default) if isinstance(lk, dict) else None for lk in links]
    return tuple(int(n) for n in counts) if all(isinstance(n, int) for n in counts) else None


def _declared(link: dict, default):
    """A link's axis elements: its own count, or the sum over its [[links.segments]]."""
    own = link.get("elements", default)
    segments = link.get("segments")
    if not isinstance(segments, list):
        return own
    counts = [s.get("elements", own) if isinstance(s, dict) else None for s in segments]
    return sum(counts) if all(isinstance(n, int) for n in counts) else None


def heading(title: str, elements, scene_toml: str) -> str:
    """An archive's ``title`` followed by the :func:`~fkev_slepc.scene.model.mesh_tag` of the mesh
    analysed where its elements per link (the ``elements`` attribute) differ from what its scene
    text declares (a run with ``--elements``) and the title does not say so already (archives
    written before re-meshed titles carried the tag)."""
    el = tuple(int(n) for n in elements)
    declared = declared_elements(scene_toml)
    if el and declared is not None and tuple(declared) != el and not REMESHED.search(title):
        return f"{title} {mesh_tag(el)}"
    return title
