"""The out-of-plane half of a link's dynamics: bending about the in-plane axis, St-Venant torsion,
the axial-force (pseudo-normal) stiffness of the weak-axis slope and the propeller moment of the
twist (docs/theory.md §19).

The out-of-plane element is the in-plane element of docs/theory.md §4-§5 with v → w, the slope
→ −β (a rotation β about the element's y axis moves the axis by −xβ along z) and u → ψ (the twist,
linear like u): every matrix here is an in-plane matrix of :mod:`fkev_slepc.model.elements` under
the signed permutation :data:`P` (§19.2). The code orders the DOFs of a node as (ψ, β, w) in the
element frame and (θ_X, θ_Y, w) in the ground frame, so that the in-plane rotation
T = blockdiag(R, 1, R, 1) of §8 is also the out-of-plane one (§19.7): the rotation vector's
in-plane components turn like a planar vector and w is the same in every frame.

The joints (§19.8) share all three DOFs at a revolute pin and fix them at ground bearings, slider
blocks and the driver's root: :func:`out_of_plane_mechanism` renumbers a
:class:`~fkev_slepc.model.mechanism.Mechanism` accordingly (same geometry, same rigid motion).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from fkev_slepc.model import elements as el
from fkev_slepc.model.element_types import element_type
from fkev_slepc.model.mechanism import Mechanism, number_dofs
from fkev_slepc.model.stacks import ElementStacks

# Element-frame DOF i (ψ₁, β₁, w₁, ψ₂, β₂, w₂) is _SIGN[i] times in-plane DOF _FROM[i] (u, v, φ per node).
_FROM = np.array([0, 2, 1, 3, 5, 4])
_SIGN = np.array([1.0, -1.0, 1.0, 1.0, -1.0, 1.0])
P = np.zeros((6, 6))
P[np.arange(6), _FROM] = _SIGN  # x_out = P x_in Pᵀ (§19.2)
_TWIST = np.ix_([0, 3], [0, 3])  # the (u₁, u₂) block of an in-plane matrix: the twist block here
N_DOF = 6
SECTION_KEYS = ("elem_ei_out", "elem_gj", "elem_rho_ip")


def _out(k_in: np.ndarray) -> np.ndarray:
    """P k Pᵀ for a stack (..., 6, 6) of in-plane element matrices."""
    return P @ k_in @ P.T


@dataclass(frozen=True)
class Section:
    """Out-of-plane section data per element (n_el,): EI_out (N m²), GJ (N m²), ρI_p (kg m)."""

    ei_out: np.ndarray
    gj: np.ndarray
    rho_ip: np.ndarray

    @classmethod
    def checked(cls, n_el: int, ei_out, gj, rho_ip) -> "Section":
        """The section of ``n_el`` elements (scalars broadcast); ValueError naming the first bad
        field and its value (not finite or not > 0)."""
        out = {}
        for name, value in (("ei_out", ei_out), ("gj", gj), ("rho_ip", rho_ip)):
            a = np.asarray(value, dtype=float)
            try:
                a = np.broadcast_to(a, (n_el,)).copy()
            except ValueError:
                raise ValueError(f"section {name}: {a.size} values for {n_el} elements") from None
            bad = ~(np.isfinite(a) & (a > 0))
            if bad.any():
                raise ValueError(f"section {name}: must be finite and > 0 (got {a[bad][0]!r} at element "
                                 f"{int(np.flatnonzero(bad)[0])})")
            out[name] = a
        return cls(**out)


def section_of(mech: Mechanism, section: Section | None = None) -> Section:
    """``section``, or the mechanism's out-of-plane arrays (``elem_ei_out``, ``elem_gj``,
    ``elem_rho_ip`` from the scene's section data); ValueError naming what is missing."""
    n_el = mech.elem_length.size
    if section is not None:
        return Section.checked(n_el, section.ei_out, section.gj, section.rho_ip)
    have = [getattr(mech, k, None) for k in SECTION_KEYS]
    if any(a is None for a in have) or any(np.isnan(np.asarray(a, float)).any() for a in have):
        raise ValueError("out-of-plane analysis needs every link's out-of-plane section data (second moment "
                         "out of plane, torsion constant, shear modulus); the scene does not give it")
    return Section.checked(n_el, *have)


# -- element matrices, element frame (ψ₁, β₁, w₁, ψ₂, β₂, w₂) ----------------------------------
def has_section(mech: Mechanism) -> bool:
    """Every element has the out-of-plane section data (EI_out, GJ, ρI_p) the problem needs."""
    try:
        section_of(mech)
    except ValueError:
        return False
    return True


def mass(rho_a: np.ndarray, rho_ip: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Consistent mass: §5.1's bending block with ρA on w, its axial block with ρI_p on the twist
    (§19.4; the rotary inertia of the bending slope is neglected)."""
    m = el.mass_local(rho_a, l)
    m[(slice(None),) + _TWIST] = el.mass_local(rho_ip, l)[(slice(None),) + _TWIST]
    return _out(m)


def structural(ei_out: np.ndarray, gj: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Bending about the in-plane axis (EI_out) and St-Venant torsion (GJ/l): §5.3 under P (§19.5)."""
    return _out(el.structural_local(gj, ei_out, l))


def strains(ei_out: np.ndarray, gj: np.ndarray, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strain operator B (n_el, n_s, 6) and weights w with :func:`structural` = Bᵀ diag(w) B (twist
    rate and curvature at Gauss points; model/element_types.py)."""
    B, w = element_type("thesis").strains(gj, ei_out, l)
    return B @ P.T, w


def axial_force(c: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Axial-force (pseudo-normal) stiffness (1/l)∫F w'ᵀw' dξ for F = c₀ + c₁ξ + c₂ξ², the same
    polynomials as in plane (§5.4, §19.5); zero on the twist."""
    return _out(el.axial_force_local(c, l))


def propeller(rho_a: np.ndarray, ea: np.ndarray, ei: np.ndarray, ei_out: np.ndarray, l: np.ndarray) -> np.ndarray:
    """n with the normal term −φ̇² n of the element equation: n = −m_ψ, m_ψ = ρ(I_yy − I_zz)(l/6)[[2, 1],
    [1, 2]] on the twist (the propeller moment, §19.4), ρI = ρA·EI/EA for each axis."""
    n = np.zeros((l.size, 6, 6))
    n[(slice(None),) + _TWIST] = el.mass_local(rho_a * (ei_out - ei) / ea, l)[(slice(None),) + _TWIST]
    return _out(n)


@dataclass(frozen=True)
class OutOfPlaneElement:
    """The out-of-plane element as an element type of :class:`~fkev_slepc.model.stacks.ElementStacks`:
    six DOFs, no internal ones, its own axial-force stiffness."""

    name: str = "out_of_plane"
    n_dof: int = N_DOF
    n_internal: int = 0

    @staticmethod
    def axial_force(c: np.ndarray, l: np.ndarray) -> np.ndarray:
        return axial_force(c, l)


# -- the mechanism out of plane ---------------------------------------------------------------
def _grounded(mech: Mechanism, jj: int) -> bool:
    """A ground bearing or a slider's guide: joint ``jj`` holds its link points to ground."""
    return not (np.isnan(mech.joint_ground[jj, 0]) and np.isnan(mech.joint_guide[jj, 0]))


def out_of_plane_mechanism(mech: Mechanism, compliant=frozenset()) -> Mechanism:
    """``mech`` with its DOFs numbered out of plane (§19.8): per node (θ_X, θ_Y, w); a revolute pin
    shares all three between the links it joins; ground bearings, prismatic joints (the slider
    block in its guide) and hence the driver's root fix all three. The joints of index in
    ``compliant`` share (or fix) w only: their rotations are tied by :class:`Bearings` springs.
    Lumped masses sit on w (``mass_dofs`` column 2); ``node_axis`` is the ground X everywhere (no
    slider node frames). Geometry, rigid motion and kinetostatics are those of ``mech``."""
    n_node = mech.node_link.size
    rep = np.arange(3 * n_node)
    fixed = np.zeros(3 * n_node, dtype=bool)
    for jj, here in enumerate(mech.attach):
        comps = [2] if jj in compliant else [0, 1, 2]
        raw = 3 * np.array([mech.point_node[lk, k] for lk, k in here])[:, None] + np.array(comps)
        rep[raw] = raw[0]
        if _grounded(mech, jj):
            fixed[raw] = True
    node_dofs, n_free = number_dofs(rep, fixed, n_node)
    elem_dofs = np.concatenate([node_dofs[mech.elem_nodes[:, 0]], node_dofs[mech.elem_nodes[:, 1]]], axis=1)
    mass_dofs = np.full((mech.mass_nodes.size, 3), -1, dtype=int)
    mass_dofs[:, 2] = node_dofs[mech.mass_nodes, 2]
    return dataclasses.replace(mech, node_dofs=node_dofs, elem_dofs=elem_dofs, n_free=n_free, mass_dofs=mass_dofs,
                               node_axis=np.tile([1.0, 0.0], (n_node, 1)))


@dataclass(frozen=True)
class Bearings:
    """Rotational springs of compliant joints out of plane (§19.8): each of the joint's link points
    (after the first; every one at a ground joint) is tied to the first's rotations (to ground) by
    k_t about the first link's axis e and k_b about e⊥, (1/2)Δθᵀ Rᵀ diag(k_t, k_b) R Δθ."""

    dofs: np.ndarray  # (n_b, 6): (θ_X, θ_Y, -1) of the two sides (-1: ground)
    link: np.ndarray  # (n_b,) the link whose axes the spring uses
    local: np.ndarray  # (n_b, 6, 6) in those axes (ψ, β, w per side)

    def stack(self, link_phi: np.ndarray) -> np.ndarray:
        """The springs in ground DOFs, (n_θ, n_b, 6, 6), for the link angles (n_θ, n_link)."""
        phi = link_phi[:, self.link]
        T = el.rotation(phi.ravel()).reshape(phi.shape + (6, 6))
        return el.to_global(self.local, T)


def bearings(mech: Mechanism, oop_mech: Mechanism, stiffness: dict) -> Bearings | None:
    """The :class:`Bearings` of ``stiffness`` {joint name: (k_t, k_b)} (N m/rad, > 0) on the
    out-of-plane numbering ``oop_mech`` (None without any); ValueError naming a bad joint or value."""
    if not stiffness:
        return None
    dofs, link, local = [], [], []
    for name, k in stiffness.items():
        if name not in mech.joint_names:
            raise ValueError(f"bearings: unknown joint {name!r}; known: {', '.join(mech.joint_names)}")
        kt, kb = (np.broadcast_to(np.asarray(k, dtype=float), (2,)) if np.ndim(k) <= 1 else (np.nan,) * 2)
        if not (np.isfinite(kt) and np.isfinite(kb) and kt > 0 and kb > 0):
            raise ValueError(f"bearings.{name}: two stiffnesses (about the link, across it) finite and > 0, "
                             f"N m/rad (got {k!r})")
        jj = mech.joint_names.index(name)
        here = mech.attach[jj]
        nodes = [int(mech.point_node[lk, kk]) for lk, kk in here]
        D = np.zeros((6, 6))
        D[[0, 1], [0, 1]] = D[[3, 4], [3, 4]] = (kt, kb)
        D[[0, 1], [3, 4]] = D[[3, 4], [0, 1]] = (-kt, -kb)
        sides = [(n, -1) for n in nodes] if _grounded(mech, jj) else [(n, nodes[0]) for n in nodes[1:]]
        for a, b in sides:
            rot = lambda n: oop_mech.node_dofs[n, :2] if n >= 0 else np.array([-1, -1])  # noqa: E731
            dofs.append(np.r_[rot(a), -1, rot(b), -1])
            link.append(here[0][0])
            local.append(D)
    return Bearings(np.array(dofs, dtype=int), np.array(link, dtype=int), np.array(local))


def lumped(mech: Mechanism) -> tuple:
    """The lumped-mass diagonal of the out-of-plane model, as ``Model._lumped``: masses on w."""
    return ((mech.mass_dofs[:, 2], mech.mass_value),)


def out_of_plane_stacks(mech: Mechanism, section: Section) -> ElementStacks:
    """The out-of-plane element stacks of ``mech`` (element frame; no skew mass: no Coriolis or
    tangential term acts out of plane, §19.6)."""
    l = mech.elem_length
    B, w = strains(section.ei_out, section.gj, l)
    return ElementStacks(OutOfPlaneElement(), l, mass(mech.elem_rho_a, section.rho_ip, l), None,
                         structural(section.ei_out, section.gj, l), B, w, None,
                         normal=propeller(mech.elem_rho_a, mech.elem_ea, mech.elem_ei, section.ei_out, l))
