"""The one verdict rule of the periodic analyses: does a motion grow over a revolution?
(docs/stability.md, docs/response.md §3).

From the largest Floquet multiplier's modulus max|μ| and the engine's estimate ``error`` of the
multipliers, with the tolerance ``tol`` of the question asked (a field of
:class:`~fkev_slepc.periodic.settings.PeriodicSettings`: ``verdict_tol`` for a Floquet speed,
``attract_tol`` for a periodic response), the allowance is

    t = tol + SAFETY · error            (SAFETY = 10: the error estimate counted ten times)

and the motion **grows** where max|μ| − 1 > t (a Floquet speed is unstable, a periodic response
does not attract), is **neutral** where |max|μ| − 1| <= t (undamped: the multipliers on the unit
circle), and **decays** below. :func:`margin` is max|μ| − 1 − t (> 0: grows), the continuous
function whose sign changes locate the band edges (fkev_slepc/periodic/bands.py,
fkev_slepc/periodic/edges.py); an unknown max|μ| or error (NaN, inf) gives no verdict.
"""

from __future__ import annotations

import numpy as np

from fkev_slepc.periodic.settings import SAFETY

GROWS, NEUTRAL, DECAYS = 1, 0, -1


def allowance(error: float, tol: float) -> float:
    """t = ``tol`` + SAFETY·``error``: how far max|μ| may sit above 1 and still not count as growth."""
    return float(tol + SAFETY * error)


def margin(max_abs: float, error: float, tol: float) -> float:
    """max|μ| − 1 − t (> 0: grows), NaN where max|μ| or the error is not finite."""
    if not (np.isfinite(max_abs) and np.isfinite(error)):
        return float("nan")
    return float(max_abs - 1.0 - allowance(error, tol))


def verdict(max_abs: float, error: float, tol: float) -> int | None:
    """:data:`GROWS`, :data:`NEUTRAL` or :data:`DECAYS` by the rule of the module docstring; None unknown."""
    m = margin(max_abs, error, tol)
    if not np.isfinite(m):
        return None
    return GROWS if m > 0 else NEUTRAL if max_abs >= 1.0 - allowance(error, tol) else DECAYS
