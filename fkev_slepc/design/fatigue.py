"""Safety factors of a point of a link against yield and fatigue (docs/design.md, "Design check").

Static: n_s = S_y / max|σ| over the cycle. Fatigue, from the mean σ_m and alternating σ_a of
the signed stress over the cycle (fkev_slepc/periodic/link_stress.py), with the material's
endurance strength S_e, ultimate S_ut and yield S_y (Shigley's *Mechanical Engineering Design*,
§6-12, the fluctuating-stress criteria):

    Goodman (default)   1/n = σ_a/S_e + σ_m/S_ut
    Soderberg           1/n = σ_a/S_e + σ_m/S_y
    Gerber              n σ_a/S_e + (n σ_m/S_ut)² = 1,  n = 2 / (a + sqrt(a² + 4b)),
                        a = σ_a/S_e, b = (σ_m/S_ut)²

A compressive mean does not shorten fatigue life in these criteria: for σ_m ≤ 0 every one gives
n = S_e/σ_a (the usual convention, Shigley §6-12). A point with σ_a = σ_m = 0 has n = ∞.
"""

from __future__ import annotations

import numpy as np

CRITERIA = ("goodman", "soderberg", "gerber")


def static_factor(peak_abs, yield_strength) -> np.ndarray:
    """S_y / max|σ| (∞ where the stress is 0)."""
    with np.errstate(divide="ignore"):
        return np.asarray(yield_strength, float) / np.asarray(peak_abs, float)


def fatigue_factor(mean, alternating, material, criterion: str = "goodman") -> np.ndarray:
    """The fatigue safety factor of (σ_m, σ_a) for ``material`` (a scene Material, or anything
    with its ``endurance_limit``, ``ultimate_strength`` and, for Soderberg, ``yield_strength``,
    numbers or arrays) by ``criterion`` (:data:`CRITERIA`).

    Examples
    --------
    >>> from fkev_slepc.scene import Material
    >>> m = Material("s", 2e11, 7850, yield_strength=500e6, ultimate_strength=600e6, endurance_limit=300e6)
    >>> float(fatigue_factor(60e6, 100e6, m))   # 1 / (100/300 + 60/600)
    2.3076923076923075
    """
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {', '.join(CRITERIA)} (got {criterion!r})")
    sm = np.maximum(np.asarray(mean, float), 0.0)
    a = np.abs(np.asarray(alternating, float)) / material.endurance_limit
    with np.errstate(divide="ignore"):
        if criterion == "gerber":
            b = (sm / material.ultimate_strength) ** 2
            return 2.0 / (a + np.sqrt(a * a + 4.0 * b))
        strength = material.ultimate_strength if criterion == "goodman" else material.yield_strength
        return 1.0 / (a + sm / strength)


def missing_strengths(material, criterion: str) -> list[str]:
    """The TOML keys of the strengths ``criterion`` needs that ``material`` lacks."""
    need = {"endurance_pa": "endurance_limit"}
    need.update({"yield_pa": "yield_strength"} if criterion == "soderberg" else {"ultimate_pa": "ultimate_strength"})
    return [key for key, field in need.items() if getattr(material, field) is None]
