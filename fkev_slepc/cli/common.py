"""Argument helpers shared by the subcommands (parsing only; no physics)."""

from __future__ import annotations

import argparse
import sys

from fkev_slepc.scene import Problem, Scene, SceneError, with_elements


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


def load_checked(path, elements=None) -> Scene:
    """Load a scene, apply ``--elements``, and check that it assembles at its crank angles.

    Raises SceneError listing every problem."""
    from fkev_slepc.model.kinematics import assembly_problems
    from fkev_slepc.scene import load_scene

    scene = load_scene(path)
    if elements is not None:
        scene = with_elements(scene, elements)
    problems: list[Problem] = assembly_problems(scene)
    if problems:
        raise SceneError(scene.source, problems)
    return scene


def report_scene_error(err: SceneError) -> int:
    print(str(err), file=sys.stderr)
    return 2
