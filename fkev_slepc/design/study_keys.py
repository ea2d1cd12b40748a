"""Scene keys a design study cannot vary: the settings it holds fixed for every design point.

A design study (fkev_slepc/design/study.py) solves every design point on the grid of the base
scene (its crank angles, speeds, cases and number of modes, each overridable for the whole study
by ``--angles``, ``--speeds``, ``--cases``, ``--modes``), with one eigen-solver and one set of
thresholds. A design key among these would be accepted and then ignored -- every point would
give the same numbers under a different label -- so it is refused before any work, naming the
key, why, and what sets it instead (docs/design.md, "Keys a design study holds fixed"). Every
other numeric scene key (link, joint, mass, damping, material, load keys, the crank
acceleration, ``analysis.gravity_m_s2``) changes the design point's model or its design
check and is designed as given.
"""

from __future__ import annotations

from fkev_slepc.scene import Problem
from fkev_slepc.scene.edit import parse_key

GRID = "every design point is solved on the study's grid"
ONE_FOR_ALL = "one value holds for the whole study"
# (section, key; None: every key of the section) -> (why, the argument that sets it instead, or None: the scene file)
FIXED = {
    ("driver", "speeds_rad_s"): (f"{GRID} (its crank speeds)", "speeds"),
    ("driver", "speeds_rpm"): (f"{GRID} (its crank speeds)", "speeds_rpm"),
    ("analysis", "crank_angles_deg"): (f"{GRID} (its crank angles)", "angles"),
    ("analysis", "cases"): (f"{GRID} (its cases)", "cases"),
    ("analysis", "modes"): (f"{GRID} (its number of modes)", "modes"),
    ("analysis", "imag_tol"): (f"{ONE_FOR_ALL} (the oscillating-mode threshold)", None),
    ("analysis", "damping_tol"): (f"{ONE_FOR_ALL} (the stability threshold)", None),
    ("analysis", "mode_shapes"): ("a design study archives no mode shapes", None),
    ("analysis", "rel_error"): ("a design study does not refine meshes: design links[i].elements instead", None),
    ("solver", None): ("one eigen-solver (and its options) solves every design point", "solver"),
}
API_NAMES = {"speeds": "speeds=", "speeds_rpm": "speeds= (rad/s)", "angles": "angles=", "cases": "cases=",
             "modes": "modes=", "solver": "solver="}
"""How :func:`fixed_key_problems` names the arguments of :meth:`Study.design <fkev_slepc.api.study.Study.design>`."""
CLI_NAMES = {"speeds": "--speeds", "speeds_rpm": "--speeds-rpm", "angles": "--angles", "cases": "--cases",
             "modes": "--modes", "solver": "--solver or -fkev_ options"}
"""The same for ``fkev design`` (its flags)."""


def fixed_key_problems(keys, name: str = "params", names: dict | None = None) -> list[Problem]:
    """One problem per design key the study holds fixed (:data:`FIXED`), named ``name[key]``,
    saying why and what sets it instead (``names``: :data:`API_NAMES` or :data:`CLI_NAMES`).

    Examples
    --------
    >>> fixed_key_problems(["links[1].length_m", "driver.speeds_rad_s"], "--set", CLI_NAMES)[0].message
    "cannot vary over a design study: every design point is solved on the study's grid (its crank speeds); use --speeds"
    """
    names = API_NAMES if names is None else names
    out = []
    for key in keys:
        try:
            parts = parse_key(str(key))
        except ValueError:
            continue  # a malformed path: the scene edit names it
        head = tuple(parts[:2]) if len(parts) > 1 else (parts[0], None)
        why, instead = FIXED.get(head, FIXED.get((parts[0], None), (None, None)))
        if why is None:
            continue
        where = f"use {names[instead]}" if instead else "set it in the scene file"
        out.append(Problem(f"{name}[{key}]", f"cannot vary over a design study: {why}; {where}"))
    return out
