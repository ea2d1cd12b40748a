"""``fkev point --sensitivity KEY``: the flag, and the sensitivities as a table or JSON (solve/sensitivity.py)."""

from __future__ import annotations

import difflib

from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.solve.sensitivity import POINT_KEYS, key_value, number_keys, scene_value


def add_sensitivity_argument(p) -> None:
    p.add_argument("--sensitivity", action="append", metavar="KEY", default=[],
                   help="also d f/d p and d ζ/d p of every mode for the numeric scene key KEY "
                        "(e.g. links[1].length_m, per unit of the key), or the point's own speed_rad_s or "
                        "angle_deg; repeatable")


def check_sensitivity_keys(scene, keys) -> None:
    """Refuse, before any work, every ``--sensitivity KEY`` at which ``scene`` holds no number
    (a typo: the closest numeric keys of the scene named), or whose number has no derivative.

    Raises
    ------
    SceneError
        Naming ``--sensitivity`` and each bad key.
    """
    bad = []
    for key in keys:
        if key in POINT_KEYS:
            continue
        try:
            path, node = scene_value(scene, key)
            if node is None:
                close = difflib.get_close_matches(path, number_keys(scene), n=3, cutoff=0.6)
                tip = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
                bad.append(Problem("--sensitivity", f"{key}: unknown key: the scene sets no number there ({tip}give "
                                   "a numeric key of the scene file, or speed_rad_s or angle_deg)"))
            else:
                key_value(scene, key)
        except SceneError as err:
            bad += [Problem("--sensitivity", str(p)) for p in err.problems]
    if bad:
        raise SceneError(scene.source, bad)


def sensitivities(res, keys) -> dict:
    """{KEY: Sensitivity.as_dict()} of a :class:`~fkev_slepc.api.results.PointResult` (SceneError for a bad key)."""
    return {key: res.sensitivity(key).as_dict() for key in keys}


def print_sensitivities(table: dict) -> None:
    """One block per key: mode, d f/d p, (p/f) d f/d p, d ζ/d p."""
    fmt = lambda v, spec: f"{v:{spec}}" if v is not None else "—"  # noqa: E731
    for key, s in table.items():
        print(f"sensitivity to {key} = {s['value']:g} ({s['method']}, step {s['step']:.3g}):")
        print(f"{'mode':>4} {'df/dp [Hz/unit]':>16} {'(p/f) df/dp':>12} {'dζ/dp [1/unit]':>15}")
        for i, (df, rel, dz) in enumerate(zip(s["frequency_hz"], s["relative_frequency"], s["damping_ratio"]), 1):
            print(f"{i:>4} {fmt(df, '16.6g'):>16} {fmt(rel, '12.4g'):>12} {fmt(dz, '15.4e'):>15}")
