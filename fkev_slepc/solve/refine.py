"""Eigenpairs of the accurate operator from the solver's own subspace (docs/engine.md, "Right pairs at any mesh").

SLEPc's pairs satisfy the *assembled* QEP, whose K has lost ~ε·n_el⁴ of the low modes (its
entries are EI/l³; model/energy.py). They are made pairs of the model's accurate operator
P(λ) = λ²M + λC + K_s + K_rest, K_s applied from element strains (StagedStiffness), by a
Rayleigh-Ritz projection onto the span of the solver's converged vectors, enlarged while needed
by the corrections K⁻¹P(λ)x of the reported pairs (a block Davidson step preconditioned by the
factorization of the assembled K that SLEPc's shift-and-invert already holds):

    V real orthonormal,  (λ² VᵀMV + λ VᵀCV + VᵀKV) z = 0,  x = V z,  V ← [V, K⁻¹P(λ)x].

VᵀK_sV comes from the element strains (E ᵀ diag(w) E, accurate to ~ε·n_el² like xᴴK_s x), the
projected QEP is solved inverted (ν = α/λ, so that its smallest λ are its best-determined), and
a real basis keeps its eigenvalues in exact conjugate pairs. The assembled K only preconditions:
its error slows the enlargement, it does not enter the pairs. Each reported pair is judged by
the step one more correction would make, ‖x - K⁻¹P(λ)x‖ against x after scaling both to the
pivot of x (:func:`~fkev_slepc.solve.acceptance.polished_pair_error` with K⁻¹ for P(σ)⁻¹):
O(1) for a wrong pair, at the round-off floor for a right one. A pair within
``settings.polish_above`` is not corrected further.

Measured (Bahgat-Willmert, θ = 0°, Ω = 500 rad/s, ``full``, 5,600 el/link, 50,400 DOFs): TOAR's
f₁ 229.364 Hz (pair error 0.68); the projection onto TOAR's 14 vectors 234.38636 Hz; one
enlargement 234.3863135 Hz, the 2,000-el/link value to 4e-11 (docs/engine.md).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la

from fkev_slepc.model.qep import GYROSCOPIC, LINEAR_SYMMETRIC, QEP
from fkev_slepc.solve.acceptance import real_times
from fkev_slepc.solve.modes import reported
from fkev_slepc.solve.thresholds import SolveSettings

_DEFAULT = SolveSettings()
_DROP = 1e-6  # a new direction whose part outside the basis is below this (relative) is dropped
_SYMMETRIC_K = (GYROSCOPIC, LINEAR_SYMMETRIC)  # model/operators.py classify
_STALL = 0.5  # the worst correction must shrink by this factor per enlargement, else: the floor


class Subspace:
    """A real basis V of the accurate operator's projection, orthonormal in the coordinates the
    engine balanced (x = D x_b, ``d``: D's diagonal, dense.balance): the projected QEP is then an
    orthogonal transformation of the balanced one, as well scaled (a full basis reproduces the
    dense engine's problem; V orthonormal in the model's own DOFs mixed translations and rotations
    and lost 1e-10 of the higher modes of the 30-DOF thesis mesh).

    Kept: V, the element strains of V (K_s's part of VᵀKV is their energy form, ΣEᵀdiag(w)E) and
    the projected matrices; K_rest, M and C are applied as assembled (no cancellation: their
    terms are of the size of λ²M). Grown in blocks into preallocated arrays; only the new columns
    are applied, and each growth reads the stored basis twice (at 50,400 DOFs each pass over an
    (n, m) block costs as much as applying a sparse matrix to it).
    """

    def __init__(self, qep: QEP, capacity: int, d: np.ndarray | None = None):
        self.q, self.m = qep, 0
        self.d = np.ones(qep.n) if d is None else np.asarray(d, dtype=float)
        self.w = qep.staged.w.reshape(-1)
        self._Vb = np.empty((qep.n, capacity), order="F")  # V/d, orthonormal; column blocks contiguous
        self._V = np.empty((qep.n, capacity), order="F")
        self._E = np.empty((self.w.size, capacity), order="F")  # element strains of V, flattened
        terms = ("K", "M") if qep.damping is None else ("K", "M", "C")
        self._P = {t: np.empty((capacity, capacity)) for t in terms}

    Vb = property(lambda self: self._Vb[:, : self.m])
    V = property(lambda self: self._V[:, : self.m])
    size = property(lambda self: self.m)

    def projected(self, term: str):
        """VᵀAV of ``term`` 'K', 'M' or 'C' (None without C)."""
        return self._P[term][: self.m, : self.m] if term in self._P else None

    def add(self, W: np.ndarray) -> int:
        """Add the part of the real columns W outside the basis; returns the number of new columns."""
        Wb = _complement(self.Vb, np.asarray(W, dtype=float) / self.d[:, None])
        k = min(Wb.shape[1], self._Vb.shape[1] - self.m)
        if not k:
            return 0
        q, Wb, a, b = self.q, Wb[:, :k], self.m, self.m + k
        W = self.d[:, None] * Wb
        E = q.staged.strains(W).reshape(-1, k)
        wE = self.w[:, None] * E
        AW = {"K": q.stiffness_rest @ W, "M": q.mass @ W}  # K: its assembled rest (K_s from E)
        if "C" in self._P:
            AW["C"] = q.damping @ W
        corner = {t: W.T @ AW[t] for t in AW}
        corner["K"] += E.T @ wE
        for t, P in self._P.items():
            P[a:b, a:b] = corner[t]
        if a:
            self._cross(W, wE, AW)
        self._Vb[:, a:b], self._V[:, a:b], self._E[:, a:b] = Wb, W, E
        self.m = b
        return k

    def _cross(self, W: np.ndarray, wE: np.ndarray, AW: dict) -> None:
        """The blocks VᵀAW and WᵀAV of the projections, with one pass over V for all of them
        (WᵀAV = (VᵀAᵀW)ᵀ; (WᵀA)ᵀ is Aᵀ W without a CSC copy; M is symmetric, and a gyroscopic
        problem's K_rest symmetric and its C skew)."""
        q, a, b, k = self.q, self.m, self.m + W.shape[1], W.shape[1]
        gyro = q.kind == GYROSCOPIC
        rest_t = AW["K"] if q.kind in _SYMMETRIC_K else (W.T @ q.stiffness_rest).T
        mats = [AW["K"], rest_t, AW["M"]]
        if "C" in AW:
            mats += [AW["C"], -AW["C"] if gyro else (W.T @ q.damping).T]
        VA = self.V.T @ np.hstack(mats)
        G = self._E[:, :a].T @ wE  # K_s is symmetric: its two off-diagonal blocks are G and Gᵀ
        right = {"K": G + VA[:, :k], "M": VA[:, 2 * k:3 * k], "C": VA[:, 3 * k:4 * k]}
        below = {"K": G.T + VA[:, k:2 * k].T, "M": VA[:, 2 * k:3 * k].T, "C": VA[:, 4 * k:].T}
        for t, P in self._P.items():
            P[:a, a:b], P[a:b, :a] = right[t], below[t]

    def ritz(self, count: int, alpha: float):
        """The ``count`` Ritz pairs nearest 0: (λ, Z) with x = V Z; the projected QEP is solved as
        ν² K + ν αC + α²M = 0 in ν = α/λ (the linearization's largest ν are its most accurate)."""
        m = self.size
        Z0, I = np.zeros((m, m)), np.eye(m)
        Mp = self.projected("M")
        norm = alpha**2 * la.norm(Mp, 1)  # the scaling of dense.qz: blocks of the size of I
        Cp = Z0 if "C" not in self._P else self.projected("C") * (alpha / norm)
        A = np.block([[Z0, I], [-Mp * (alpha**2 / norm), -Cp]])
        B = np.block([[I, Z0], [Z0, self.projected("K") / norm]])
        nu, W = la.eig(A, B)
        order = np.argsort(-np.abs(np.where(np.isfinite(nu), nu, 0)))[:count]
        nu, Z = nu[order], W[:m, order]
        return alpha / nu, Z / np.linalg.norm(Z, axis=0)

    def vectors(self, Z: np.ndarray) -> np.ndarray:
        """x = V z per column of the complex Z (one real product: Z's parts side by side)."""
        return real_times(self.V, Z)


def residuals(qep: QEP, lam: np.ndarray, X: np.ndarray) -> np.ndarray:
    """P(λ_j) x_j with K_s applied from the element strains of x_j (model/energy.py)."""
    R = qep.staged.apply(X) + real_times(qep.stiffness_rest, X) + real_times(qep.mass, X) * lam**2
    return R if qep.damping is None else R + real_times(qep.damping, X) * lam


def _complement(V: np.ndarray, W: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the part of span(W) outside span(V): W's columns scaled to 1,
    projected out of V (twice when the first pass cancelled: "twice is enough", Kahan-Parlett),
    then orthonormalized from their Gram matrix, twice (CholQR2; at 50,400 DOFs the Gram of 12
    columns costs 0.7 ms, their QR 8-20 ms, their SVD 28 ms). Directions whose new part is
    below _DROP of a unit column are dropped."""
    norms = np.linalg.norm(W, axis=0)
    W = W[:, norms > 0] / norms[norms > 0]
    for _ in range(2):
        before = np.linalg.norm(W, axis=0)
        W = W - V @ (V.T @ W)
        if np.all(np.linalg.norm(W, axis=0) > 0.7 * before):
            break
    if not W.shape[1]:
        return W
    s2, Q = la.eigh(W.T @ W)
    keep = s2 > _DROP**2  # the columns were unit before the projection
    if not keep.any():
        return W[:, :0]
    W = W @ (Q[:, keep] / np.sqrt(s2[keep]))
    s2, Q = la.eigh(W.T @ W)  # again: after one pass W is orthonormal only to ~ε·κ² (CholQR2)
    return W @ (Q / np.sqrt(s2))


def corrections(X: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Per column: the relative change of direction from x to x - c, both scaled to the pivot
    (largest entry) of x (acceptance.polished_pair_error, batched)."""
    piv = np.argmax(np.abs(X), axis=0)
    cols = np.arange(X.shape[1])
    Y = X - C
    with np.errstate(divide="ignore", invalid="ignore"):
        Xn, Yn = X / X[piv, cols], Y / Y[piv, cols]
        out = np.linalg.norm(Yn - Xn, axis=0) / np.linalg.norm(Xn, axis=0)
    return np.where(np.isfinite(out), out, np.inf)


def refine(qep: QEP, lam: np.ndarray, X: np.ndarray, n_modes: int, solve,
           settings: SolveSettings = _DEFAULT, d: np.ndarray | None = None):
    """The solver's pairs (``lam``, ``X``: every converged one) replaced by Ritz pairs of the
    accurate operator; returns (λ, X, errors, enlargements).

    ``solve`` applies K⁻¹ (the assembled K) to a complex (n, k) block; ``d``: the engine's
    balancing (dense.balance), for the basis (:class:`Subspace`). The reported pairs (the
    ``n_modes`` lowest frequencies and the real eigenvalues) get the correction measure
    (:func:`corrections`) as their error; the others, which decide nothing, NaN (not judged,
    as the dense engine's). The basis grows by the corrections of the reported
    pairs above ``settings.polish_above`` until none is left, or the worst stops shrinking
    (the round-off floor), or ``settings.polish_max_steps`` enlargements.
    """
    count = lam.size
    upper = lam.imag >= 0  # one vector per conjugate pair: the real basis spans both
    n_rep = min(n_modes, count) + int(np.count_nonzero(np.abs(lam.imag) <= settings.imag_tol * np.abs(lam)))
    sub = Subspace(qep, 2 * int(upper.sum()) + 2 * n_rep * settings.polish_max_steps, d)
    sub.add(np.hstack([X[:, upper].real, X[:, upper].imag]))
    alpha = float(np.median(np.abs(lam[lam != 0]))) if np.any(lam != 0) else 1.0
    best, steps = None, 0  # best: (worst correction, λ, Z, used, their corrections)
    while True:
        lam, Z = sub.ritz(min(count, 2 * sub.size), alpha)
        osc, is_real = reported(lam, max(n_modes, 1), settings.imag_tol)
        used = np.concatenate([osc, np.flatnonzero(is_real)])
        Xu = sub.vectors(Z[:, used])
        C = solve(residuals(qep, lam[used], Xu))
        err_used = corrections(Xu, C)
        open_ = err_used > settings.polish_above
        worst = float(err_used.max()) if used.size else 0.0
        stalled = best is not None and not worst < _STALL * best[0]
        if best is None or worst < best[0]:
            best = (worst, lam, Z, used, err_used)
        if not open_.any() or steps >= settings.polish_max_steps or stalled:
            break  # stalled: the round-off floor of the accurate operator; the best step is kept
        if not sub.add(np.hstack([C[:, open_].real, C[:, open_].imag])):
            break
        steps += 1
    _, lam, Z, used, err_used = best
    errors = np.full(lam.size, np.nan)  # the pairs a point does not report are not judged
    errors[used] = err_used
    Z = np.vstack([Z, np.zeros((sub.size - Z.shape[0], Z.shape[1]))])  # the best step's basis: a leading part
    return lam, sub.vectors(Z), errors, steps
