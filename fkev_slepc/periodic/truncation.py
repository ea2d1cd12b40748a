"""The frozen-mode reduction's basis rule and its truncation error, measured by a convergence sequence.

A reduced monodromy (fkev_slepc/periodic/reduce.py) is only as good as its basis, and its error is not
known in advance: it is measured here by growing the basis and watching what a designer uses
change from one basis level to the next.

**The basis rule.** The pool is the lowest ``r`` undamped frozen modes of the case at ``angles``
equispaced crank angles, each unit-normalised and co-rotated into its links' frames
(:func:`~fkev_slepc.periodic.reduce.frozen_pool`). A level keeps the pool's left singular
directions with s > τ·s₀ (:func:`~fkev_slepc.periodic.reduce.compress`), τ running through
``THRESHOLDS`` = 1e-1, 1e-2, ..., 1e-10; a τ that adds no direction is skipped (it would repeat
the level and show a false zero change). When the pool is used up (τ = 1e-10 reached) the pool
doubles (2r modes per angle) and τ starts again, each level strictly larger than the last, up
to ``max_basis`` vectors. A basis that spans every DOF is the full model (the projection is then
a change of variables): its truncation error is zero.

**The truncation measures** between two successive levels (:func:`measures`), reported
separately:

* ``max_abs``: |Δ max|μ||/max|μ|, the relative change of the amplitude factor per revolution
  that decides the verdict (absolute near max|μ| = 1; undamped and stable it is round-off: the
  Galerkin projection of a Lagrangian system is Lagrangian, so every reduced step is symplectic
  and |μ| = 1 at every level);
* ``growth_rate``: |Δ max Re s| (1/s), the same information as a growth rate;
* ``frequency``: the largest relative change of the retained cycle-mean Floquet frequencies
  (the lowest ``retained`` pairs by |Im s| unwrapped, ``retained`` = the pool's first r),
  compared **folded**, f = |arg μ|·|Ω|/2π ∈ [0, |Ω|/2] (:func:`folded`), the two levels' pairs
  matched on f (least total change), each change relative to the finer level's unwrapped
  frequency. Unwrapped Im s is defined modulo |Ω| only, and the Rayleigh-quotient pick of its
  branch can differ from level to level for one pair (Bahgat–Willmert, 500 rad/s, 2 modes per
  link: 2909.96 = 6Ω − 90.04 at 4 elements per link, 2592.70 = 5Ω + 92.70 at 8): the unwrapped
  values differ by 317 rad/s where the multiplier's phase moved by 2.66 rad/s.

Multipliers are not compared directly: their phases are 2πω̄/Ω mod 2π, so a frequency error ε
moves μ by about 2πεω̄/Ω, meaningless for stability.

**Convergence.** :func:`converge` stops at the first level whose ``max_abs`` and ``frequency``
changes are both ≤ ``tol`` for two successive pairs of levels (one small change can be a
coincidence of a sequence that has not converged: Turcic–Midha at 2 elements per link, 60 rad/s,
changed max|μ| by 3.3e-4 from 9 to 11 vectors while 11 were still 5.5e-4 from the full model),
and returns that (finest) level's result with the larger of the two pairs' changes, measure by
measure, as its truncation error estimate. When ``max_basis`` or the whole pool of the model
is reached first it returns the last level with the last measured changes and
``converged = False``: the error is reported, never hidden.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fkev_slepc.periodic.ladder import climb
from fkev_slepc.periodic.magnus import match_multipliers
from fkev_slepc.periodic.settings import DEFAULTS, resolve_reduce  # noqa: F401 (resolve_reduce: exported here too)

THRESHOLDS = tuple(10.0 ** -k for k in range(1, 11))
REDUCE_TOL = DEFAULTS.reduce_tol  # |Δ max|μ|| and the relative frequency change that end the sequence
AUTO_MODES = DEFAULTS.auto_modes  # modes per angle of the first pool
AUTO_ANGLES = DEFAULTS.basis_angles  # pool angles over a revolution
AUTO_MIN_STEPS = DEFAULTS.auto_min_steps  # ``reduce="default"``: reduced where the full model needs this many steps
LINKS_STEP_RATIO = DEFAULTS.links_step_ratio  # ... on link components where their level needs 1/4 of those or fewer


@dataclass(frozen=True)
class Truncation:
    """Truncation error of a reduced monodromy: the changes from the previous basis level."""

    max_abs: float  # |Δ max|μ||/max|μ|
    growth_rate: float  # |Δ max Re s|, 1/s
    frequency: float  # largest relative change of the retained Floquet frequencies
    converged: bool  # both changes ≤ tol twice in a row (or the basis spans every DOF)
    tol: float
    levels: tuple = ()  # (basis size, max|μ|, max Re s) of every level computed, coarse to fine

    @property
    def value(self) -> float:
        """The larger of the two convergence measures (|Δ max|μ||, relative Δ frequency)."""
        return float(max(self.max_abs, self.frequency))


def link_modes(reduce) -> int | None:
    """N of a resolved ``"links:N"``, None for any other value."""
    return int(reduce[6:]) if isinstance(reduce, str) and reduce.startswith("links:") else None


def moving_modes(reduce) -> int | None:
    """R of a resolved ``"moving:R"``, None for any other value."""
    return int(reduce[7:]) if isinstance(reduce, str) and reduce.startswith("moving:") else None


def retained_frequencies(exponents: np.ndarray, retained: int) -> np.ndarray:
    """The ``retained`` lowest Floquet frequencies |Im s| (one per conjugate pair), rad/s."""
    return np.sort(np.abs(np.asarray(exponents).imag))[::2][:retained]


def folded(freq, omega: float) -> np.ndarray:
    """The branch-free Floquet frequency of a pair, |arg μ|·|Ω|/2π ∈ [0, |Ω|/2] rad/s, from any
    unwrapped |Im s| (``freq``, rad/s) at crank speed ``omega`` (rad/s)."""
    r = np.mod(np.asarray(freq, dtype=float), abs(omega))
    return np.minimum(r, abs(omega) - r)


def measures(coarse, fine, retained: int) -> tuple[float, float, float]:
    """(|Δ max|μ||/max|μ|, |Δ max Re s|, largest relative Δ of the retained frequencies) of two
    levels; the frequencies compared folded and matched (see the module docstring)."""
    return (float(abs(coarse.max_abs - fine.max_abs) / max(fine.max_abs, 1e-300)),
            float(abs(np.max(coarse.exponents.real) - np.max(fine.exponents.real))),
            frequency_change(coarse.exponents, fine.exponents, fine.omega, retained))


def frequency_change(coarse, fine, omega: float, retained: int) -> float:
    """The largest relative change of the ``retained`` lowest Floquet frequencies between two
    results' exponents (1/s), compared folded and matched, each relative to ``fine``'s unwrapped
    frequency (the ``frequency`` measure of the module docstring; also the Magnus step-count
    criterion's second measure, fkev_slepc/periodic/floquet.py). inf when there is none."""
    fa, fb = (retained_frequencies(x, retained) for x in (coarse, fine))
    n = min(fa.size, fb.size)
    ga, gb = folded(fa[:n], omega), folded(fb[:n], omega)
    i, j = match_multipliers(ga, gb)
    rel = np.abs(ga[i] - gb[j]) / np.maximum(fb[:n][j], 1e-300)
    return float(np.max(rel)) if n else float("inf")


def basis_levels(pool, compress, n_dof: int, modes: int, max_basis: int | None = None, max_modes: int | None = None):
    """The bases of the basis rule of the module docstring, coarse to fine, built lazily: ``pool(r)`` ->
    the (n, k) pool of r modes per angle (or per link, or the moving basis of r modes), ``compress(pool, τ)``
    -> V̂ (the identity for the link components and the moving basis: r then doubles level by level);
    each level strictly larger than the last, at most ``max_basis`` vectors (default n_dof), r at most
    ``max_modes`` (default n_dof − 1)."""
    cap = n_dof if max_basis is None else min(int(max_basis), n_dof)
    top = n_dof - 1 if max_modes is None else int(max_modes)
    r, last = int(modes), None
    while True:
        P = pool(r)
        for tau in THRESHOLDS:
            V = compress(P, tau)
            size = V.shape[1]
            if last is not None and size <= last:
                continue
            if size > cap:
                return
            last = size
            yield V
        if not (r < top and (last is None or last < cap)):
            return
        r = min(2 * r, top)


def converge(solve, levels, n_dof: int, *, tol: float = REDUCE_TOL, retained: int = AUTO_MODES, confirm: bool = True,
             fixed: bool = False):
    """(result, :class:`Truncation`): the one reduction ladder (fkev_slepc/periodic/ladder.py) over the
    bases ``levels`` (:func:`basis_levels`, or two bases with ``fixed``: the second measured from the
    first, the result), ``solve(V̂)`` -> a reduced Floquet result, the changes :func:`measures` of the ``retained``
    lowest Floquet frequencies, max|μ| and the frequencies deciding; ``confirm`` False: the first level
    pair within ``tol`` ends the sequence (the moving basis, whose error falls by an order or more per
    doubling, fkev_slepc/periodic/moving.py), not two in a row. A basis of n_dof vectors is the full model
    (truncation zero). ValueError when no level fits (``max_basis`` below the first)."""
    c = climb(levels, solve, lambda a, b: measures(a, b, retained), tol, decisive=(0, 2), confirm=confirm,
              whole=lambda V: V.shape[1] == n_dof, fixed=fixed)
    if c is None:
        raise ValueError("max_basis: no basis level fits in it (the first has more vectors)")
    levels = tuple((r.basis, r.max_abs, float(np.max(r.exponents.real))) for _, r, _ in c.rungs)
    m = (0.0, 0.0, 0.0) if c.exact else c.changes or (np.inf, np.inf, np.inf)
    return c.result, Truncation(*m, bool(c.converged), tol, levels)
