"""Polishing eigenpairs beyond the round-off floor of the assembled K (docs/accuracy.md §2).

On fine meshes the assembled K_s loses ~ε·n_el⁴ of the low modes (its entries are EI/l³, the
forces of a smooth mode are n_el⁴ times smaller), so every engine's pairs drift as the mesh is
refined (f₁ of Bahgat-Willmert off 4e-5 at 1,024 elements per link). Each reported pair is
polished by residual inverse iteration (Neumaier 1985),

    λ_{k+1}:  x_kᴴ P(λ) x_k = 0 (the root nearest λ_k),     x_{k+1} = x_k - P(σ)⁻¹ P(λ_{k+1}) x_k,

with σ the engine's eigenvalue and P(σ) factored once (scipy's SuperLU, complex). The factored
P(σ) only has to be a contraction; the accuracy comes from the residual P(λ)x and the stiffness
form xᴴKx, both evaluated with K_s kept factored (model/energy.py: element strains first). The
pair error of a polished pair is :func:`~fkev_slepc.solve.acceptance.polished_pair_error`: the size of
the step a further iteration would take (O(1) for a wrong pair, ~ε·n_el² for a right one).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fkev_slepc.model.qep import QEP
from fkev_slepc.solve.acceptance import pair_error_floor, polished_pair_error, staged_products, staged_residual
from fkev_slepc.solve.thresholds import SolveSettings
from fkev_slepc.solve.modes import mac, reported
from fkev_slepc.solve.refine import refine

_DEFAULT = SolveSettings()
# The projection (refine.py) is used when the solver's pairs span at most this share of the
# space. On the thesis meshes (15-30 DOFs; a heavy mass at B, tests/test_stress.py) the basis is
# the whole space, the projection is a dense QZ of it, 4e-13 off the Newton-refined frequencies
# where the per-pair polish is within 1e-13; there an LU per pair costs microseconds.
_PROJECTION_MAX_SHARE = 0.25


def _quadratic_root(x: np.ndarray, products, near: complex) -> complex:
    """The root nearest ``near`` of xᴴ(λ²M + λC + K)x = 0 (``products``: x's
    :func:`~fkev_slepc.solve.acceptance.staged_products`)."""
    _, Mx, Cx, xKx = products
    roots = np.roots([np.vdot(x, Mx), 0.0 if Cx is None else np.vdot(x, Cx), xKx])
    return complex(roots[np.argmin(np.abs(roots - near))])


def polish_pair(qep: QEP, lam: complex, x: np.ndarray,
                settings: SolveSettings = _DEFAULT) -> tuple[complex, np.ndarray, float]:
    """One eigenpair polished by residual inverse iteration; returns (λ, x, pair error).

    When the iteration stalls above ``settings.polish_above``, P is factored again at the improved
    λ, up to ``settings.polish_max_restarts`` times. Measured on Bahgat-Willmert with 4,000 cubic elements per
    link (60,000 DOFs, θ = 10°, Ω = 1000 rad/s, full): TOAR's f₁ pair had pair error 0.12; one
    factorization, stopping when a step shrank by less than 0.3, left 5.8e-4 and f₁ 6.8e-6 off
    (flagged not_converged); going on while steps shrink by 0.9 and refactoring gives 5.5e-9 and
    f₁ within 3.8e-10 of the Richardson reference, in 2.3 s.

    Raises
    ------
    RuntimeError
        When P(σ) is exactly singular (SuperLU); the caller keeps the engine's pair.
    """
    x = np.asarray(x, dtype=complex).ravel()
    x = x / x[np.argmax(np.abs(x))]
    for _ in range(1 + settings.polish_max_restarts):
        lam, x, err = _iterate(qep, lam, x, settings)
        if err <= settings.polish_above:
            break
    return lam, x, err


def _iterate(qep: QEP, lam: complex, x: np.ndarray, settings: SolveSettings) -> tuple[complex, np.ndarray, float]:
    """Residual inverse iteration with P(σ) factored once at σ = ``lam``."""
    P = qep.stiffness + lam * lam * qep.mass
    if qep.damping is not None:
        P = P + lam * qep.damping
    lu = spla.splu(sp.csc_matrix(P, dtype=complex))
    prev = np.inf
    for _ in range(settings.polish_max_steps):
        products = staged_products(qep, x)  # each computed once per step
        lam = _quadratic_root(x, products, lam)
        x_new = x - lu.solve(staged_residual(products, lam))
        x_new = x_new / x_new[np.argmax(np.abs(x_new))]
        step = np.linalg.norm(x_new - x) / np.linalg.norm(x_new)
        x = x_new
        # converged, or no longer contracting (noise level). A slow contraction goes on: on very
        # fine meshes the LU of P(σ) is itself only a few digits good and contracts by ~0.5/step
        if step < settings.polish_step_tol or step > 0.9 * prev:
            break
        prev = step
    products = staged_products(qep, x)
    lam = _quadratic_root(x, products, lam)
    return lam, x, float(polished_pair_error(qep, lam, x, lu.solve, products))


def polish(qep: QEP, lam: np.ndarray, X: np.ndarray, errors: np.ndarray, which: np.ndarray,
           settings: SolveSettings = _DEFAULT):
    """Polish the pairs ``which`` (indices into ``lam``); returns new (lam, X, errors, note).

    The conjugate partner of a polished pair (a real QEP's eigenvalues come in pairs) gets the
    conjugate value. A pair whose polish fails keeps the engine's values and error. A polish is a
    refinement, not a search: a pair that moved more than ``settings.polish_max_move`` (relative
    to |λ|) keeps the engine's values, and pairs polished onto one mode (eigenvalues within
    1e-6 and vectors with MAC > ``settings.duplicate_mac``) are flagged; ``note`` says so ('' if
    neither happened), for the engine to mark the point not converged.
    """
    lam, X, errors = lam.astype(complex), X.astype(complex), np.asarray(errors, dtype=float).copy()
    start = lam.copy()
    moved, polished = [], []
    for j in np.asarray(which, dtype=int):
        try:
            new, x, err = polish_pair(qep, lam[j], X[:, j], settings)
        except RuntimeError:
            continue
        move = abs(new - start[j]) / max(abs(start[j]), abs(new))
        if not move <= settings.polish_max_move:  # NaN too
            moved.append((start[j], new, move))
            continue
        partner = np.argmin(np.abs(lam - np.conj(lam[j])))
        if partner != j and abs(lam[partner] - np.conj(lam[j])) <= 1e-6 * abs(lam[j]):
            lam[partner], X[:, partner], errors[partner] = np.conj(new), x.conj(), err
        lam[j], X[:, j], errors[j] = new, x, err
        polished.append(j)
    notes = []
    if moved:
        a, b, m = max(moved, key=lambda t: t[2])
        notes.append(f"the polish moved {len(moved)} eigenvalue(s) by more than {settings.polish_max_move:g} relative "
                     f"(worst {a:.6g} -> {b:.6g} 1/s): the engine's pairs kept")
    dup = _collapsed(lam, X, np.asarray(polished, dtype=int), settings.duplicate_mac)
    if dup:
        notes.append(dup)
    return lam, X, errors, "; ".join(notes)


def _collapsed(lam: np.ndarray, X: np.ndarray, which: np.ndarray, max_mac: float) -> str:
    """'' or why two of the pairs ``which`` are one pair: (nearly) equal eigenvalues whose
    vectors are parallel (MAC > ``max_mac``). Independent vectors of a double eigenvalue pass."""
    if which.size < 2:
        return ""
    lw, xw = lam[which], X[:, which]
    same = np.abs(lw[:, None] - lw[None, :]) <= 1e-6 * np.abs(lw)[:, None]
    m = np.triu(np.where(same, mac(xw, xw), 0.0), 1)
    i, j = np.unravel_index(np.argmax(m), m.shape)
    if not m[i, j] > max_mac:
        return ""
    return (f"two polished pairs converged onto one eigenpair ({lw[i]:.6g} 1/s, MAC {m[i, j]:.4f}): "
            "a mode reported twice, eigenpairs not trustworthy")


def polish_reported(qep: QEP, lam: np.ndarray, X: np.ndarray, errors: np.ndarray, n_modes: int,
                    settings: SolveSettings = _DEFAULT, by_floor: bool = False, solve=None, d=None):
    """Polish the pairs a point reports (the ``n_modes`` lowest frequencies and the real
    eigenvalues, real by ``settings.imag_tol``) that ask for it; every engine calls this before
    its pair-error check. Returns (lam, X, errors, note): ``note`` is '' or why the polish
    could not be trusted (:func:`polish`).

    A reported pair is polished when its plain pair error exceeds ``settings.polish_above`` or,
    with ``by_floor``, exceeds ``settings.polish_ratio`` times what one-ulp changes of the
    matrices explain (:func:`~fkev_slepc.solve.acceptance.pair_error_floor`; the SLEPc engine
    asks for it). When a reported frequency is polished all of them are: an unpolished
    one carries a spurious real part of the size of its round-off (measured: 2.2e-4 1/s on a
    gyroscopic Bahgat-Willmert point at 2,000 elements per link, whose true real parts are 0),
    and ζ and max Re λ, the stability verdict, are taken over the reported modes and the real
    eigenvalues (solve/modes.py ``postprocess``). The engine's other pairs (SLEPc returns a few
    more than asked) are not polished: they are not reported and decide nothing (at 50,400 DOFs
    polishing them too meant 6 polished pairs per point instead of 4).

    Real eigenvalues: near a toggle position the dense engine's values are right but its vectors
    had pair errors up to 0.97 (QZ's), then up to 7e-6 = 1.5e10 times their floor (one
    inverse-iteration step), which failed the acceptance test while SLEPc's pairs of the same
    eigenvalues passed; polished they pass, within 2.2e-7 of 40-digit values of the same
    matrices (``scripts/stress.py toggle --mpmath``).
    """
    if X is None or qep.staged is None:
        return lam, X, errors, ""
    errors = np.asarray(errors, dtype=float)
    which = polish_wanted(qep, lam, X, errors, n_modes, settings, by_floor)
    if not which.size:
        return lam, X, errors, ""
    if solve is not None and lam.size <= _PROJECTION_MAX_SHARE * qep.n:
        try:
            lam, X, errors, _ = refine(qep, lam, X, n_modes, solve, settings, d)
        except RuntimeError:  # K singular at this point: the per-pair polish factors P(λ) instead
            return polish(qep, lam, X, errors, which, settings)
        osc, is_real = reported(lam, max(n_modes, 1), settings.imag_tol)
        used = np.concatenate([osc, np.flatnonzero(is_real)])
        which = used[~(errors[used] <= settings.max_pair_error)]  # rare: what the projection could not fix
        if not which.size:
            return lam, X, errors, ""
    return polish(qep, lam, X, errors, which, settings)


def polish_wanted(qep: QEP, lam: np.ndarray, X: np.ndarray, errors: np.ndarray, n_modes: int,
                  settings: SolveSettings = _DEFAULT, by_floor: bool = False) -> np.ndarray:
    """Indices of the reported pairs that ask for a polish (:func:`polish_reported`'s rule; empty
    when none does): every reported frequency when one of them does, and the real eigenvalues that do."""
    errors = np.asarray(errors, dtype=float)
    above = settings.polish_above
    if not by_floor and not np.any(errors > above):  # NaN (no vector) compares False
        return np.zeros(0, dtype=int)  # the common case, decided before selecting pairs (per-point cost)
    osc, is_real = reported(lam, max(n_modes, 1), settings.imag_tol)
    used = np.concatenate([osc, np.flatnonzero(is_real)])
    need = errors[used] > above
    check = ~need  # the floor only where it can decide (at 50,400 DOFs it costs a third of a solve)
    check[: osc.size] &= not need[: osc.size].any()  # one frequency asks: all of them are polished
    if by_floor and check.any():
        idx = used[check]
        need[check] = errors[idx] > settings.polish_ratio * pair_error_floor(qep, lam[idx], X[:, idx])
    which = used[need]
    if need[: osc.size].any():
        which = np.union1d(which, osc)
    return which.astype(int)
