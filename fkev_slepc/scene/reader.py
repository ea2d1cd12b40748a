"""Reading a scene: TOML text -> validated :class:`~fkev_slepc.scene.model.Scene`.

Every problem is collected with its dotted path and raised as one :class:`SceneError`.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from fkev_slepc.scene.validity import timoshenko_problems
from fkev_slepc.scene import parts
from fkev_slepc.scene import sections as sec
from fkev_slepc.scene import settings
from fkev_slepc.scene.damping import read_damping
from fkev_slepc.scene.drive import read_drive
from fkev_slepc.scene.materials import read_materials
from fkev_slepc.scene.model import Problem, Scene, SceneError
from fkev_slepc.scene.process_loads import read_process_loads
from fkev_slepc.scene.schema import Reader
from fkev_slepc.scene.toml_text import dumps
from fkev_slepc.scene.units import read_units, to_si, units_label


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        A TOML scene file (format: ``runs/README.md``, "Scene file format").

    Returns
    -------
    Scene
        Frozen, validated, SI units; ``source_text`` holds the file verbatim.

    Raises
    ------
    SceneError
        Listing every problem found (unreadable file, TOML syntax, schema), each with its
        dotted path and offending value.
    """
    source = str(path)
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise SceneError(source, [Problem("file", "no such file")]) from None
    except IsADirectoryError:
        raise SceneError(source, [Problem("file", "is a directory, not a scene file")]) from None
    except OSError as exc:
        raise SceneError(source, [Problem("file", f"cannot be read ({exc.strerror})")]) from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        problem = Problem("file", f"is not UTF-8 text (bad byte at offset {exc.start})")
        raise SceneError(source, [problem]) from None
    return parse_scene(text, source)


def parse_scene(text: str, source: str = "<scene>") -> Scene:
    """Validate the TOML ``text`` of a scene; see :func:`load_scene`.

    Examples
    --------
    >>> try:
    ...     parse_scene("title = 1", "x.toml")
    ... except SceneError as err:
    ...     print(err)
    x.toml: 4 problems
      title: must be a string (got 1)
      links: missing required key (add at least one [[links]] table)
      joints: missing required key (add at least one [[joints]] table)
      driver: missing required key (add a [driver] table)
    """
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(source, [_syntax_problem(exc)]) from None
    if "units" in doc:
        return _parse_in_units(doc, text, source)
    return _parse_document(doc, text, source)


def _parse_in_units(doc: dict, text: str, source: str) -> Scene:
    """A scene with ``[units]``: validated as written (messages quote the values the user typed),
    then converted to SI once; the Scene's ``source_text`` is the SI document, headed by the file
    as written in comments (scene/units.py)."""
    r = Reader(sec.SECTIONS)
    factors = read_units(r, doc)
    problems = list(r.problems)
    as_written = {k: v for k, v in doc.items() if k != "units"}
    try:
        _parse_document(as_written, text, source)
    except SceneError as err:
        problems += err.problems
    if problems:
        raise SceneError(source, problems)
    quoted = "".join(f"#   {line}\n" for line in text.splitlines())
    si_text = (f"# {source} in SI: its [units] ({units_label(doc)}) converted on reading (fkev_slepc/scene/units.py).\n"
               f"# The file as written:\n{quoted}\n" + dumps(to_si(doc, factors)))
    return _parse_document(to_si(doc, factors), si_text, source)


def _parse_document(doc: dict, text: str, source: str) -> Scene:
    """Validate a parsed scene document (SI); ``text`` is kept as the Scene's ``source_text``."""
    r = Reader(sec.SECTIONS)
    r.check_keys(doc, "", sec.TOP_KEYS)
    title = r.string(doc, "title", "", default=Path(source).stem)
    mats = read_materials(r, doc)
    links, link_names, ternary = sec.read_links(r, doc, mats)
    n_before = len(r.problems)
    joints, joint_names = sec.read_joints(r, doc, link_names, ternary)
    topology_ok = len(r.problems) == n_before and None not in links and None not in joints
    driver = sec.read_driver(r, doc, link_names, joints if topology_ok else None)
    masses = parts.read_masses(r, doc, joints, joint_names, links, link_names)
    analysis = settings.read_analysis(r, doc)
    solver = settings.read_solver(r, doc)
    damping = read_damping(r, doc)
    process = read_process_loads(r, doc, links, joints)
    drive = read_drive(r, doc)
    if topology_ok and links:
        sec.check_topology(r, links, joints)
    if r.problems:
        raise SceneError(source, r.compacted())
    scene = Scene(
        title=title,
        links=tuple(links),
        joints=tuple(joints),
        driver=driver,
        masses=tuple(masses),
        analysis=analysis,
        solver=solver,
        damping=damping,
        materials=tuple(mats.values()) if mats else (),
        process_loads=tuple(process),
        drive=drive,
        source_text=text,
        source=source,
    )
    bad = timoshenko_problems(scene)
    if bad:
        raise SceneError(source, bad)
    return scene


def _syntax_problem(exc: tomllib.TOMLDecodeError) -> Problem:
    msg = str(exc)
    m = re.fullmatch(r"(.*) \(at line (\d+), column (\d+)\)", msg, flags=re.S)
    if m:
        return Problem(f"line {m[2]}, column {m[3]}", f"TOML syntax error: {m[1]}")
    m = re.fullmatch(r"(.*) \(at end of document\)", msg, flags=re.S)
    if m:
        return Problem("end of file", f"TOML syntax error: {m[1]}")
    return Problem("file", f"TOML syntax error: {msg}")


