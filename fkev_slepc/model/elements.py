"""Element matrices of the planar Euler-Bernoulli frame element (docs/theory.md §5, §8).

Pure numpy, vectorised over elements: every function takes (n_el,) arrays and returns an
(n_el, 6, 6) stack in the local DOF order (u₁, v₁, φ₁, u₂, v₂, φ₂).
"""

from __future__ import annotations

import numpy as np


def _stack(template: np.ndarray, *factors: np.ndarray) -> np.ndarray:
    """Σ_k factors[k][e] · template[k] for a (n_terms, 6, 6) template: one einsum, no loop over e."""
    return np.einsum("ke,kij->eij", np.stack(factors), template)


# fmt: off
# Consistent mass (eq 2.10) split by powers of l: (ρAl/420)·(T0 + l·T1 + l²·T2).
_M0 = np.array([[140, 0, 0, 70, 0, 0], [0, 156, 0, 0, 54, 0], [0, 0, 0, 0, 0, 0],
                [70, 0, 0, 140, 0, 0], [0, 54, 0, 0, 156, 0], [0, 0, 0, 0, 0, 0]], float)
_M1 = np.array([[0, 0, 0, 0, 0, 0], [0, 0, 22, 0, 0, -13], [0, 22, 0, 0, 13, 0],
                [0, 0, 0, 0, 0, 0], [0, 0, 13, 0, 0, -22], [0, -13, 0, 0, -22, 0]], float)
_M2 = np.zeros((6, 6)); _M2[2, 2] = _M2[5, 5] = 4; _M2[2, 5] = _M2[5, 2] = -3
# Secondary (skew) mass (eq 2.11): (ρAl/60)·(S0 + l·S1).
_S0 = np.zeros((6, 6)); _S0[0, 1], _S0[0, 4], _S0[3, 1], _S0[3, 4] = -21, -9, -9, -21
_S1 = np.zeros((6, 6)); _S1[0, 2], _S1[0, 5], _S1[3, 2], _S1[3, 5] = -3, 2, -2, 3
# Structural stiffness (eq 2.22): EA/l·A + EI/l³·B0 + EI/l²·B1 + EI/l·B2.
_KA = np.zeros((6, 6)); _KA[0, 0] = _KA[3, 3] = 1; _KA[0, 3] = _KA[3, 0] = -1
_KB0 = np.zeros((6, 6)); _KB0[1, 1] = _KB0[4, 4] = 12; _KB0[1, 4] = _KB0[4, 1] = -12
_KB1 = np.zeros((6, 6))
_KB1[1, 2] = _KB1[2, 1] = _KB1[1, 5] = _KB1[5, 1] = 6
_KB1[2, 4] = _KB1[4, 2] = _KB1[4, 5] = _KB1[5, 4] = -6
_KB2 = np.zeros((6, 6)); _KB2[2, 2] = _KB2[5, 5] = 4; _KB2[2, 5] = _KB2[5, 2] = 2
# fmt: on
_S0 = _S0 - _S0.T
_S1 = _S1 - _S1.T


def mass_local(rho_a: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Consistent mass matrix m (eq 2.10)."""
    c = rho_a * l / 420.0
    return _stack(np.stack([_M0, _M1, _M2]), c, c * l, c * l**2)


def skew_mass_local(rho_a: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Secondary mass m_a = ρAl∫NᵀSN dξ, S = [[0,-1],[1,0]] (eq 2.11); skew-symmetric."""
    c = rho_a * l / 60.0
    return _stack(np.stack([_S0, _S1]), c, c * l)


def structural_local(ea: np.ndarray, ei: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Structural stiffness k_s (eq 2.22)."""
    return _stack(np.stack([_KA, _KB0, _KB1, _KB2]), ea / l, ei / l**3, ei / l**2, ei / l)


def axial_force_local(c: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Pseudo-normal (axial-force) stiffness k_g for F(ξ) = c₀ + c₁ξ + c₂ξ² (§5.4).

    ``c`` is (n_el, 3). Tension (F > 0) stiffens. Rows/columns of u₁, u₂ are zero.
    """
    c0, c1, c2 = c[:, 0], c[:, 1], c[:, 2]
    k = np.zeros((l.size, 6, 6))
    k22 = (6 / 5 * c0 + 3 / 5 * c1 + 12 / 35 * c2) / l
    k23 = c0 / 10 + c1 / 10 + c2 / 14
    k26 = c0 / 10 - c2 / 35
    k33 = l * (2 / 15 * c0 + 1 / 30 * c1 + 2 / 105 * c2)
    k36 = -l * (1 / 30 * c0 + 1 / 60 * c1 + 1 / 70 * c2)
    k66 = l * (2 / 15 * c0 + 1 / 10 * c1 + 3 / 35 * c2)
    v1, p1, v2, p2 = 1, 2, 4, 5
    entries = {
        (v1, v1): k22, (v1, v2): -k22, (v2, v2): k22,
        (v1, p1): k23, (p1, v2): -k23,
        (v1, p2): k26, (v2, p2): -k26,
        (p1, p1): k33, (p1, p2): k36, (p2, p2): k66,
    }  # fmt: skip
    for (i, j), val in entries.items():
        k[:, i, j] = val
        k[:, j, i] = val
    return k


def rotation(phi: np.ndarray, n_dof: int = 6) -> np.ndarray:
    """T = blockdiag(R, 1, R, 1, I), R = [[cos φ, sin φ], [-sin φ, cos φ]]: q_local = T q_global (§8).

    DOFs beyond the sixth are internal axial amplitudes (element_types.py): already local.
    """
    c, s = np.cos(phi), np.sin(phi)
    T = np.zeros((phi.size, n_dof, n_dof))
    T[:, 6:, 6:] = np.eye(n_dof - 6)
    for o in (0, 3):
        T[:, o, o] = T[:, o + 1, o + 1] = c
        T[:, o, o + 1] = s
        T[:, o + 1, o] = -s
        T[:, o + 2, o + 2] = 1.0
    return T


@np.errstate(over="ignore", invalid="ignore")  # overflowing properties: inf/NaN entries the engines refuse
def to_global(k_local: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Tᵀ k T for a stack of element matrices (..., n_dof, n_dof); T may carry extra leading
    axes (crank angles) that broadcast against ``k_local``'s."""
    return np.swapaxes(T, -1, -2) @ k_local @ T
