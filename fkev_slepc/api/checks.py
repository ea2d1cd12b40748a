"""The one validation layer of the API's point arguments (``Study.point``, ``Study.critical``).

Every problem is named by the Python argument (``angle_deg``, ``speed_rad_s``, ``case``,
``modes``, ``max_speed_rad_s``, ``elements``); the command line alone turns those names into its
flags (:data:`fkev_slepc.cli.common.API_FLAGS`). All problems of one call are reported together.
"""

from __future__ import annotations

import numpy as np

from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.scene.cases import case_name
from fkev_slepc.sweep.grid import check_modes, modes_problem


def _finite(name: str, value, bad: list[Problem]) -> None:
    if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool):
        bad.append(Problem(name, f"must be a number (got {value!r})"))
    elif not np.isfinite(value):
        bad.append(Problem(name, f"must be finite (got {value})"))


def point_arguments(scene: Scene, case, modes, *, angle_deg=None, speed_rad_s=None, max_speed_rad_s=None,
                    need_angle: bool = False, need_speed: bool = False) -> tuple[str, int]:
    """``(case name, number of modes)`` for a point-like request, or SceneError listing every
    bad argument. ``modes`` None: the scene's ``analysis.modes``; ``angle_deg``/``speed_rad_s``
    are checked when given or ``need_*``; ``max_speed_rad_s`` must be > 0 when given.

    Examples
    --------
    >>> from fkev_slepc.scene import load_scene
    >>> sc = load_scene(RUNS / "bahgat-willmert-1976.toml")
    >>> point_arguments(sc, 1, None, angle_deg=10.0, speed_rad_s=0.0)
    ('full', 4)
    >>> point_arguments(sc, "Full", 0, angle_deg=float("nan"))
    Traceback (most recent call last):
    ...
    fkev_slepc.scene.model.SceneError: ...
      case: unknown case 'Full'; did you mean 'full'? ...
      modes: must be >= 1 (got 0)
      angle_deg: must be finite (got nan)
    """
    bad: list[Problem] = []
    try:
        case = case_name(case)
    except ValueError as err:
        bad.append(Problem("case", str(err)))
    n_modes = scene.analysis.modes if modes is None else modes
    bad += check_modes(n_modes, "modes")
    if angle_deg is not None or need_angle:
        _finite("angle_deg", angle_deg, bad)
    if speed_rad_s is not None or need_speed:
        _finite("speed_rad_s", speed_rad_s, bad)
    if max_speed_rad_s is not None:
        ok = isinstance(max_speed_rad_s, (int, float, np.integer, np.floating)) and not isinstance(max_speed_rad_s, bool)
        if not (ok and np.isfinite(max_speed_rad_s) and max_speed_rad_s > 0):
            bad.append(Problem("max_speed_rad_s", f"must be a finite speed > 0 rad/s (got {max_speed_rad_s!r})"))
    if bad:
        raise SceneError(scene.source, bad)
    return case, int(n_modes)


def modes_fit(scene: Scene, n_modes: int, n_free: int, explicit: bool) -> None:
    """SceneError when more modes are asked than the model has free DOFs (named ``modes`` when
    the caller gave them, ``analysis.modes`` when they are the scene's)."""
    too_many = modes_problem(n_modes, n_free, "modes" if explicit else None)
    if too_many:
        raise SceneError(scene.source, [too_many])
