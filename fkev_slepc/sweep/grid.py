"""The sweep grid: a scene's crank angles, speeds, cases and modes, with overrides checked.

Overrides come as text from the command line (``--angles 0:360:5``) or as values from Python
(``angles_deg=[0, 90]``); both go through the same checks and the same error messages, which
name the flag or argument (``names``) and the value given.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from fkev_slepc.scene.validity import timoshenko_problems
from fkev_slepc.scene import ELEMENT_NAMES, Problem, Scene, SceneError
from fkev_slepc.scene.cases import CASE_NAMES, case_name
from fkev_slepc.scene.units import RAD_S_PER_RPM
from fkev_slepc.model.kinematics import assembly_problems
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.solve.finite import overflow_problems

MAX_POINTS_PER_AXIS = 1_000_000
API_NAMES = {"angles": "angles_deg", "speeds": "speeds_rad_s", "speeds_rpm": "speeds_rpm", "cases": "cases",
             "modes": "modes", "element": "element", "rel_error": "rel_error"}
"""How :func:`configure` names each override in its messages (Python argument names)."""
CLI_NAMES = {"angles": "--angles", "speeds": "--speeds", "speeds_rpm": "--speeds-rpm", "cases": "--cases",
             "modes": "--modes", "element": "--element", "rel_error": "--rel-error"}
"""The same for ``fkev run`` (its flags)."""


def parse_range(value, what: str = "values") -> tuple[float, ...]:
    """``START:STOP:STEP`` (STOP included when it lies on the grid), ``a,b,c``, or a
    sequence of numbers; ``what`` names the values in the message for too long a range.

    Examples
    --------
    >>> parse_range("0:300:100"), parse_range("0:1:0.4"), parse_range("5,1")
    ((0.0, 100.0, 200.0, 300.0), (0.0, 0.4, 0.8), (5.0, 1.0))
    """
    if not isinstance(value, str) or ":" not in value:
        return _list(value)
    parts = value.split(":")
    if len(parts) != 3:
        raise ValueError(f"expected START:STOP:STEP or a,b,c (got {value!r})")
    start, stop, step = (_number(v, value) for v in parts)
    if step <= 0:
        raise ValueError(f"STEP must be > 0 (got {value!r})")
    if stop < start:
        raise ValueError(f"STOP must be >= START (got {value!r})")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    if n > MAX_POINTS_PER_AXIS:
        raise ValueError(f"{n} {what} is too many (got {value!r})")
    return tuple(float(v) for v in start + step * np.arange(n))


def parse_angles(value) -> tuple[float, ...]:
    """Crank angles (deg): ``START:STOP:STEP``, ``a,b,c`` or a sequence (:func:`parse_range`).

    Examples
    --------
    >>> parse_angles("0:90:45"), parse_angles([10, 20.5])
    ((0.0, 45.0, 90.0), (10.0, 20.5))
    """
    values = parse_range(value, "angles")
    if any(not abs(v) <= MAX_ABS_ANGLE_DEG for v in values):
        raise ValueError(f"crank angles must lie within ±{MAX_ABS_ANGLE_DEG:g} deg, where a double still resolves "
                         f"1e-7 deg (got {value!r})")
    return values


MAX_ABS_ANGLE_DEG = 1e9  # beyond, one unit in the last place of an angle exceeds 1e-7 deg (1e155 deg: 1e139)


def parse_speeds(value) -> tuple[float, ...]:
    """Crank speeds (rad/s, >= 0): ``START:STOP:STEP``, ``a,b,c`` or a sequence of numbers.

    Examples
    --------
    >>> parse_speeds("0:300:150")
    (0.0, 150.0, 300.0)
    """
    values = parse_range(value, "speeds")
    if any(v < 0 for v in values):
        raise ValueError(f"speeds must be >= 0 rad/s (got {value!r})")
    return values


def parse_speeds_rpm(value) -> tuple[float, ...]:
    """Crank speeds given in rev/min (>= 0; ranges as :func:`parse_speeds`), returned in rad/s."""
    values = parse_range(value, "speeds")
    if any(v < 0 for v in values):
        raise ValueError(f"speeds must be >= 0 rpm (got {value!r})")
    return tuple(v * RAD_S_PER_RPM for v in values)


def parse_cases(value) -> tuple[str, ...]:
    """Case names: ``"all"``, ``"c1,c2"`` or a sequence of names / Table 3.1 numbers."""
    if isinstance(value, str) and value.strip() == "all":
        return CASE_NAMES
    items = value.split(",") if isinstance(value, str) else [value] if isinstance(value, int) else list(value)
    names = tuple(case_name(v) for v in items)
    if not names:
        raise ValueError(f"no case given (got {value!r})")
    if len(set(names)) != len(names):
        raise ValueError(f"a case is listed twice (got {value!r})")
    return names


def _number(v, text) -> float:
    try:
        x = float(v.strip() if isinstance(v, str) else v)
    except (TypeError, ValueError):
        shown = v.strip() if isinstance(v, str) else v
        raise ValueError(f"{shown!r} is not a number (got {text!r})") from None
    if not np.isfinite(x):
        raise ValueError(f"values must be finite (got {text!r})")
    return x


def _list(value) -> tuple[float, ...]:
    if isinstance(value, str):
        items = value.split(",")
    else:
        items = list(np.ravel(np.asarray(value, dtype=object)))
    values = tuple(_number(v, value) for v in items)
    if not values:
        raise ValueError(f"no value given (got {value!r})")
    if len(set(values)) != len(values):
        raise ValueError(f"a value is listed twice (got {value!r})")
    return values


def check_modes(modes, name: str) -> list[Problem]:
    """The problem with a number of modes (an integer >= 1), if any, named ``name``."""
    if isinstance(modes, bool) or not isinstance(modes, (int, np.integer)):
        return [Problem(name, f"must be an integer (got {modes!r})")]
    return [Problem(name, f"must be >= 1 (got {modes})")] if modes < 1 else []


def check_rel_error(rel_error, name: str) -> list[Problem]:
    """The problem with a requested relative frequency error (a number in (0, 1)), if any."""
    ok = isinstance(rel_error, (int, float, np.integer, np.floating)) and not isinstance(rel_error, bool)
    if ok and 0 < rel_error < 1:
        return []
    return [Problem(name, f"must be a number in (0, 1) (got {rel_error!r})")]


def modes_problem(n_modes: int, n_free: int, name: str | None) -> Problem | None:
    """A problem when more modes are asked than the model can have: its ``n_free`` DOFs give
    at most ``n_free`` oscillating modes (conjugate pairs of the 2·n_free eigenvalues)."""
    if n_modes <= n_free:
        return None
    return Problem(name or "analysis.modes",
                   f"{n_modes} modes asked, but the model has {n_free} free DOFs, so at most {n_free} "
                   "oscillating modes (refine with --elements or ask fewer)")


def scene_problems(scene: Scene, model_for=None) -> list[Problem]:
    """Every problem that stops a valid scene file from being solved (``fkev check`` and each design
    point of ``fkev design``): the crank angles at which the linkage cannot be assembled, else more
    modes than DOFs, else operators that overflow double precision
    (:func:`fkev_slepc.solve.finite.overflow_problems`, on ``model_for(scene, cases, "in")``'s model
    of the structure and every case; default a new one)."""
    problems = assembly_problems(scene)
    if not problems:
        problems = [p for p in [modes_problem(scene.analysis.modes, build_mechanism(scene).n_free, None)] if p]
    if problems:
        return problems
    every = tuple(dict.fromkeys(("structure", *scene.analysis.cases)))
    return overflow_problems(scene, None if model_for is None else model_for(scene, every, "in"))


def configure(scene: Scene, *, angles=None, speeds=None, speeds_rpm=None, cases=None, modes=None,
              mode_shapes=False, element=None, rel_error=None, names=API_NAMES) -> Scene:
    """``scene`` with its sweep grid (and element, requested accuracy) overridden where a value
    is given, and checked.

    Parameters
    ----------
    scene : Scene
    angles, speeds, speeds_rpm, cases : str or sequence, optional
        Crank angles (deg), speeds (rad/s, or rev/min) and cases (see :func:`parse_angles`,
        :func:`parse_speeds`, :func:`parse_cases`; angles and speeds also as a range
        ``"START:STOP:STEP"``); None keeps the scene's.
    modes : int, optional
        Modes per point (>= 1, at most the model's free DOFs); None keeps the scene's.
    mode_shapes : bool
        Also archive mode shapes (in addition to the scene's ``analysis.mode_shapes``).
    element : str, optional
        Element type, one of ``ELEMENT_NAMES`` (``analysis.element``); None keeps the scene's.
    rel_error : float, optional
        Requested relative frequency error in (0, 1) (``analysis.rel_error``: the sweep is then
        re-meshed by :func:`fkev_slepc.sweep.session.mesh_for_accuracy`); None keeps the scene's.
    names : dict
        How messages name each override (:data:`API_NAMES` or :data:`CLI_NAMES`).

    Raises
    ------
    SceneError
        Listing every bad override, or every crank angle at which the linkage cannot be
        assembled. Nothing has been computed or written.

    Examples
    --------
    >>> from fkev_slepc.scene import load_scene
    >>> from pathlib import Path
    >>> runs = Path(__file__).resolve().parents[2] / "runs"
    >>> s = configure(load_scene(runs / "bahgat-willmert-1976.toml"), angles="0:20:10", cases=[1])
    >>> s.analysis.crank_angles_deg, s.analysis.cases
    ((0.0, 10.0, 20.0), ('full',))
    >>> configure(s, speeds=[-1])
    Traceback (most recent call last):
    ...
    fkev_slepc.scene.model.SceneError: ...speeds_rad_s: speeds must be >= 0 rad/s (got [-1])
    """
    an, drv, problems = scene.analysis, scene.driver, []
    for key, value, parse, field in (("angles", angles, parse_angles, "crank_angles_deg"),
                                     ("speeds", speeds, parse_speeds, "speeds"),
                                     ("speeds_rpm", speeds_rpm, parse_speeds_rpm, "speeds"),
                                     ("cases", cases, parse_cases, "cases")):
        if value is None:
            continue
        try:
            parsed = parse(value)
        except ValueError as err:
            problems.append(Problem(names[key], str(err)))
            continue
        if field == "speeds":
            drv = replace(drv, speeds=parsed, speed_unit="rpm" if key == "speeds_rpm" else "rad/s")
        else:
            an = replace(an, **{field: parsed})
    if modes is not None:
        bad = check_modes(modes, names["modes"])
        problems += bad
        if not bad:
            an = replace(an, modes=int(modes))
    if element is not None:
        if element in ELEMENT_NAMES:
            an = replace(an, element=element)
            problems += timoshenko_problems(replace(scene, analysis=an), names["element"])
        else:
            problems.append(Problem(names["element"], f"must be one of {', '.join(ELEMENT_NAMES)} (got {element!r})"))
    if rel_error is not None:
        bad = check_rel_error(rel_error, names["rel_error"])
        problems += bad
        if not bad:
            an = replace(an, rel_error=float(rel_error))
    if problems:
        raise SceneError(scene.source, problems)
    scene = replace(scene, analysis=replace(an, mode_shapes=an.mode_shapes or bool(mode_shapes)), driver=drv)
    bad = assembly_problems(scene)
    if bad and angles is not None:
        bad = [Problem(p.path.replace("analysis.crank_angles_deg", names["angles"]), p.message) for p in bad]
    if not bad:  # the mechanism builds: its size bounds the number of modes
        too_many = modes_problem(scene.analysis.modes, build_mechanism(scene).n_free,
                                 names["modes"] if modes is not None else None)
        bad = [too_many] if too_many else []
    if bad:
        raise SceneError(scene.source, bad)
    return scene
