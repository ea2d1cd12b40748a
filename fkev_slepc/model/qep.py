"""The quadratic eigenproblem handed to a solver, and its solution.

``(λ² M + λ C + K) x = 0``. All three matrices of a model share one CSR sparsity pattern
(the union of every term, explicit zeros kept), so PETSc matrices can be updated in place.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fkev_slepc.model.energy import StagedStiffness

# Problem kinds, from the term flags (see operators.classify):
LINEAR_SYMMETRIC = "linear_symmetric"  # C = 0, K = Kᵀ: generalized symmetric-definite in μ = -λ²
LINEAR = "linear"  # C = 0, K non-symmetric (tangential term): generalized non-symmetric in μ
GYROSCOPIC = "gyroscopic"  # C skew, K symmetric
GENERAL = "general"  # C skew and K non-symmetric
KINDS = (LINEAR_SYMMETRIC, LINEAR, GYROSCOPIC, GENERAL)

# A point whose reported pairs have pair_error above this is not converged, whatever the
# solver's own test said (option -fkev_max_pair_error, or max_pair_error in [solver.petsc]).
# Measured (README, "SLEPc engine"): right pairs give 1e-14..1e-5 up to a few thousand DOFs,
# wrong pairs 0.1..1; on over-refined models (>~1e4 DOFs) every unpolished pair drifts toward 1,
# because the round-off in the assembled K grows like n_el⁴. Models keep K_s factored, and the
# engines polish such pairs (solve/polish.py), judged by polished_pair_error instead.
MAX_PAIR_ERROR = 1e-3
# ... and no more than this multiple of what one-ulp changes of the matrix entries explain
# (pair_error_floor): the accuracy contract of docs/numerical-stability.md. Measured there
# (scripts/stress.py random, conditioning, toggle, refine): pairs of both engines within a few
# times their frequency floor reach 8.8e6 (a dense pair 1e-4° before a toggle; refined meshes
# stay below 10); the old dense eigh(K, M) of a rhombus with a rigid crank and a 1e4 kg mass
# (f₁ 6.6e-6 wrong) had 6.5e8.
MAX_FLOOR_RATIO = 1e8


@dataclass(frozen=True)
class QEP:
    """One instantaneous-structure eigenproblem. ``damping`` is None when there is no C."""

    mass: sp.csr_matrix
    damping: sp.csr_matrix | None
    stiffness: sp.csr_matrix
    kind: str
    # K = K_s + stiffness_rest with K_s also kept factored (model/energy.py): lets a solution be
    # polished beyond the round-off of the assembled K (solve/polish.py). None when not built.
    staged: StagedStiffness | None = None
    stiffness_rest: sp.csr_matrix | None = None

    @property
    def n(self) -> int:
        return self.mass.shape[0]


@dataclass(frozen=True)
class Divergence:
    """Whole-spectrum divergence verdict of one QEP (solve/stability.py, docs/stability.md).

    ``divergent``: the QEP has a real eigenvalue λ > 0 somewhere in its spectrum.
    ``proven``: decided by a certificate (a Cholesky factorization or a determinant sign),
    not by locating eigenvalues. ``real_eigenvalues``: the positive real eigenvalues located
    (1/s, ascending; may be empty for a proven divergence whose values were not located).
    ``method`` says how, ``scope`` which part of the spectrum the verdict covers.
    """

    divergent: bool
    proven: bool
    real_eigenvalues: np.ndarray
    method: str
    scope: str = "whole spectrum"


@dataclass(frozen=True)
class EigenSolution:
    """Eigenpairs of a QEP as a solver returned them (unsorted, unfiltered).

    ``errors`` holds :func:`pair_error` for each pair. ``vectors`` is (n, k) or None.
    ``converged`` is False when the solver stopped short of what was asked.
    """

    eigenvalues: np.ndarray  # complex (k,)
    errors: np.ndarray  # float (k,)
    vectors: np.ndarray | None
    converged: bool
    solver: str
    message: str = ""
    divergence: Divergence | None = None  # None: no whole-spectrum check was made


def pair_error(qep: QEP, lam: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Relative residual of eigenpairs that exposes wrong pairs on stiff models.

    η = ‖P(λ)x‖ / (‖Kx‖ + |λ|‖Cx‖ + |λ|²‖Mx‖), per column of ``X``.

    SLEPc's backward error divides by ‖K‖‖x‖, and ‖K‖ reaches 1e19 on refined meshes while
    the low modes hardly load the stiffest directions, so it reports ~1e-15 for pairs that are
    100 % wrong. Scaling by the norms of the *products* keeps η = O(1) for a wrong pair
    (its residual is of the size of the terms it should balance) and O(ε) for a right one.
    """
    return pair_error_and_floor(qep, lam, X, floor=False)[0]


def pair_error_and_floor(qep: QEP, lam: np.ndarray, X: np.ndarray, floor: bool = True):
    """(:func:`pair_error`, :func:`pair_error_floor` or None) of the columns of ``X``, sharing
    the products Kx, Cx, Mx (on small dense models their overhead is a fair part of a solve).

    ``qep``'s matrices may also be stacks (k, n, n), one per column of X: the pairs of several
    problems of one model judged in one go (solve/dense.py ``DenseEngine.solve_many``)."""
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
    with np.errstate(invalid="ignore", divide="ignore"):
        err = np.where(den > 0, res / den, np.inf)
        return err, (np.where(den > 0, np.finfo(float).eps * num / den, np.inf) if floor else None)


def _apply(A, X: np.ndarray) -> np.ndarray:
    """A @ X, or column by column when A stacks one matrix per column of X: (k, n, n)."""
    if getattr(A, "ndim", 2) == 3:
        return np.matmul(A, X.T[:, :, None])[:, :, 0].T
    return A @ X


def staged_products(qep: QEP, x: np.ndarray):
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


def polished_pair_error(qep: QEP, lam: complex, x: np.ndarray, solve, products=None) -> float:
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


def pair_error_floor(qep: QEP, lam: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The pair error that one-ulp changes of the matrix entries alone can cause, per pair.

    η₀ = ε (‖|K||x|‖ + |λ|‖|C||x|‖ + |λ|²‖|M||x|‖) / (‖Kx‖ + |λ|‖Cx‖ + |λ|²‖Mx‖): a pair that
    is exact for some matrices within one unit in the last place of the assembled ones (the
    definition of "accurate to its conditioning") has :func:`pair_error` ≲ η₀. It is large when
    the products cancel: low modes of refined meshes, stiff links the mode hardly loads.
    """
    return pair_error_and_floor(qep, lam, X)[1]
