"""The one cycle-mean frozen frequency ω̄ₖ(Ω) (docs/theory.md §18.7, docs/stability.md): the
frozen frequencies averaged over exactly one crank revolution, weighted by angle.

``cycle_mean(angles, values, period=360.0) -> mean over axis 0``
    the periodic trapezoid rule: angles are taken modulo ``period``, an angle met twice (0° and
    360°) counts once (its first value), and each remaining angle weighs half the gap to its two
    neighbours around the circle, so a uniform grid gets equal weights and a non-uniform one is
    weighted by angle; non-finite values (an angle that did not converge) are left out column by
    column. NaN where a column has no finite value.
``frozen_frequencies(model, theta, omega, case, n_modes) -> (len(θ), n_modes)``
    the lowest ``n_modes`` frozen frequencies Im λ (rad/s) of the case's QEP at each crank angle
    (Rayleigh damping and the Coriolis term included: the eigenvalues of the frozen sweep), by
    the dense linearisation [[0, I], [-K, -C]] x = λ [[I, 0], [0, M]] x.
``cycle_mean_frequencies(model, omega, case, n_modes, n_angles=24) -> (n_modes,)``
    the two together at ``n_angles`` equispaced angles.

Used by the band labels and resonance probes of ``fkev floquet`` (from the archived frozen sweep)
and the forced resonances of ``fkev response --speeds``.
"""

from __future__ import annotations

import numpy as np
from fkev_slepc.solve.dense import all_eigenvalues


def angle_weights(angles, period: float = 360.0) -> tuple[np.ndarray, np.ndarray]:
    """(index, weight): the first occurrence of each distinct angle modulo ``period`` and its
    periodic-trapezoid weight (weights sum to 1)."""
    a = np.mod(np.asarray(angles, dtype=float), period)
    a = np.where(np.isclose(a, period, rtol=0.0, atol=1e-9 * period), 0.0, a)
    _, first = np.unique(np.round(a / period, 12), return_index=True)
    if first.size == 1:
        return first, np.ones(1)
    x = a[first]  # sorted, as uniq
    gap = np.diff(np.r_[x, x[0] + period])  # to the next angle around the circle
    w = 0.5 * (gap + np.roll(gap, 1))
    return first, w / period


def cycle_mean(angles, values, period: float = 360.0) -> np.ndarray:
    """The angle-weighted mean of ``values`` (len(angles), ...) over one revolution (see the
    module docstring)."""
    angles = np.asarray(angles, dtype=float)
    v = np.asarray(values, dtype=float)
    flat = v.reshape(v.shape[0], -1)
    out = np.full(flat.shape[1], np.nan)
    ok = np.isfinite(flat)
    for masks in np.unique(ok.T, axis=0):  # one weighting per pattern of converged angles
        cols = np.flatnonzero((ok.T == masks).all(axis=1))
        if not masks.any():
            continue
        rows = np.flatnonzero(masks)
        idx, w = angle_weights(angles[rows], period)
        out[cols] = np.sum(w[:, None] * flat[rows[idx]][:, cols], axis=0)  # not BLAS: the same sum on any thread count
    return out.reshape(v.shape[1:])


def frozen_frequencies(model, theta, omega: float, case: str, n_modes: int) -> np.ndarray:
    """The lowest ``n_modes`` frozen frequencies Im λ > 0 (rad/s) at each angle (NaN-padded)."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    stack = model.piece_stack(theta)
    qeps = [model.qep(model.pieces_at(stack, i), omega, case) for i in range(theta.size)]
    # solve/'s scaled, balanced dense path (solve/dense.py: the unscaled companion form loses the low modes' digits)
    lam = np.stack([all_eigenvalues(q) for q in qeps])
    lam = np.where(np.isfinite(lam), lam, 0.0)
    im = np.where(lam.imag > 1e-9 * np.abs(lam).max(axis=1, keepdims=True), lam.imag, np.inf)
    w = np.sort(im, axis=1)[:, :n_modes]
    return np.where(np.isfinite(w), w, np.nan)


def cycle_mean_frequencies(model, omega: float, case: str, n_modes: int, n_angles: int = 24) -> np.ndarray:
    """ω̄ₖ (n_modes,), rad/s: :func:`frozen_frequencies` at ``n_angles`` equispaced angles,
    averaged by :func:`cycle_mean`."""
    theta = 2.0 * np.pi * np.arange(n_angles) / n_angles
    return cycle_mean(theta, frozen_frequencies(model, theta, omega, case, n_modes), 2.0 * np.pi)
