"""Crank speeds in rev/min: the conversion, and whether a scene (or a command line) used rpm.

Scenes store speeds in rad/s; when the user wrote them in rpm (``driver.speeds_rpm``,
``--speeds-rpm``, ``--speed-rpm``) the outputs show rpm beside rad/s.
"""

from __future__ import annotations

import math
import tomllib

RAD_S_PER_RPM = 2.0 * math.pi / 60.0


def speeds_given_in_rpm(scene_toml: str, command_line: str = "") -> bool:
    """True when ``driver.speeds_rpm`` is in the scene text or ``--speeds-rpm``/``--speed-rpm``
    is on the command line.

    Examples
    --------
    >>> speeds_given_in_rpm('[driver]\\nspeeds_rpm = [600]')
    True
    """
    if "--speeds-rpm" in command_line or "--speed-rpm" in command_line:
        return True
    try:
        doc = tomllib.loads(scene_toml) if scene_toml else {}
    except tomllib.TOMLDecodeError:
        return False
    driver = doc.get("driver")
    return isinstance(driver, dict) and "speeds_rpm" in driver


def with_rpm(rad_s: float, show: bool) -> str:
    """``104.72 rad/s`` or ``104.72 rad/s (1000 rpm)``."""
    return f"{rad_s:g} rad/s" + (f" ({rad_s / RAD_S_PER_RPM:.6g} rpm)" if show else "")
