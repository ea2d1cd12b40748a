"""Scene files: TOML -> validated, frozen dataclass tree in SI units.

This module owns the scene *schema*. It never imports PETSc, MPI or h5py.
Loading and validation (``load_scene``) collect every problem with its dotted
path and raise one :class:`SceneError`.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

END_NAMES = ("root", "tip")


@dataclass(frozen=True)
class Problem:
    """One problem in a scene: dotted field path and a message (includes the value)."""

    path: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"


class SceneError(ValueError):
    """A scene with one or more problems; ``problems`` lists them all."""

    def __init__(self, source: str, problems: list[Problem]):
        self.source = source
        self.problems = list(problems)
        n = len(self.problems)
        head = f"{source}: {n} problem{'s' if n != 1 else ''}"
        super().__init__("\n".join([head, *(f"  {p}" for p in self.problems)]))


@dataclass(frozen=True)
class Link:
    """A straight, uniform Euler-Bernoulli link running from its root to its tip."""

    name: str
    length: float  # m
    youngs_modulus: float  # Pa
    density: float  # kg/m^3
    area: float  # m^2
    second_moment: float  # m^4
    elements: int


@dataclass(frozen=True)
class LinkEnd:
    link: str
    end: str  # "root" | "tip"


@dataclass(frozen=True)
class Joint:
    """A revolute joint between link ends, or between link ends and a ground point."""

    name: str
    type: str  # "revolute"
    ends: tuple[LinkEnd, ...]  # the moving link ends it connects (1 or more)
    ground: tuple[float, float] | None = None  # ground position (m) if pinned to ground
    assembly: str = "left"  # dyad branch: joint left/right of the ray P->Q (see kinematics)


@dataclass(frozen=True)
class Driver:
    link: str
    speeds: tuple[float, ...]  # rad/s
    acceleration: float = 0.0  # rad/s^2


@dataclass(frozen=True)
class LumpedMass:
    joint: str
    link: str  # the link whose end carries the particle (kinetostatics)
    mass: float  # kg


@dataclass(frozen=True)
class Analysis:
    crank_angles_deg: tuple[float, ...]
    cases: tuple[str, ...]  # canonical case names (cases.CASE_NAMES order preserved as given)
    modes: int = 4
    mode_shapes: bool = False
    # Named thresholds (recorded in archives): |Im λ| <= imag_tol*|λ| is a real eigenvalue;
    # Re λ > stability_tol*|λ| marks a pair unstable.
    imag_tol: float = 1e-9
    stability_tol: float = 1e-9


@dataclass(frozen=True)
class Solver:
    method: str = "auto"  # "auto" | "slepc" | "dense"
    petsc: tuple[tuple[str, str], ...] = ()  # [solver.petsc] table, option name without "fkev_"


@dataclass(frozen=True)
class Scene:
    title: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    driver: Driver
    masses: tuple[LumpedMass, ...] = ()
    analysis: Analysis = field(default_factory=lambda: Analysis((0.0,), ("full",)))
    solver: Solver = field(default_factory=Solver)
    source_text: str = ""  # the TOML text, verbatim (archived)
    source: str = "<scene>"  # file name, for messages


def with_elements(scene: Scene, elements: tuple[int, ...] | int) -> Scene:
    """Return ``scene`` with its links re-meshed (``--elements N`` or ``n1,n2,...``)."""
    from dataclasses import replace

    if isinstance(elements, int):
        elements = (elements,) * len(scene.links)
    if len(elements) != len(scene.links):
        raise SceneError(
            scene.source,
            [Problem("--elements", f"needs 1 or {len(scene.links)} values (got {len(elements)})")],
        )
    bad = [Problem(f"--elements[{i}]", f"must be >= 1 (got {n})") for i, n in enumerate(elements) if n < 1]
    if bad:
        raise SceneError(scene.source, bad)
    links = tuple(replace(lk, elements=int(n)) for lk, n in zip(scene.links, elements))
    return replace(scene, links=links)


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
    # Imported here: the section readers build this module's dataclasses.
    from . import scene_sections as sec
    from .scene_schema import Reader

    r = Reader(sec.SECTIONS)
    r.check_keys(doc, "", sec.TOP_KEYS)
    title = r.string(doc, "title", "", default=Path(source).stem)
    links, link_names = sec.read_links(r, doc)
    n_before = len(r.problems)
    joints, joint_names = sec.read_joints(r, doc, link_names)
    topology_ok = len(r.problems) == n_before and None not in links and None not in joints
    driver = sec.read_driver(r, doc, link_names, joints if topology_ok else None)
    masses = sec.read_masses(r, doc, joints, joint_names)
    analysis = sec.read_analysis(r, doc)
    solver = sec.read_solver(r, doc)
    if topology_ok and links:
        sec.check_topology(r, links, joints)
    if r.problems:
        raise SceneError(source, r.problems)
    return Scene(
        title=title,
        links=tuple(links),
        joints=tuple(joints),
        driver=driver,
        masses=tuple(masses),
        analysis=analysis,
        solver=solver,
        source_text=text,
        source=source,
    )


def _syntax_problem(exc: tomllib.TOMLDecodeError) -> Problem:
    msg = str(exc)
    m = re.fullmatch(r"(.*) \(at line (\d+), column (\d+)\)", msg, flags=re.S)
    if m:
        return Problem(f"line {m[2]}, column {m[3]}", f"TOML syntax error: {m[1]}")
    m = re.fullmatch(r"(.*) \(at end of document\)", msg, flags=re.S)
    if m:
        return Problem("end of file", f"TOML syntax error: {m[1]}")
    return Problem("file", f"TOML syntax error: {msg}")


