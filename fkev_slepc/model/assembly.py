"""Scatter element stacks into CSR matrices on one cached sparsity pattern (docs/theory.md §9).

The pattern (the union of all element blocks, restricted to free DOFs) is built once per
mechanism; afterwards each assembly is one ``np.bincount`` into the CSR data array, so every
operator of a model shares ``indptr``/``indices`` and PETSc matrices can be updated in place.
Constrained DOFs (index -1) are simply dropped: that is the elimination of §9.3. Load vectors
(model/loads.py) are scattered onto the same free-DOF numbering by :meth:`Pattern.scatter_vector`.
Every scatter takes stacks with leading crank-angle axes and scatters all angles in one call.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp


class Pattern:
    """CSR pattern of ``elem_dofs`` (n_el, n_dof) over ``n_free`` DOFs, with scatter positions.

    ``extra_dofs`` (n_x, n_dof), optional: more blocks in the pattern that are not elements (the
    compliant bearings out of plane, model/out_of_plane.py), scattered by :meth:`scatter_extra`."""

    def __init__(self, elem_dofs: np.ndarray, n_free: int, extra_dofs: np.ndarray | None = None):
        self.elem_dofs = elem_dofs = np.asarray(elem_dofs)
        k = elem_dofs.shape[1]
        extra = np.zeros((0, k), dtype=int) if extra_dofs is None else np.asarray(extra_dofs).reshape(-1, k)
        blocks = np.concatenate([elem_dofs, extra])
        rows = np.repeat(blocks, k, axis=1).ravel()
        cols = np.tile(blocks, (1, k)).ravel()
        valid = (rows >= 0) & (cols >= 0)
        r, c = rows[valid], cols[valid]
        key = r.astype(np.int64) * n_free + c
        uniq, position = np.unique(key, return_inverse=True)
        n_elem = elem_dofs.size * k
        self.valid, self.extra_valid = valid[:n_elem], valid[n_elem:]
        n_valid = int(self.valid.sum())
        self.position, self.extra_position = position[:n_valid], position[n_valid:]
        self.indices = (uniq % n_free).astype(np.int32)
        counts = np.bincount((uniq // n_free).astype(np.int64), minlength=n_free)
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.n = n_free
        self.nnz = uniq.size
        diag = np.full(n_free, -1, dtype=np.int64)
        is_diag = (uniq // n_free) == (uniq % n_free)
        diag[uniq[is_diag] // n_free] = np.flatnonzero(is_diag)
        self.diag_position = diag

    def scatter(self, stack: np.ndarray) -> np.ndarray:
        """CSR data array Σ_e Aᵀ k_e A of an (..., n_el, n_dof, n_dof) stack: (..., nnz).

        Leading axes (crank angles) are scattered in one sparse product with :attr:`summing`,
        each angle's entries summed in the order a ``np.bincount`` of that angle alone sums them
        (the same numbers to the last bit)."""
        lead = stack.shape[:-3]
        w = stack.reshape(-1, self.valid.size)
        if w.shape[0] == 1:
            return np.bincount(self.position, weights=w[0][self.valid], minlength=self.nnz).reshape(lead + (self.nnz,))
        return np.ascontiguousarray((self.summing @ w.T).T).reshape(lead + (self.nnz,))

    def scatter_extra(self, stack: np.ndarray) -> np.ndarray:
        """CSR data (..., nnz) of an (..., n_x, n_dof, n_dof) stack on the ``extra_dofs`` blocks."""
        lead = stack.shape[:-3]
        w = stack.reshape(-1, self.extra_valid.size)[:, self.extra_valid]
        return self._bincount(self.extra_position, w, self.nnz).reshape(lead + (self.nnz,))

    @cached_property
    def summing(self) -> sp.csr_matrix:
        """(nnz, n_el·n_dof²) 0/1 matrix: the CSR data of a stack's flattened entries (constrained
        ones dropped), column indices in increasing order within each row."""
        cols = np.flatnonzero(self.valid)
        return sp.csr_matrix((np.ones(cols.size), (self.position, cols)), shape=(self.nnz, self.valid.size))

    def scatter_vector(self, values: np.ndarray, dofs: np.ndarray | None = None) -> np.ndarray:
        """Vector Σ_e Aᵀ f_e over the free DOFs, (..., n) for values (..., n_el, n_dof) on
        ``dofs`` (n_el, n_dof; default the elements' DOFs). Entries on constrained DOFs (-1) are
        dropped; leading axes (crank angles) are kept."""
        dofs = self.elem_dofs if dofs is None else np.asarray(dofs)
        keep = dofs.ravel() >= 0
        lead = values.shape[: values.ndim - dofs.ndim]
        w = values.reshape((int(np.prod(lead)), dofs.size))[:, keep]
        return self._bincount(dofs.ravel()[keep], w, self.n).reshape(lead + (self.n,))

    @staticmethod
    def _bincount(position: np.ndarray, w: np.ndarray, size: int) -> np.ndarray:
        """Row-wise bincount of the (n_rows, k) weights ``w`` at ``position`` (k,): (n_rows, size)."""
        if w.shape[0] == 1:
            return np.bincount(position, weights=w[0], minlength=size)[None]
        idx = (position[None, :] + size * np.arange(w.shape[0])[:, None]).ravel()
        return np.bincount(idx, weights=w.ravel(), minlength=size * w.shape[0]).reshape(-1, size)

    def add_diagonal(self, data: np.ndarray, dofs: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``data`` (..., nnz) with ``values`` added on the diagonal at ``dofs`` (entries with dof
        -1 skipped), the same for every leading index."""
        dofs = np.asarray(dofs)
        vals = np.broadcast_to(np.asarray(values, dtype=float), dofs.shape).ravel()
        dofs = dofs.ravel()
        keep = dofs >= 0
        out = data.copy()
        flat = out.reshape(-1, self.nnz)
        np.add.at(flat, (slice(None), self.diag_position[dofs[keep]]), vals[keep])
        return out

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """CSR matrix with this pattern (explicit zeros kept, pattern arrays shared).

        scipy's constructor re-validates the pattern on every call (index dtypes, bounds,
        pruning): ~50 µs, three times per point, a third of a thesis-size model's QZ solve. The
        pattern is validated once, by building :attr:`template` the checked way; every further
        matrix is a copy of its attributes with new data (tests/test_operators.py checks the
        result against the checked constructor, so a scipy that stores CSR differently is caught).
        """
        data = np.asarray(data, dtype=float)
        if data.shape != (self.nnz,):
            raise ValueError(f"CSR data of {data.shape} for a pattern with {self.nnz} entries")
        m = sp.csr_matrix.__new__(sp.csr_matrix)
        m.__dict__.update(self.template.__dict__)
        m.data = data
        return m

    @cached_property
    def template(self) -> sp.csr_matrix:
        """The pattern as a checked scipy CSR matrix (zero data)."""
        return sp.csr_matrix((np.zeros(self.nnz), self.indices, self.indptr), shape=(self.n, self.n))
