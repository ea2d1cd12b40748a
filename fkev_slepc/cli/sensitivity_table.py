"""``fkev point --sensitivity KEY``: the flag, and the sensitivities as a table or JSON (solve/sensitivity.py)."""

from __future__ import annotations


def add_sensitivity_argument(p) -> None:
    p.add_argument("--sensitivity", action="append", metavar="KEY", default=[],
                   help="also d f/d p and d ζ/d p of every mode for the numeric scene key KEY "
                        "(e.g. links[1].length_m, per unit of the key), or the point's own speed_rad_s or "
                        "angle_deg; repeatable")


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
