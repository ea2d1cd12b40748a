"""Stability verdicts shared by both engines: whole-spectrum divergence and damping ratios.

**Divergence** (docs/stability.md): a point is divergent iff (λ²M + λC + K)x = 0 has a real
eigenvalue λ > 0 *anywhere* in its spectrum, not only among the modes a solver was asked for.
With M symmetric positive definite and C = Ω G + C_d (G skew, C_d = α M + β K_s symmetric
positive semi-definite since α, β >= 0), a real λ > 0 with real x gives

    λ² xᵀMx + λ xᵀC_d x + xᵀK_sym x = 0,   K_sym = (K + Kᵀ)/2,

so xᵀK_sym x < 0 and λ² <= -μ_min(K_sym, M). Hence, in order:

1. **Proven stable** against divergence when K_sym is positive definite: one Cholesky
   factorization (banded, after a reverse Cuthill-McKee ordering).
2. **Proven divergent** when det K < 0: det P(0) = det K < 0 while det P(s) > 0 for
   s² > -μ_min (P(s) then has a positive-definite symmetric part), so det P has a root in
   between. The sign comes from one sparse LU.
3. Otherwise (and to report the values) the real eigenvalues are **located**: from the whole
   spectrum when the engine has it (dense engine) or a dense solve is affordable
   (n <= :data:`DENSE_LIMIT`, the same LAPACK kernel for both engines, so their verdicts
   agree); above that, among the eigenvalues the engine computed (then ``scope`` says so).

Round-off: a factorization that succeeds proves definiteness of K_sym + E with ‖E‖ of order
n·ε·‖K‖; points that close to singular K are at the divergence speed itself.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

from fkev_slepc.model.qep import QEP
from fkev_slepc.solve.protocol import Divergence
from fkev_slepc.solve.thresholds import IMAG_TOL

# Undecided points of models up to this many free DOFs get every eigenvalue by dense QZ
# (companion size 2n; measured ~0.1 s at n = 100 and a few s at n = 1000 on this machine).
DENSE_LIMIT = 1000
WHOLE = "whole spectrum"
# What every verdict of this module covers in time (docs/stability.md, "Frozen-time and cycle verdicts"):
# exp(2π Re λ/Ω) is not the growth over a revolution, the Floquet multipliers are (fkev_slepc/periodic/magnus.py).
FROZEN_TIME = ("frozen-time: the matrices held at this crank angle and speed; whether vibration grows over a "
               "crank revolution is the Floquet verdict (fkev floquet)")


def damping_ratio(lam) -> np.ndarray:
    """ζ = -Re λ / |λ| of each eigenvalue (NaN where λ is NaN or 0)."""
    lam = np.asarray(lam, dtype=complex)
    mag = np.abs(lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(mag > 0, -lam.real / np.where(mag > 0, mag, 1.0), np.nan)


def sym_positive_definite(K) -> bool:
    """Whether (K + Kᵀ)/2 is positive definite: a banded Cholesky after RCM reordering (a
    dense one for a dense K)."""
    if not sp.issparse(K):
        try:
            la.cholesky((K + K.T) * 0.5, lower=True, check_finite=True)
        except la.LinAlgError:
            return False
        return True
    S = sp.csr_matrix((K + K.T) * 0.5)
    perm = csgraph.reverse_cuthill_mckee(S, symmetric_mode=True)
    P = sp.tril(S[perm][:, perm]).tocoo()
    band = int((P.row - P.col).max()) if P.nnz else 0
    ab = np.zeros((band + 1, S.shape[0]))
    ab[P.row - P.col, P.col] = P.data  # lower band storage: ab[i - j, j] = S[i, j]
    try:
        la.cholesky_banded(ab, lower=True, check_finite=True)
    except la.LinAlgError:
        return False
    return True


def det_sign(K) -> int:
    """Sign of det K (-1, 0 or +1) from a sparse LU: Pr A Pc = L U with unit-diagonal L (a
    dense LU with row interchanges for a dense K)."""
    if not sp.issparse(K):
        lu, piv = la.lu_factor(K, check_finite=False)
        d = lu.diagonal()
        if np.any(d == 0) or not np.all(np.isfinite(d)):
            return 0
        swaps = int(np.count_nonzero(piv != np.arange(piv.size)))  # each a transposition
        return -1 if (np.count_nonzero(d < 0) + swaps) % 2 else 1
    try:
        lu = spla.splu(sp.csc_matrix(K))
    except RuntimeError:  # exactly singular
        return 0
    d = lu.U.diagonal()
    if np.any(d == 0) or not np.all(np.isfinite(d)):
        return 0
    neg = int(np.count_nonzero(d < 0))
    return -1 if (neg + _parity(lu.perm_r) + _parity(lu.perm_c)) % 2 else 1


def _parity(perm: np.ndarray) -> int:
    """0 for an even permutation, 1 for an odd one: (n - number of cycles) mod 2."""
    n = perm.size
    g = sp.csr_matrix((np.ones(n), (np.arange(n), perm)), shape=(n, n))
    cycles = csgraph.connected_components(g, directed=True, connection="weak")[0]
    return (n - cycles) % 2


def real_positive(lam, imag_tol: float = IMAG_TOL) -> np.ndarray:
    """The real eigenvalues λ > 0 (|Im λ| <= imag_tol·|λ|), ascending."""
    lam = np.asarray(lam, dtype=complex)
    lam = lam[np.isfinite(lam)]
    is_real = np.abs(lam.imag) <= imag_tol * np.maximum(np.abs(lam), np.finfo(float).tiny)
    return np.sort(lam.real[is_real & (lam.real > 0)])


def check_divergence(qep: QEP, spectrum=None, computed=None, dense_spectrum=None, imag_tol: float = IMAG_TOL,
                     dense_limit: int = DENSE_LIMIT, sym_definite: bool | None = None) -> Divergence:
    """Whole-spectrum divergence verdict of ``qep`` (see the module docstring).

    Parameters
    ----------
    qep : QEP
        Its C must have a positive semi-definite symmetric part (Coriolis + Rayleigh damping
        with α, β >= 0, as :meth:`Model.qep` builds it).
    spectrum : array, optional
        Every eigenvalue of ``qep`` (the dense engine has them).
    computed : array, optional
        The eigenvalues an engine computed (a subset); used only above ``dense_limit``.
    dense_spectrum : callable, optional
        qep -> every eigenvalue (the dense engine's LAPACK kernel, solve/dense.py
        ``all_eigenvalues``); called for an undecided point of at most ``dense_limit`` DOFs.
    imag_tol : float
        |Im λ| <= imag_tol·|λ| is a real eigenvalue.
    dense_limit : int
        Largest model (free DOFs) whose undecided points get a dense whole-spectrum solve.
    sym_definite : bool, optional
        The Cholesky certificate when the caller already has it (the dense engine factors a
        batch of problems at once); None: factor here.

    Returns
    -------
    Divergence
    """
    if sym_definite if sym_definite is not None else sym_positive_definite(qep.stiffness):
        return Divergence(False, True, np.zeros(0), "proven: sym(K) positive definite (Cholesky)")
    negative_det = det_sign(qep.stiffness) < 0
    if spectrum is None and qep.n <= dense_limit and dense_spectrum is not None:
        spectrum = dense_spectrum(qep)
    if spectrum is not None:
        found, how, scope = real_positive(spectrum, imag_tol), "located: every eigenvalue (dense LAPACK)", WHOLE
    else:
        found = real_positive(computed if computed is not None else [], imag_tol)
        how = f"located among the {0 if computed is None else len(computed)} eigenvalues computed"
        scope = f"eigenvalues computed (n = {qep.n} > {dense_limit}: no dense whole-spectrum solve)"
    if negative_det:
        return Divergence(True, True, found, f"proven: det K < 0 (sparse LU); {how}", WHOLE)
    return Divergence(bool(found.size), False, found, f"sym(K) indefinite, det K >= 0; {how}", scope)
