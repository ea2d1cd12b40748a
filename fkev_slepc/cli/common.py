"""Argument helpers shared by the subcommands (parsing only; no physics)."""

from __future__ import annotations

import argparse
import sys

from fkev_slepc.periodic import limits
from fkev_slepc.scene import ELEMENT_NAMES, Problem, Scene, SceneError, with_elements
from fkev_slepc.scene.units import RAD_S_PER_RPM
from fkev_slepc.sweep.grid import modes_problem  # noqa: F401 (re-exported to the subcommands)


def parse_elements(text: str) -> int | tuple[int, ...]:
    """``--elements 4`` (every link) or ``--elements 1,2,2`` (per link, scene order)."""
    try:
        vals = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--elements: expected N or n1,n2,... (got {text!r})") from None
    if any(v < 1 for v in vals):
        raise argparse.ArgumentTypeError(f"--elements: every count must be >= 1 (got {text!r})")
    return vals[0] if len(vals) == 1 else vals


def add_elements_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--elements", type=parse_elements, metavar="N|n1,n2,...",
                   help="re-mesh: N elements on every link, or one count per link (scene order)")


def add_plane_selection(p: argparse.ArgumentParser) -> None:
    """``--plane in|out``: which sweep of a two-plane archive (``fkev run --plane both``) to read."""
    p.add_argument("--plane", choices=("in", "out"),
                   help="the plane of a two-plane archive (fkev run --plane both): in (default) or out (bending out "
                        "of the plane and torsion, /planes/out); a one-plane archive: its plane")


def add_accuracy_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--element", choices=ELEMENT_NAMES, help="element type (default: the scene's analysis.element)")
    p.add_argument("--rel-error", type=_positive_fraction, metavar="TOL",
                   help="choose element and elements per link so that the requested frequencies are within TOL "
                        "(relative) of the converged model's, by an a-posteriori estimate (docs/accuracy.md)")


def _positive_fraction(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"--rel-error: must be a number in (0, 1) (got {text!r})")
    return v


def apply_element(scene: Scene, element: str | None) -> Scene:
    """``scene`` with ``--element`` applied (None: unchanged); a Timoshenko element on links without
    shear data is refused (scene/validity.py)."""
    from fkev_slepc.scene.validity import timoshenko_problems
    from fkev_slepc.solve.accuracy import with_element

    if element is None:
        return scene
    new = with_element(scene, element)
    bad = timoshenko_problems(new, "--element")
    if bad:
        raise SceneError(scene.source, bad)
    return new


def add_model_arguments(p: argparse.ArgumentParser) -> None:
    """``--elements`` and ``--solver``: how a single-point command meshes and solves."""
    add_elements_argument(p)
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default: the scene's)")


API_FLAGS = {"angle_deg": "--angle", "speed_rad_s": "--speed", "case": "--case", "modes": "--modes",
             "max_speed_rad_s": "--max-speed", "rel_error": "--rel-error", "elements": "--elements"}
"""The API's argument names (in its errors) -> the flags that set them: the CLI alone speaks flags."""


def as_flags(err: SceneError, flags: dict | None = None) -> SceneError:
    """``err`` with each problem's API name (``angle_deg``, ``elements[1]``) as its flag (``--angle``,
    ``--elements[1]``); ``flags`` adds or overrides names for one command."""
    names = {**API_FLAGS, **(flags or {})}

    def flag(path: str) -> str:
        head, sep, rest = path.partition("[")
        return names[head] + sep + rest if head in names else path

    return SceneError(err.source, [Problem(flag(p.path), p.message) for p in err.problems])


ARCHIVE_FLAGS = {"angle": "--angle", "angles": "--angle", "speed": "--speed", "speeds": "--speed", "case": "--case",
                 "cases": "--case", "mode": "--modes", "modes": "--modes", "order": "--order", "kind": "--kind",
                 "plane": "--plane"}
"""Names in the errors of archive readers and plots -> the flags of ``fkev plot/info/margins``."""
SWEEP_FLAGS = {"angles_deg": "--angles", "speeds_rad_s": "--speeds", "modes": "--modes", "cases": "--cases"}
"""Names in a refused ``resume`` (the sweep's arguments) -> the flags of ``fkev run``."""


def flag_words(text: str, names: dict) -> str:
    """``text`` with each ``name:`` of ``names`` (at the start, or after ``: `` / ``; ``) as its flag.

    Examples
    --------
    >>> flag_words("angle: 20 deg is not on the grid", ARCHIVE_FLAGS)
    '--angle: 20 deg is not on the grid'
    >>> flag_words("x.h5: cannot resume: angles_deg: archive has 0,90; cases: archive has full", SWEEP_FLAGS)
    'x.h5: cannot resume: --angles: archive has 0,90; --cases: archive has full'
    """
    import re

    pattern = r"(^|: |; )(" + "|".join(map(re.escape, sorted(names, key=len, reverse=True))) + r"):"
    return re.sub(pattern, lambda m: f"{m.group(1)}{names[m.group(2)]}:", str(text))


def load_checked(path, elements=None, check_angles: bool = True) -> Scene:
    """Load a scene, apply ``--elements``, and check that it assembles at its crank angles
    (not with ``check_angles=False``: ``fkev point`` needs only its own angle).

    Raises SceneError listing every problem (named by flag)."""
    from fkev_slepc.model.kinematics import assembly_problems
    from fkev_slepc.scene import load_scene

    scene = load_scene(path)
    if elements is not None:
        try:
            scene = with_elements(scene, elements)
        except SceneError as err:
            raise as_flags(err) from None
    problems: list[Problem] = assembly_problems(scene) if check_angles else []
    if problems:
        raise SceneError(scene.source, problems)
    return scene


PLOT_FORMATS = (".png", ".pdf", ".svg")  # every --plot of every command
CLI_NAMES = {"elements": "--elements", "harmonics": "--harmonics"}  # how periodic/limits.py names them on the command line


def preflight(scene: Scene, args, *, speeds=None, speed_flag: str = "--speed", plots: tuple[str, ...] = ("plot",),
              output: str | None = None, periodic: bool = False, harmonics: int | None = None,
              reduce: str | None = None, model_for=None) -> None:
    """Every check of a command's input that needs no solve, before any work (one place for all
    commands): the figure paths (``plots``: attribute names of ``args``, e.g. ``plot_stations`` for
    ``--plot-stations``; a format matplotlib writes, an existing folder), the ``output`` file of a
    labelled result (``-o``: not a directory), the mesh size (``--elements``: at most
    :func:`fkev_slepc.periodic.limits.size_problems`, the limits the Python API checks
    too), the harmonic-balance size (``harmonics``), the damping (ζ over-critical) and ``speeds`` whose
    operators overflow double precision (named by ``speed_flag``;
    :func:`fkev_slepc.periodic.limits.plausibility_problems`, on ``model_for``'s model: the command's
    own :class:`~fkev_slepc.periodic.steady.SharedModel`, so that the check costs no Model of its own).

    Raises
    ------
    SceneError
        Every problem found, each naming its flag and value.
    """
    from fkev_slepc.archive.paths import PathProblem, check_output

    bad: list[Problem] = []
    for name in plots:
        path = getattr(args, name, None)
        if path is not None:
            flag = "--" + name.replace("_", "-")
            try:
                check_output(path, PLOT_FORMATS, flag)
            except PathProblem as exc:
                bad.append(Problem(flag, str(exc).removeprefix(flag + " ")))
    if output is not None:
        try:
            check_output(output, (".h5",), "-o", make_parent=True)
        except PathProblem as exc:
            bad.append(Problem("-o", str(exc).removeprefix("-o ")))
    bad += limits.size_problems(scene, periodic, harmonics, reduce, CLI_NAMES)
    if bad:  # nothing below is worth computing
        raise SceneError(scene.source, bad)
    bad += limits.plausibility_problems(scene, speeds, periodic, {**CLI_NAMES, "speed_rad_s": speed_flag},
                                        model_for)
    if bad:
        raise SceneError(scene.source, bad)
    from fkev_slepc.scene.validity import slenderness_warnings

    for w in slenderness_warnings(scene):
        print(f"warning: {w}", file=sys.stderr, flush=True)


def report_scene_error(err: SceneError) -> int:
    print(str(as_flags(err)), file=sys.stderr)
    return 2


def transmission_warning(mu: float, angle_deg: float) -> None:
    """A warning on stderr when the transmission angle ``mu`` (deg) at crank angle ``angle_deg``
    is below ``kinematics.TRANSMISSION_WARN_DEG`` (near a toggle, docs/numerical-stability.md)."""
    from fkev_slepc.model.kinematics import TRANSMISSION_WARN_DEG

    if mu < TRANSMISSION_WARN_DEG:
        print(f"warning: transmission angle {mu:.3g}° < {TRANSMISSION_WARN_DEG:g}° at θ = {angle_deg:g}°: "
              "near a toggle position, where link speeds and the speed-dependent terms grow like "
              "1/sin(μ) (docs/numerical-stability.md)", file=sys.stderr)


def angles_and_gravity(args, bad: list) -> tuple:
    """``--angles`` (deg grid, None if not given) and ``--gravity GX,GY`` (a tuple, or the text as typed
    for the scene check to name) of the cycle commands (loads, response); a bad grid is added to ``bad``."""
    from fkev_slepc.sweep.grid import parse_angles

    angles = gravity = None
    if args.angles is not None:
        try:
            angles = parse_angles(args.angles)
        except ValueError as err:
            bad.append(Problem("--angles", str(err)))
    if args.gravity is not None:
        try:
            gravity = tuple(float(v) for v in args.gravity.split(","))
        except ValueError:
            gravity = args.gravity
    return angles, gravity


def add_speed_arguments(p: argparse.ArgumentParser, default: str = "the scene's highest") -> None:
    """``--speed W`` (rad/s) or ``--speed-rpm RPM`` (rev/min), one of them (as ``fkev point``)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--speed", type=float, metavar="W", help=f"crank speed, rad/s (default: {default})")
    g.add_argument("--speed-rpm", type=float, metavar="RPM", help="crank speed, rev/min")


def chosen_speed(args, scene: Scene, flags: dict) -> float:
    """The crank speed in rad/s: ``--speed``, ``--speed-rpm`` converted (then ``flags`` names
    ``--speed-rpm`` for the speed in messages) or the scene's highest."""
    if args.speed_rpm is not None:
        flags["speed_rad_s"] = "--speed-rpm"
        return args.speed_rpm * RAD_S_PER_RPM
    return max(scene.driver.speeds, key=abs) if args.speed is None else args.speed


def add_speeds_arguments(p: argparse.ArgumentParser, help_rad_s: str) -> None:
    """``--speeds SPEC`` (rad/s) or ``--speeds-rpm SPEC`` (rev/min), one of them (as ``fkev run``)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--speeds", metavar="START:STOP:STEP|a,b,c", help=help_rad_s)
    g.add_argument("--speeds-rpm", metavar="START:STOP:STEP|a,b,c", help="crank speeds, rev/min (as --speeds)")
