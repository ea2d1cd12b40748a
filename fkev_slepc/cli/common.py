"""Argument helpers shared by the subcommands (parsing only; no physics)."""

from __future__ import annotations

import argparse
import sys

from fkev_slepc.scene import ELEMENT_NAMES, Problem, Scene, SceneError, with_elements
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
    """``scene`` with ``--element`` applied (None: unchanged)."""
    from fkev_slepc.solve.accuracy import with_element

    return scene if element is None else with_element(scene, element)


def add_model_arguments(p: argparse.ArgumentParser) -> None:
    """``--elements`` and ``--solver``: how a single-point command meshes and solves."""
    add_elements_argument(p)
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default: the scene's)")


def load_checked(path, elements=None, check_angles: bool = True) -> Scene:
    """Load a scene, apply ``--elements``, and check that it assembles at its crank angles
    (not with ``check_angles=False``: ``fkev point`` needs only its own angle).

    Raises SceneError listing every problem."""
    from fkev_slepc.model.kinematics import assembly_problems
    from fkev_slepc.scene import load_scene

    scene = load_scene(path)
    if elements is not None:
        scene = with_elements(scene, elements)
    problems: list[Problem] = assembly_problems(scene) if check_angles else []
    if problems:
        raise SceneError(scene.source, problems)
    return scene


def scene_case_modes(args, check_angles: bool = True) -> tuple[Scene, str, int]:
    """``args.scene`` loaded and checked (with ``--elements``; ``check_angles`` as in
    :func:`load_checked`), ``--case`` resolved and ``--modes`` checked (defaults: the scene's
    first case, its modes); SceneError names the bad file or flag."""
    from fkev_slepc.scene.cases import case_name

    scene = load_checked(args.scene, args.elements, check_angles)
    try:
        case = case_name(args.case) if args.case is not None else scene.analysis.cases[0]
    except ValueError as err:
        raise SceneError(args.scene, [Problem("--case", str(err))]) from None
    n_modes = scene.analysis.modes if args.modes is None else args.modes
    if n_modes < 1:
        raise SceneError(args.scene, [Problem("--modes", f"must be >= 1 (got {n_modes})")])
    return scene, case, n_modes


def report_scene_error(err: SceneError) -> int:
    print(str(err), file=sys.stderr)
    return 2


def transmission_warning(mu: float, angle_deg: float) -> None:
    """A warning on stderr when the transmission angle ``mu`` (deg) at crank angle ``angle_deg``
    is below ``kinematics.TRANSMISSION_WARN_DEG`` (near a toggle, docs/numerical-stability.md)."""
    from fkev_slepc.model.kinematics import TRANSMISSION_WARN_DEG

    if mu < TRANSMISSION_WARN_DEG:
        print(f"warning: transmission angle {mu:.3g}° < {TRANSMISSION_WARN_DEG:g}° at θ = {angle_deg:g}°: "
              "near a toggle position, where link speeds and the speed-dependent terms grow like "
              "1/sin(μ) (docs/numerical-stability.md)", file=sys.stderr)
