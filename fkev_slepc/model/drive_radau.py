"""Numerical pieces of the drive's steady cycle (docs/theory.md §20.3): the mesh of one revolution,
the Radau IIA collocation coefficients, and the extremes of a cubic Hermite interpolant."""

from __future__ import annotations

import numpy as np
from numpy.polynomial import legendre as L
from numpy.polynomial import polynomial as P


def radau_iia(s: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes c (s,) in (0, 1], c_s = 1 (the zeros of P_s(2x−1) − P_{s−1}(2x−1)), and the matrix
    A (s, s), a_ij = ∫₀^{c_i} ℓ_j, of s-stage Radau IIA collocation (b = A[-1])."""
    coef = np.zeros(s + 1)
    coef[s], coef[s - 1] = 1.0, -1.0
    x = np.sort(np.real(L.legroots(coef)))
    c = 0.5 * (x + 1.0)
    c[-1] = 1.0
    A = np.empty((s, s))
    for j in range(s):
        others = np.delete(c, j)
        basis = P.polyfromroots(others) / np.prod(c[j] - others)
        integral = P.polyint(basis)
        A[:, j] = P.polyval(c, integral)
    return c, A


def cycle_mesh(knots, max_step: float) -> np.ndarray:
    """Nodes 0 = θ_0 < … < θ_M = 2π containing every knot (rad, taken mod 2π) and no interval
    longer than ``max_step``: the knots cut the circle, each piece is split evenly."""
    two_pi = 2.0 * np.pi
    cuts = np.unique(np.concatenate([np.mod(np.asarray(k, float), two_pi) for k in knots] + [np.zeros(1)]))
    cuts = np.r_[cuts[np.r_[True, np.diff(cuts) > 1e-9]], two_pi]
    if two_pi - cuts[-2] <= 1e-9:
        cuts = np.delete(cuts, -2)
    pieces = [np.linspace(a, b, int(np.ceil((b - a) / max_step - 1e-9)) + 1)[:-1] for a, b in zip(cuts[:-1], cuts[1:])]
    return np.r_[np.concatenate(pieces), two_pi]


def hermite_extremes(ya, yb, da, db, h) -> tuple[float, float]:
    """(min, max) over all intervals of the cubic Hermite interpolant with end values ya, yb and
    end slopes da, db (per unit of the abscissa) on intervals of lengths h (arrays (M,))."""
    a1, b1 = h * da, h * db
    a2 = -3.0 * ya - 2.0 * a1 + 3.0 * yb - b1
    a3 = 2.0 * ya + a1 - 2.0 * yb + b1
    qa, qb, qc = 3.0 * a3, 2.0 * a2, a1  # p'(x) = qa x² + qb x + qc
    disc = np.maximum(qb * qb - 4.0 * qa * qc, 0.0)
    sq = np.sqrt(disc)
    with np.errstate(divide="ignore", invalid="ignore"):
        # roots without cancellation; a linear p' where qa = 0
        q = -0.5 * (qb + np.copysign(sq, qb))
        r1 = np.where(qa != 0, q / qa, -qc / qb)
        r2 = np.where(q != 0, qc / q, np.nan)
    cand = [np.zeros_like(ya), np.ones_like(ya), r1, r2]
    vals = []
    for x in cand:
        x = np.where(np.isfinite(x) & (x >= 0.0) & (x <= 1.0), x, 0.0)
        vals.append(ya + x * (a1 + x * (a2 + x * a3)))
    v = np.stack(vals)
    return float(v.min()), float(v.max())
