"""The quadratic eigenproblem the model hands to a solver.

``(λ² M + λ C + K) x = 0``. All three matrices of a model share one CSR sparsity pattern
(the union of every term, explicit zeros kept), so PETSc matrices can be updated in place.
What a solver returns, and how its pairs are judged, belong to the solve stage
(solve/protocol.py, solve/acceptance.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import scipy.sparse as sp

from fkev_slepc.model.energy import StagedStiffness

# Problem kinds, from the term flags (see operators.classify):
LINEAR_SYMMETRIC = "linear_symmetric"  # C = 0, K = Kᵀ: generalized symmetric-definite in μ = -λ²
LINEAR = "linear"  # C = 0, K non-symmetric (tangential term): generalized non-symmetric in μ
GYROSCOPIC = "gyroscopic"  # C skew, K symmetric
GENERAL = "general"  # C skew and K non-symmetric
KINDS = (LINEAR_SYMMETRIC, LINEAR, GYROSCOPIC, GENERAL)


@dataclass(frozen=True)
class QEP:
    """One instantaneous-structure eigenproblem, sparse (CSR matrices on the model's pattern).
    ``damping`` is None when there is no C. (Dense and batched problems: solve/acceptance.py
    ``DenseQEP``.)"""

    mass: sp.csr_matrix
    damping: sp.csr_matrix | None
    stiffness: sp.csr_matrix
    kind: str
    # K = K_s + stiffness_rest with K_s also kept factored (model/energy.py): lets a solution be
    # polished beyond the round-off of the assembled K (solve/polish.py). None when not built.
    staged: StagedStiffness | None = None
    stiffness_rest: sp.csr_matrix | None = None

    def __post_init__(self):
        for name in ("mass", "damping", "stiffness", "stiffness_rest"):
            A = getattr(self, name)
            if A is not None and not sp.issparse(A):
                raise TypeError(f"QEP.{name} must be a scipy sparse matrix (got {type(A).__name__}); "
                                "dense problems are solve.acceptance.DenseQEP")

    @property
    def n(self) -> int:
        return self.mass.shape[0]
