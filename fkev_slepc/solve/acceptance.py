"""Whether an engine's eigenpairs are right: pair errors, their one-ulp floor, the acceptance test.

Every engine judges the pairs a point reports (solve/modes.py ``reported``: the lowest
frequencies and every real eigenvalue) by :func:`check_pairs`, with the thresholds of its
:class:`~fkev_slepc.solve.thresholds.SolveSettings`. The measures accept a sparse
:class:`~fkev_slepc.model.qep.QEP` or a :class:`DenseQEP` (numpy arrays, one problem or a stack
of problems judged in one go by the dense engine).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.solve.thresholds import SolveSettings
from fkev_slepc.solve.modes import reported

_EPS = np.finfo(float).eps  # hoisted: np.finfo costs microseconds per call, check_pairs runs per point


@dataclass(frozen=True)
class DenseQEP:
    """A QEP with numpy matrices: one problem (n, n) or a stack (k, n, n), one per column of
    the pairs judged (the dense engine's batch). ``damping`` is None when there is no C."""

    mass: np.ndarray
    damping: np.ndarray | None
    stiffness: np.ndarray
    kind: str

    @property
    def n(self) -> int:
        return self.mass.shape[-1]


def pair_error(qep, lam: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Relative residual of eigenpairs that exposes wrong pairs on stiff models.

    η = ‖P(λ)x‖ / (‖Kx‖ + |λ|‖Cx‖ + |λ|²‖Mx‖), per column of ``X``.

    SLEPc's backward error divides by ‖K‖‖x‖, and ‖K‖ reaches 1e19 on refined meshes while
    the low modes hardly load the stiffest directions, so it reports ~1e-15 for pairs that are
    100 % wrong. Scaling by the norms of the *products* keeps η = O(1) for a wrong pair
    (its residual is of the size of the terms it should balance) and O(ε) for a right one.
    """
    return pair_error_and_floor(qep, lam, X, floor=False)[0]


def pair_error_and_floor(qep, lam: np.ndarray, X: np.ndarray, floor: bool = True):
    """(:func:`pair_error`, :func:`pair_error_floor` or None) of the columns of ``X``, sharing
    the products Kx, Cx, Mx (on small dense models their overhead is a fair part of a solve).

    ``qep`` may be a :class:`DenseQEP` of stacks (k, n, n), one per column of X: the pairs of
    several problems of one model judged in one go (solve/dense.py ``DenseEngine.solve_many``)."""
    lam = np.atleast_1d(np.asarray(lam, dtype=complex))
    X = np.asarray(X, dtype=complex).reshape(qep.mass.shape[-1], -1)
    terms = [(A, p) for A, p in ((qep.stiffness, 0), (qep.damping, 1), (qep.mass, 2)) if A is not None]
    AX = np.stack([_apply(A, X) for A, _ in terms])  # (term, n, pair)
    power = lam ** np.array([p for _, p in terms])[:, None]  # λ⁰, λ¹, λ² per term and pair
    weight = np.abs(power)
    den = np.sum(weight * np.linalg.norm(AX, axis=1), axis=0)
    res = np.linalg.norm(np.sum(power[:, None, :] * AX, axis=0), axis=0)
    num = None
    if floor:
        aX = np.abs(X)
        num = np.sum(weight * np.linalg.norm(np.stack([_apply(abs(A), aX) for A, _ in terms]), axis=1), axis=0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        err = np.where(den > 0, res / den, np.inf)
        return err, (np.where(den > 0, _EPS * num / den, np.inf) if floor else None)


def _apply(A, X: np.ndarray) -> np.ndarray:
    """A @ X, or column by column when A stacks one matrix per column of X: (k, n, n)."""
    if getattr(A, "ndim", 2) == 3:
        return np.matmul(A, X.T[:, :, None])[:, :, 0].T
    return real_times(A, X)


def real_times(A, X: np.ndarray) -> np.ndarray:
    """A @ X for a real (sparse or dense) A and a real or complex (n, k) X: a complex X as the
    real (n, 2k) array of its parts side by side (a view), so A is not cast to complex (at 50,400
    DOFs a sparse K times 7 complex columns: 8.1 ms cast, 5.0 ms this way)."""
    if not np.iscomplexobj(X) or np.iscomplexobj(getattr(A, "data", A)):
        return A @ X
    X = np.ascontiguousarray(X, dtype=complex)
    return np.ascontiguousarray(A @ X.view(float)).view(complex)


def pair_error_floor(qep, lam: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The pair error that one-ulp changes of the matrix entries alone can cause, per pair.

    η₀ = ε (‖|K||x|‖ + |λ|‖|C||x|‖ + |λ|²‖|M||x|‖) / (‖Kx‖ + |λ|‖Cx‖ + |λ|²‖Mx‖): a pair that
    is exact for some matrices within one unit in the last place of the assembled ones (the
    definition of "accurate to its conditioning") has :func:`pair_error` ≲ η₀. It is large when
    the products cancel: low modes of refined meshes, stiff links the mode hardly loads.
    """
    return pair_error_and_floor(qep, lam, X)[1]


def staged_products(qep, x: np.ndarray):
    """(K x, M x, C x or None, xᴴKx) of one vector with K_s applied factored (model/energy.py):
    K_s x and xᴴK_s x from one set of element strains, not from the assembled K.

    Their round-off is a perturbation of the element stresses of relative size ~ε·n_el², which
    moves the low eigenvalues only by as much; the assembled K's is ~ε·n_el⁴ of them.
    """
    x = np.asarray(x, dtype=complex).ravel()
    e = qep.staged.strains(x)
    rest = qep.stiffness_rest @ x
    Kx = qep.staged.forces(e)[:, 0] + rest
    xKx = qep.staged.energy(e, e)[0] + np.vdot(x, rest)
    return Kx, qep.mass @ x, None if qep.damping is None else qep.damping @ x, xKx


def staged_residual(products, lam: complex) -> np.ndarray:
    """P(λ)x from the :func:`staged_products` of x."""
    Kx, Mx, Cx, _ = products
    R = Kx + (lam * lam) * Mx
    return R if Cx is None else R + lam * Cx


def polished_pair_error(qep, lam: complex, x: np.ndarray, solve, products=None) -> float:
    """Pair error of a pair polished by solve/polish.py: the relative change of direction of x
    that one more residual-inverse-iteration step x - P(σ)⁻¹P(λ)x would make.

    ``solve`` applies P(σ)⁻¹ for the shift σ the polish used; ``products`` are x's
    :func:`staged_products` when the caller has them. O(1) for a wrong pair (the iteration
    would turn it toward another eigenvector), ~ε·n_el² for a right one. :func:`pair_error`
    cannot judge these pairs: on fine meshes the round-off of the assembled K alone gives them
    ~ε·n_el⁴.
    """
    x = np.asarray(x, dtype=complex).ravel()
    piv = np.argmax(np.abs(x))
    y = x - solve(staged_residual(products or staged_products(qep, x), lam))
    if y[piv] == 0:
        return float("inf")
    y, x = y / y[piv], x / x[piv]
    return float(np.linalg.norm(y - x) / np.linalg.norm(x))


def check_pairs(qep, lam: np.ndarray, X: np.ndarray, err: np.ndarray, n_modes: int,
                settings: SolveSettings) -> tuple[float, str]:
    """The acceptance test of every engine: (largest reported pair error, '' or why the pairs fail).

    A point's reported pairs (the ``n_modes`` lowest frequencies and every real eigenvalue, real
    by ``settings.imag_tol``) must have pair error ≤ ``settings.max_pair_error`` *and* ≤
    ``settings.max_floor_ratio`` times what one-ulp changes of the matrices explain
    (:func:`pair_error_floor`): accurate to their conditioning (docs/numerical-stability.md). The
    floor is at least ε (‖|A||x|‖ ≥ ‖Ax‖), so pairs with error ≤ ``max_floor_ratio``·ε pass
    without computing it (most pairs, at a fair share of a small model's solve).
    """
    osc, is_real = reported(lam, n_modes, settings.imag_tol)
    used = np.concatenate([osc, np.flatnonzero(is_real)])
    worst = float(np.asarray(err)[used].max()) if used.size else np.inf
    msg = untrustworthy(worst, settings.max_pair_error)
    ratio_max = settings.max_floor_ratio
    if not msg:
        suspect = used[np.asarray(err)[used] > 0.5 * ratio_max * _EPS]  # 0.5: the floor's own rounding
        ratio = 0.0
        if suspect.size:
            ratio = float(np.max(np.asarray(err)[suspect] / pair_error_floor(qep, lam[suspect], X[:, suspect])))
        if ratio > ratio_max:
            msg = (f"pair error {worst:.1e} is {ratio:.1e} times what one-ulp changes of the matrices explain "
                   f"(> {ratio_max:g}): eigenpairs less accurate than their conditioning allows")
    return worst, msg


def untrustworthy(worst: float, max_pair_error: float) -> str:
    """Message for a solve whose reported pairs fail the pair-error check ('' if they pass)."""
    if worst <= max_pair_error:
        return ""
    return (f"pair error {worst:.1e} > max_pair_error {max_pair_error:g}: eigenpairs not trustworthy"
            " (with -fkev_pep_type other than toar, try toar; on a very fine mesh, use fewer elements)")
