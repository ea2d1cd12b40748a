"""The structural stiffness kept factored, K_s = Σ_e (B_e T_e)ᵀ diag(w_e) (B_e T_e) (docs/accuracy.md §2).

An assembled K_s applied to a smooth displacement cancels like n_el⁴ (its entries are EI/l³,
the result is of the size of λ·M x), so its round-off sets a floor on the accuracy of the low
modes of fine meshes. Evaluated in stages -- element strains (axial strain and curvature at
Gauss points, cancellation ~n_el²) first, then the strain energy or the nodal forces -- the
stiffness form xᴴK_s x is accurate to ~ε·n_el², and a residual computed this way is the residual
of the exact K_s up to a perturbation of the element stresses of that relative size, which moves
the eigenvalues only by as much (a perturbation of D in BᵀDB, not of the entries of K).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class StagedStiffness:
    """K_s of one crank angle as strain operator and weights, applied without assembly.

    Parameters
    ----------
    B_local : (n_el, n_s, n_dof) strain operator in local DOFs (element_types.ElementType.strains).
    w : (n_el, n_s) weights (EA·l·w_g, EI·l·w_g).
    T : (n_el, n_dof, n_dof) rotations (q_local = T q_global).
    elem_dofs : (n_el, n_dof) free DOF index of each element DOF, -1 where constrained.
    n_free : number of free DOFs.
    gather : optional, :func:`gather_matrix` of ``elem_dofs`` (angle-independent: a model
        builds it once and hands it to the StagedStiffness of every angle).
    """

    def __init__(self, B_local, w, T, elem_dofs, n_free: int, gather=None):
        self.B = B_local @ T  # strains from global element DOFs
        self.Bt = np.ascontiguousarray(self.B.transpose(0, 2, 1))
        self.w = w
        self.dofs = np.where(elem_dofs >= 0, elem_dofs, n_free)  # constrained -> a zero row
        self.n = n_free
        self.gather = gather_matrix(elem_dofs, n_free) if gather is None else gather

    def strains(self, X: np.ndarray) -> np.ndarray:
        """Element strains (n_el, n_s, k) of the columns of X (n, k)."""
        X = np.asarray(X).reshape(self.n, -1)
        Xp = np.concatenate([X, np.zeros((1, X.shape[1]), X.dtype)])
        return _real_matmul(self.B, Xp[self.dofs])

    def energy(self, ey: np.ndarray, ex: np.ndarray) -> np.ndarray:
        """yᴴK_s x (k,) from the element strains of y and x."""
        return np.einsum("es,esk,esk->k", self.w, ey.conj(), ex)

    def apply(self, X: np.ndarray) -> np.ndarray:
        """K_s X (n, k): element stresses w·(B x) first, then Bᵀ, then summed into the nodes."""
        return self.forces(self.strains(X))

    def forces(self, e: np.ndarray) -> np.ndarray:
        """Nodal forces K_s x (n, k) from the element strains e = B x (n_el, n_s, k)."""
        f = _real_matmul(self.Bt, self.w[:, :, None] * e)
        return (self.gather @ f.reshape(-1, e.shape[-1]))[:-1]


def gather_matrix(elem_dofs: np.ndarray, n_free: int) -> sp.csr_matrix:
    """(n_free + 1, n_el·n_dof) 0/1 matrix summing element DOF values into the free DOFs (the last
    row collects the constrained ones). Summing element forces into nodes as one sparse product:
    np.add.at cost 3x more (35 vs 13 ms per apply at 50,400 DOFs, scripts/bench_large.py's model)."""
    dofs = np.where(elem_dofs >= 0, elem_dofs, n_free).ravel()
    return sp.csr_matrix((np.ones(dofs.size), (dofs, np.arange(dofs.size))), shape=(n_free + 1, dofs.size))


def _real_matmul(A: np.ndarray, X: np.ndarray) -> np.ndarray:
    """A @ X for a real stack A and a real or complex X, without casting A to complex."""
    if np.iscomplexobj(X):
        return (A @ X.real) + 1j * (A @ X.imag)
    return A @ X
