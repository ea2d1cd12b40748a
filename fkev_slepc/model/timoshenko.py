"""The Timoshenko frame element: shear deformation and rotary inertia (docs/theory.md §22).

Same DOFs as the thesis element (u₁, v₁, ψ₁, u₂, v₂, ψ₂), ψ the section's rotation. The
interdependent interpolation of §22.2 (Friedman & Kosmatka 1993) with the shear parameter
Φ = 12EI/(κGA l²) of each element is exact in statics and tends to the thesis element as Φ → 0
(no locking). Every matrix is a polynomial in Φ over a power of (1 + Φ); its coefficients are
integrated once by Gauss quadrature (templates) and combined for all elements in one einsum.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.polynomial.legendre import leggauss

_G = np.array([0.0, -1.0, -0.5, 0.0, 1.0, -0.5])  # γ = Φ/((1+Φ)l) g q (rotation columns x l)


@dataclass(frozen=True)
class Shear:
    """Per-element section data of shear and rotary inertia (n_el,): κGA (N) and ρI (kg m)."""

    kga: np.ndarray
    rho_i: np.ndarray

    def parameter(self, ei: np.ndarray, l: np.ndarray) -> np.ndarray:
        """Φ = 12EI/(κGA l²) of every element."""
        return 12.0 * ei / (self.kga * l**2)


def section_shear(pieces) -> Shear:
    """The :class:`Shear` of the scene segments ``pieces`` (one per element; ``Mechanism.elem_piece``):
    κGA from the segment's shear coefficient, shear modulus and area, ρI from its density and I
    (NaN where the scene gives no κ or G; scene/validity.py refuses a Timoshenko scene then)."""
    def field(name):
        return np.array([np.nan if getattr(p, name) is None else getattr(p, name) for p in pieces], dtype=float)

    kga = field("shear_coefficient") * field("shear_modulus") * field("area")
    return Shear(kga, field("density") * field("second_moment"))


def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = leggauss(n)
    return (x + 1) / 2, w / 2


def shapes(xi: np.ndarray) -> dict[str, np.ndarray]:
    """The pieces (n_xi, 2, 6) of the shape functions: [Φ⁰ part, Φ¹ part] (to be divided by
    1 + Φ) of v (``v``), dv/dξ (``dv``), ψ·l (``psi``) and dψ/dξ·l (``dpsi``); the axial ``u`` and
    ``du`` (Φ-free, (n_xi, 6)). Rotation columns per unit l (model/element_types.py ``dof_scale``)."""
    z, o = np.zeros_like(xi), np.ones_like(xi)
    h = np.stack([z, 1 - 3 * xi**2 + 2 * xi**3, xi * (1 - xi) ** 2, z, 3 * xi**2 - 2 * xi**3, -(xi**2) * (1 - xi)], -1)
    dh = np.stack([z, -6 * xi + 6 * xi**2, 1 - 4 * xi + 3 * xi**2, z, 6 * xi - 6 * xi**2, 3 * xi**2 - 2 * xi], -1)
    d2h = np.stack([z, -6 + 12 * xi, -4 + 6 * xi, z, 6 - 12 * xi, 6 * xi - 2], -1)
    h1 = np.stack([z, 1 - xi, xi * (1 - xi) / 2, z, xi, -xi * (1 - xi) / 2], -1)
    dh1 = np.stack([z, -o, (1 - 2 * xi) / 2, z, o, -(1 - 2 * xi) / 2], -1)
    p1 = np.stack([z, z, 1 - xi, z, z, xi], -1)
    dp1 = np.stack([z, z, -o, z, z, o], -1)
    u = np.stack([1 - xi, z, z, xi, z, z], -1)
    du = np.stack([-o, z, z, o, z, z], -1)
    pair = lambda a, b: np.stack([a, b], 1)  # noqa: E731
    return {"v": pair(h, h1), "dv": pair(dh, dh1), "psi": pair(dh, p1), "dpsi": pair(d2h, dp1), "u": u, "du": du}


def _gram2(a: np.ndarray, b: np.ndarray, w: np.ndarray, f=None) -> np.ndarray:
    """(3, 6, 6) templates T_p with ∫ aᵀ b f dξ = Σ_p Φ^p T_p / (1+Φ)² for a, b = (X₀ + ΦX₁)/(1+Φ)."""
    f = np.ones_like(w) if f is None else f
    g = np.einsum("g,gpi,gqj->pqij", w * f, a, b)
    return np.stack([g[0, 0], g[0, 1] + g[1, 0], g[1, 1]])


@lru_cache(maxsize=1)
def templates() -> dict[str, np.ndarray]:
    """Gauss-quadrature templates of every matrix (6 points: exact to degree 11)."""
    xi, w = _gauss(6)
    s = shapes(xi)
    uu = np.einsum("g,gi,gj->ij", w, s["u"], s["u"])
    # skew: ∫ (N_vᵀ N_u - N_uᵀ N_v); N_v over (1+Φ), N_u not: linear in Φ over (1+Φ)
    vu = np.einsum("g,gpi,gj->pij", w, s["v"], s["u"])
    return {
        "uu": uu,
        "vv": _gram2(s["v"], s["v"], w),
        "pp": _gram2(s["psi"], s["psi"], w),
        "kk": _gram2(s["dpsi"], s["dpsi"], w),
        "skew": vu - np.swapaxes(vu, -1, -2),
        "kg": np.stack([_gram2(s["dv"], s["dv"], w, xi**k) for k in range(3)]),
        "du": np.einsum("g,gi,gj->ij", w, s["du"], s["du"]),
    }


def _scale(l: np.ndarray) -> np.ndarray:
    d = np.ones((l.size, 6))
    d[:, 2] = d[:, 5] = l
    return d[:, :, None] * d[:, None, :]


def _powers(phi: np.ndarray, n: int, den: int) -> np.ndarray:
    """(n, n_el): Φ^p / (1+Φ)^den for p < n."""
    return np.stack([phi**p for p in range(n)]) / (1 + phi) ** den


def mass(rho_a: np.ndarray, rho_i: np.ndarray, l: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(m, m_t): the consistent mass m = m_t + m_r and its translational part m_t (§22.3)."""
    t = templates()
    c = _powers(phi, 3, 2)
    vv = np.einsum("pe,pij->eij", c, t["vv"])
    pp = np.einsum("pe,pij->eij", c, t["pp"])
    mt = (rho_a * l)[:, None, None] * (t["uu"] + vv) * _scale(l)
    mr = (rho_i / l)[:, None, None] * pp * _scale(l)
    return mt + mr, mt


def skew_mass(rho_a: np.ndarray, l: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """m_a = ρAl∫NᵀSN dξ with the Timoshenko N_v (skew-symmetric)."""
    sk = np.einsum("pe,pij->eij", _powers(phi, 2, 1), templates()["skew"])
    return (rho_a * l)[:, None, None] * sk * _scale(l)


def strains(ea, ei, kga, l, phi) -> tuple[np.ndarray, np.ndarray]:
    """B (n_el, 7, 6) and w (n_el, 7) with k_s = Bᵀ diag(w) B: u′ and ψ′ at 3 Gauss points
    (exact: u′ constant, ψ′ linear) and the constant shear strain γ (§22.3)."""
    xi, wg = _gauss(3)
    s = shapes(xi)
    d = np.ones((l.size, 6))
    d[:, 2] = d[:, 5] = l
    Bu = s["du"][None] * d[:, None, :] / l[:, None, None]
    dpsi = (s["dpsi"][None, :, 0] + phi[:, None, None] * s["dpsi"][None, :, 1]) / (1 + phi)[:, None, None]
    Bk = dpsi * d[:, None, :] / (l**2)[:, None, None]
    Bg = (phi / ((1 + phi) * l))[:, None, None] * (_G[None, None, :] * d[:, None, :])
    B = np.concatenate([Bu, Bk, Bg], axis=1)
    w = np.concatenate([np.outer(ea * l, wg), np.outer(ei * l, wg), (kga * l)[:, None]], axis=1)
    return B, w


def structural(ea, ei, kga, l, phi) -> np.ndarray:
    """k_s (closed form of §22.3; ``strains`` gives the same as Bᵀ diag(w) B)."""
    t = templates()
    bend = np.einsum("pe,pij->eij", _powers(phi, 3, 2), t["kk"]) * (ei / l**3)[:, None, None]
    shear = (12 * ei * phi / ((1 + phi) ** 2 * l**3))[:, None, None] * np.outer(_G, _G)
    return ((ea / l)[:, None, None] * t["du"] + (bend + shear) * _scale(l))


def axial_force(c: np.ndarray, l: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """k_g = (1/l)∫F(ξ) N_v,ξᵀN_v,ξ dξ for F = c₀ + c₁ξ + c₂ξ² (c: (n_el, 3))."""
    k = np.einsum("ek,pe,kpij->eij", c, _powers(phi, 3, 2), templates()["kg"])
    return k * _scale(l) / l[:, None, None]
