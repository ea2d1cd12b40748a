"""The ``[damping]`` section of a scene: Rayleigh structural damping (docs/stability.md)."""

from __future__ import annotations

from fkev_slepc.scene.model import Damping
from fkev_slepc.scene.schema import Reader

DAMPING_KEYS = ("mass_proportional_1_s", "stiffness_proportional_s")


def read_damping(r: Reader, doc) -> Damping | None:
    """``[damping]``: Rayleigh structural damping C_d = α M + β K_s (α, β >= 0; default none).

    Non-negative coefficients keep C_d positive semi-definite, which the whole-spectrum
    divergence certificate relies on (solve/stability.py)."""
    table = r.table(doc, "damping", "")
    if table is None:
        return None
    r.check_keys(table, "damping", DAMPING_KEYS)
    alpha = r.number(table, "mass_proportional_1_s", "damping", default=0.0, minimum=0.0)
    beta = r.number(table, "stiffness_proportional_s", "damping", default=0.0, minimum=0.0)
    return None if None in (alpha, beta) else Damping(alpha, beta)
