"""``fkev check SCENE [SCENE...]``: validate scene files without computing anything.

Schema problems come first (:func:`fkev_slepc.scene.load_scene`); only a scene without them is
checked for assembly at every requested crank angle (kinematics: the intervals of θ where it
cannot be assembled, with the Grashof class) and meshed (to report the number of free DOFs,
the Grashof class and the smallest transmission angle), and its ``[solver.petsc]`` options are
given to the SLEPc objects (an option no object reads, e.g. a misspelt name, is an error).
Its operators are assembled at the first crank angle and the largest speed: finite values whose
operators overflow double precision (a speed of 1e155 rad/s, an area of 1e300 m²) are refused
(:func:`fkev_slepc.solve.finite.overflow_problems`).
Every problem of every file is printed; the exit code is 2 if any file
has one.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fkev_slepc.scene import Scene, SceneError, load_scene


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "check",
        help="validate scene files (schema, references, assembly at every crank angle)",
        description="Validate scene files and report every problem, with its dotted field path.",
    )
    p.add_argument("scenes", nargs="+", type=Path, metavar="SCENE", help="scene TOML file(s)")
    p.add_argument("--strict", action="store_true",
                   help="treat implausible values (unit slips: warnings) as problems (exit code 2)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Check every scene in ``args.scenes``; 0 if all are valid, else 2."""
    from fkev_slepc.status import EXIT_BAD_INPUT, EXIT_OK

    status = EXIT_OK
    for path in args.scenes:
        try:
            scene = check_scene(path)
        except SceneError as err:
            print(err, file=sys.stderr, flush=True)
            status = EXIT_BAD_INPUT
            continue
        print(f"{path}: ok ({summary(scene)})", flush=True)
        warnings = print_links(scene) + print_buckling(scene)
        for w in warnings:
            print(f"{path}: warning: {w}", file=sys.stderr, flush=True)
        if warnings and getattr(args, "strict", False):
            status = EXIT_BAD_INPUT
    return status


def print_links(scene: Scene) -> list[str]:
    """The per-link table (mass, slenderness, pinned-pinned f₁ estimate, and with out-of-plane
    section data the weak-axis f₁ and the first torsion frequency f_t, docs/theory.md §19;
    scene/plausible.py) on stdout; returns the warnings on implausible values."""
    from fkev_slepc.scene.plausible import damping_warnings, summarize_scene

    rows = summarize_scene(scene)
    import re

    written = re.match(r"# .* in SI: its \[units\] \((.*?)\) converted on reading", scene.source_text)
    if written:
        print(f"  units: written in {written[1]}, converted to SI on reading (the values below, and archives, are SI)")
    print(f"  {'link':<12} {'L [m]':>9} {'mass [kg]':>10} {'L/r':>8} {'f1 pinned-pinned [Hz]':>22}"
          f" {'f1 out of plane [Hz]':>21} {'f_t torsion [Hz]':>17}")
    for s in rows:
        print(f"  {s.name:<12} {s.length_m:>9.4g} {s.mass_kg:>10.4g} {s.slenderness:>8.4g} {s.pinned_frequency_hz:>22.5g}"
              f" {_hz(s.pinned_frequency_out_hz, 21)} {_hz(s.torsion_frequency_hz, 17)}")
    if any(None in (s.pinned_frequency_out_hz, s.torsion_frequency_hz) for s in rows):
        print("  - : no out-of-plane section data (second moment out of plane, torsion constant, shear modulus)")
    from fkev_slepc.scene.validity import slenderness_warnings

    return [w for s in rows for w in s.warnings] + damping_warnings(scene, rows) + slenderness_warnings(scene)


def _hz(f: float | None, width: int) -> str:
    return f"{'-':>{width}}" if f is None else f"{f:>{width}.5g}"


def print_buckling(scene: Scene) -> list[str]:
    """The weak-axis Euler margin of every link with an out-of-plane section under the
    kinetostatic axial force at the scene's highest speed (model/buckling.py) on stdout; returns
    the warnings of margins below 3. Nothing for a scene without out-of-plane sections."""
    import numpy as np

    from fkev_slepc.api.loads import study_loads
    from fkev_slepc.model.buckling import euler_loads, weak_axis_buckling
    from fkev_slepc.model.mechanism import build_mechanism

    mech = build_mechanism(scene)
    if np.isnan(euler_loads(mech)).all():
        return []
    speed = max(scene.driver.speeds, key=abs)
    rows = weak_axis_buckling(mech, study_loads(scene, speed))
    print(f"  weak-axis buckling at the scene's highest speed {speed:g} rad/s (kinetostatic axial force):")
    for b in rows:
        margin = "no compression" if b.min_axial_force_n >= 0 else "no out-of-plane section" if b.factor is None \
            else f"factor {b.factor:.4g}"
        print(f"  {b.link:<12} P_cr {b.euler_load_n:10.5g} N (K = {b.length_factor:g})  "
              f"N_min {b.min_axial_force_n:10.5g} N  {margin}")
    return [w for b in rows for w in [b.warning()] if w]


def check_scene(path: str | Path) -> Scene:
    """Load ``path`` and check that the linkage assembles at every requested crank angle.

    Raises
    ------
    SceneError
        With every schema problem, or else with every assembly/topology problem.
    """
    scene = load_scene(path)
    from fkev_slepc.sweep.grid import scene_problems

    problems = scene_problems(scene)
    if problems:
        raise SceneError(scene.source, problems)
    if scene.solver.petsc:  # names PETSc would silently ignore (misspelt) are errors too
        from fkev_slepc.solve.engines import check_petsc_options

        try:
            check_petsc_options(scene.solver.petsc)
        except SceneError as err:
            raise SceneError(scene.source, err.problems) from None
    return scene


def summary(scene: Scene) -> str:
    """One-line description: counts of links, joints, elements, free DOFs and sweep points,
    the Grashof class of a four-bar and the smallest transmission angle over the grid."""
    import numpy as np

    from fkev_slepc.model.kinematics import TRANSMISSION_WARN_DEG, grashof_class, solve_kinematics
    from fkev_slepc.model.mechanism import build_mechanism

    mech = build_mechanism(scene)
    n_free = mech.n_free
    geometry = [grashof_class(mech) or ""]
    mu = solve_kinematics(mech, np.radians(scene.analysis.crank_angles_deg)).transmission
    if np.isfinite(mu).any():
        low = " (below %g°: near a toggle)" % TRANSMISSION_WARN_DEG if np.nanmin(mu) < np.radians(TRANSMISSION_WARN_DEG) else ""
        geometry.append(f"transmission angle >= {np.degrees(np.nanmin(mu)):.1f}°{low}")
    a = scene.analysis
    n_el = mech.elem_length.size  # with ternary branches and nodes inserted at masses
    plural = lambda n, word: f"{n} {word}{'' if n == 1 else 's'}"  # noqa: E731
    return ", ".join(
        [
            plural(len(scene.links), "link"),
            plural(len(scene.joints), "joint"),
            plural(n_el, "element"),
            f"n_free {n_free}",
            f"{plural(len(a.crank_angles_deg), 'angle')} x {plural(len(scene.driver.speeds), 'speed')}"
            f" x {plural(len(a.cases), 'case')}",
            plural(a.modes, "mode"),
            *(g for g in geometry if g),
        ]
    )
