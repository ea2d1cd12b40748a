"""Element types: the thesis frame element, a frame element with cubic axial interpolation and
the Timoshenko frame element (``timoshenko``: shear deformation and rotary inertia, same six DOFs,
matrices in :mod:`fkev_slepc.model.timoshenko`, docs/theory.md §22).

Both are planar Euler-Bernoulli frame elements with cubic Hermite bending; they differ in the
axial displacement u(ξ) (docs/accuracy.md §1):

* ``thesis``: linear u (the thesis's element, docs/theory.md §5). Six DOFs
  (u₁, v₁, φ₁, u₂, v₂, φ₂). Its closed-form matrices live in :mod:`fkev_slepc.model.elements`.
* ``cubic``: u(ξ) = u₁(1-ξ) + u₂ξ + a₁·4ξ(1-ξ) + a₂·6√3·ξ(1-ξ)(1-2ξ), two internal axial
  amplitudes per element (DOFs 7-8, kept, not condensed: a condensation exact for the stiffness
  is not exact for the mass). The axial order then matches the bending order and linkage modes,
  which stretch the links, converge like h⁴ instead of h² (docs/accuracy.md §1, measured).
  The bubbles' derivatives are Legendre polynomials P₁, P₂, so the axial stiffness does not
  couple them to the nodal DOFs.

Every matrix of the ``cubic`` element (mass m, secondary skew mass m_a, structural k_s,
axial-force k_g, and through m and m_a the tangential and normal terms) comes from the same
shape functions by Gauss quadrature, exact for the polynomial degrees involved. The stiffness is
also available factored, k_s = Bᵀ diag(w) B over strain sampling points
(:meth:`ElementType.strains`), which :mod:`fkev_slepc.model.energy` uses to apply K_s without the
n_el⁴ cancellation of an assembled matrix.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.polynomial.legendre import leggauss

from fkev_slepc.model import elements as el
from fkev_slepc.model import timoshenko as tim
from fkev_slepc.scene.model import ELEMENT_NAMES
_R3 = 6.0 * np.sqrt(3.0)


def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss rule on [0, 1]."""
    x, w = leggauss(n)
    return (x + 1) / 2, w / 2


def axial_shapes(xi: np.ndarray, n_dof: int, deriv: int) -> np.ndarray:
    """d^k/dξ^k of the axial shape functions at ``xi``: (n_xi, n_dof)."""
    out = np.zeros((xi.size, n_dof))
    if deriv == 0:
        out[:, 0], out[:, 3] = 1 - xi, xi
    else:
        out[:, 0], out[:, 3] = -1.0, 1.0
    if n_dof > 6:
        if deriv == 0:
            out[:, 6] = 4 * xi * (1 - xi)
            out[:, 7] = _R3 * xi * (1 - xi) * (1 - 2 * xi)
        else:
            out[:, 6] = 4 * (1 - 2 * xi)
            out[:, 7] = _R3 * (1 - 6 * xi + 6 * xi**2)
    return out


def bending_shapes(xi: np.ndarray, n_dof: int, deriv: int) -> np.ndarray:
    """d^k/dξ^k of the Hermite shape functions (rotations per unit l; the φ columns are
    multiplied by l in :func:`dof_scale`): (n_xi, n_dof)."""
    out = np.zeros((xi.size, n_dof))
    if deriv == 0:
        out[:, 1] = 1 - 3 * xi**2 + 2 * xi**3
        out[:, 2] = xi * (1 - xi) ** 2
        out[:, 4] = 3 * xi**2 - 2 * xi**3
        out[:, 5] = -(xi**2) * (1 - xi)
    elif deriv == 1:
        out[:, 1] = -6 * xi + 6 * xi**2
        out[:, 2] = 1 - 4 * xi + 3 * xi**2
        out[:, 4] = 6 * xi - 6 * xi**2
        out[:, 5] = 3 * xi**2 - 2 * xi
    else:
        out[:, 1] = -6 + 12 * xi
        out[:, 2] = -4 + 6 * xi
        out[:, 4] = 6 - 12 * xi
        out[:, 5] = 6 * xi - 2
    return out


def _gram(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Σ_g w_g a_gᵀ b_g: ∫ aᵀb dξ by quadrature."""
    return np.einsum("g,gi,gj->ij", w, a, b)


def dof_scale(l: np.ndarray, n_dof: int) -> np.ndarray:
    """(n_el, n_dof) DOF scaling: rotations enter the shape functions multiplied by l."""
    d = np.ones((l.size, n_dof))
    d[:, 2] = d[:, 5] = l
    return d


@dataclass(frozen=True)
class ElementType:
    """An element type: DOF count and its element-matrix stacks (each (n_el, n_dof, n_dof),
    local DOFs u₁, v₁, φ₁, u₂, v₂, φ₂, then internal axial amplitudes)."""

    name: str
    n_dof: int

    @property
    def n_internal(self) -> int:
        return self.n_dof - 6

    # -- templates by quadrature (exact: 6 points integrate degree 11) ----------------------
    @cached_property
    def _templates(self):
        xi, w = _gauss(6)
        n = self.n_dof
        Nu, Nv = axial_shapes(xi, n, 0), bending_shapes(xi, n, 0)
        dNv = bending_shapes(xi, n, 1)
        mass = _gram(Nu, Nu, w) + _gram(Nv, Nv, w)
        skew = _gram(Nv, Nu, w) - _gram(Nu, Nv, w)  # ∫NᵀSN, S = [[0, -1], [1, 0]]
        kg = np.stack([_gram(xi[:, None] ** k * dNv, dNv, w) for k in range(3)])
        return mass, skew, kg

    def mass(self, rho_a: np.ndarray, l: np.ndarray, shear: tim.Shear | None = None, ei=None) -> np.ndarray:
        """Consistent mass m = ρAl∫NᵀN dξ (Timoshenko: plus the rotary inertia, docs/theory.md §22)."""
        if self.name == "timoshenko":
            return tim.mass(rho_a, shear.rho_i, l, shear.parameter(ei, l))[0]
        if self.name == "thesis":
            return el.mass_local(rho_a, l)
        d = dof_scale(l, self.n_dof)
        return (rho_a * l)[:, None, None] * self._templates[0] * d[:, :, None] * d[:, None, :]

    def normal_mass(self, rho_a: np.ndarray, l: np.ndarray, shear: tim.Shear | None = None, ei=None):
        """The matrix n of the normal term −φ̇² n: None (the mass m) but for the Timoshenko element,
        whose rotary inertia has no centripetal term (its translational mass, §22.4)."""
        if self.name != "timoshenko":
            return None
        return tim.mass(rho_a, shear.rho_i, l, shear.parameter(ei, l))[1]

    def skew_mass(self, rho_a: np.ndarray, l: np.ndarray, shear: tim.Shear | None = None, ei=None) -> np.ndarray:
        """Secondary mass m_a = ρAl∫NᵀSN dξ (skew-symmetric)."""
        if self.name == "timoshenko":
            return tim.skew_mass(rho_a, l, shear.parameter(ei, l))
        if self.name == "thesis":
            return el.skew_mass_local(rho_a, l)
        d = dof_scale(l, self.n_dof)
        return (rho_a * l)[:, None, None] * self._templates[1] * d[:, :, None] * d[:, None, :]

    def structural(self, ea: np.ndarray, ei: np.ndarray, l: np.ndarray, shear: tim.Shear | None = None) -> np.ndarray:
        """Structural stiffness k_s = Bᵀ diag(w) B (= EA/l∫u'² + EI/l³∫v''² in ξ)."""
        if self.name == "timoshenko":
            return tim.structural(ea, ei, shear.kga, l, shear.parameter(ei, l))
        if self.name == "thesis":
            return el.structural_local(ea, ei, l)
        B, w = self.strains(ea, ei, l)
        return np.einsum("esi,es,esj->eij", B, w, B)

    def axial_force(self, c: np.ndarray, l: np.ndarray, phi: np.ndarray | None = None) -> np.ndarray:
        """Pseudo-normal stiffness k_g = (1/l)∫F(ξ) v'ᵀv' dξ for F = c₀ + c₁ξ + c₂ξ² (c: (n_el, 3));
        ``phi``: the Timoshenko element's shear parameters Φ (n_el,)."""
        if self.name == "timoshenko":
            return tim.axial_force(c, l, phi)
        if self.name == "thesis":
            return el.axial_force_local(c, l)
        d = dof_scale(l, self.n_dof)
        kg = np.einsum("ek,kij->eij", c, self._templates[2])
        return kg * (d[:, :, None] * d[:, None, :]) / l[:, None, None]

    def strains(self, ea: np.ndarray, ei: np.ndarray, l: np.ndarray, shear: tim.Shear | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Strain operator B (n_el, n_s, n_dof) and weights w (n_el, n_s) with k_s = Bᵀ diag(w) B.

        Rows: axial strain u' and curvature v'' at 3 Gauss points (exact for both elements:
        u' is at most quadratic, v'' linear); Timoshenko: curvature ψ′ and one shear-strain row.
        """
        if self.name == "timoshenko":
            return tim.strains(ea, ei, shear.kga, l, shear.parameter(ei, l))
        xi, wg = _gauss(3)
        d = dof_scale(l, self.n_dof)
        Bu = axial_shapes(xi, self.n_dof, 1)[None] * d[:, None, :] / l[:, None, None]
        Bv = bending_shapes(xi, self.n_dof, 2)[None] * d[:, None, :] / (l**2)[:, None, None]
        B = np.concatenate([Bu, Bv], axis=1)
        w = np.concatenate([np.outer(ea * l, wg), np.outer(ei * l, wg)], axis=1)
        return B, w


def point_load(xi: np.ndarray, l: np.ndarray, n_dof: int, f: np.ndarray, phi: np.ndarray | None = None) -> np.ndarray:
    """Consistent element loads Nᵀ(u, v) f_uv + (dN_v/dx)ᵀ m of point forces and moments
    ``f`` (..., n_pt, 3: f_u, f_v along and normal to the element, m) at element coordinates
    ``xi`` (n_pt,) of elements of length ``l`` (n_pt,): (..., n_pt, n_dof) on the local DOFs
    (docs/theory.md §5.1: the shape functions of the mass matrix; rotations per unit l). With the
    Timoshenko shear parameters ``phi`` (n_pt,): N_v and, for the moment, N_ψ of docs/theory.md §22.2."""
    xi, l = np.asarray(xi, float), np.asarray(l, float)
    d = dof_scale(l, n_dof)
    Nu = axial_shapes(xi, n_dof, 0) * d
    Nv = bending_shapes(xi, n_dof, 0) * d
    dNv = bending_shapes(xi, n_dof, 1) * d / l[:, None]
    if phi is not None:
        s, ph = tim.shapes(xi), np.asarray(phi, float)[:, None]
        Nv = (s["v"][:, 0] + ph * s["v"][:, 1]) / (1 + ph) * d
        dNv = (s["psi"][:, 0] + ph * s["psi"][:, 1]) / (1 + ph) * d / l[:, None]
    return f[..., 0:1] * Nu + f[..., 1:2] * Nv + f[..., 2:3] * dNv


_N_DOF = {"thesis": 6, "cubic": 8, "timoshenko": 6}
ELEMENT_TYPES = {name: ElementType(name, _N_DOF[name]) for name in ELEMENT_NAMES}


def element_type(name: str) -> ElementType:
    """The element type called ``name`` (one of :data:`ELEMENT_NAMES`)."""
    try:
        return ELEMENT_TYPES[name]
    except KeyError:
        raise ValueError(f"unknown element {name!r}; known: {', '.join(ELEMENT_NAMES)}") from None
