"""Rigid-body inertia loads on the elastic DOFs (docs/theory.md §6, "Load pieces" of
docs/engine.md "Vectorised pieces"), at an array of crank angles.

The part of the kinetic energy linear in the elastic coordinates gives, for every element, the
consistent load f_e = -∫ρA Nᵀ Qᵀ a_rigid dx (a_rigid the acceleration of the material point in the
rigid motion, Q the element frame); the terms from the frame's rotation cancel. Over a rigid
element a_rigid is linear in x, and the element's shape functions reproduce a linear field
exactly: with a_L, a_R the rigid accelerations of its nodes in element components and φ̈ the
angular acceleration of its link, the field's element DOFs are (a_L, φ̈, a_R, φ̈, 0…) and

    f_e = -m (a_Lu, a_Lv, φ̈, a_Ru, a_Rv, φ̈, 0, …)      (m the consistent mass, §5.1),

then Tᵀ f_e on the model's DOFs. A lumped mass or slider block adds -m_P a_P on its translations
(in its node frame) and -J_P φ̈ on its rotation. As everything of the rigid motion, the loads are
linear in Ω² and in the crank acceleration α (a = p''Ω² + p'α, φ̈ = φ''Ω² + φ'α): they are
returned per Ω² (at α = 0) and per α (at Ω = 0). Gravity is the same load for a uniform frame
acceleration: the ``gravity`` piece is the load of 1 m/s² acting along -Y (frame acceleration
(0, +1)), ``gravity_x`` of 1 m/s² along -X.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.assembly import Pattern
from fkev_slepc.model.kinematics import point_local
from fkev_slepc.model.mechanism import Mechanism
from fkev_slepc.model.stacks import AngleState, ElementStacks

PARTS = ("per_w2", "per_accel", "gravity", "gravity_x")


@dataclass(frozen=True)
class ElementLoads:
    """Loads before assembly, on the model's DOF frame (slider node frames included): per
    element (n_θ, n_el, n_dof) and per particle (n_θ, n_mass, 3) on ``Mechanism.mass_dofs``;
    each a dict over :data:`PARTS`."""

    element: dict[str, np.ndarray]
    particle: dict[str, np.ndarray]


@dataclass(frozen=True)
class LoadPieces:
    """Rigid-body inertia load vectors on the free DOFs (the numbering of ``Model.pattern``),
    (n_θ, n_free) each: f(θ) = Ω² per_w2 + α per_accel + g gravity + g_x gravity_x (N, N·m).
    NaN rows where ``ok`` is False."""

    theta: np.ndarray  # (n_θ,) rad
    ok: np.ndarray  # (n_θ,)
    per_w2: np.ndarray  # per Ω² (rad/s)², at α = 0
    per_accel: np.ndarray  # per crank acceleration α (rad/s²), at Ω = 0
    gravity: np.ndarray  # per g (m/s²), gravity along -Y
    gravity_x: np.ndarray  # per g_x (m/s²), gravity along -X

    def total(self, omega: float, accel: float = 0.0, g: float = 0.0, g_x: float = 0.0) -> np.ndarray:
        """The load vectors (n_θ, n_free) at crank speed ``omega``, acceleration ``accel`` and
        gravity ``g`` along -Y and ``g_x`` along -X (m/s²; 0: none)."""
        f = omega * omega * self.per_w2 + accel * self.per_accel
        if g:
            f = f + g * self.gravity
        return f + g_x * self.gravity_x if g_x else f


def rigid_fields(mech: Mechanism, stacks: ElementStacks, state: AngleState) -> dict[str, np.ndarray]:
    """Element DOFs (n_θ, n_el, n_dof, element frame) of the rigid acceleration field of every
    :data:`PARTS` piece: (a_Lu, a_Lv, φ̈, a_Ru, a_Rv, φ̈, 0…), linear along the element; the
    element's consistent load is -m of it and its distributed load -ρA a(ξ) (docs/theory.md §6)."""
    kin = state.kinematics
    _, d_node, dd_node = point_local(kin, mech.node_link, mech.node_local)
    left, right = mech.elem_nodes[:, 0], mech.elem_nodes[:, 1]
    c, s = np.cos(state.phi), np.sin(state.phi)

    def local(a):  # element components (u, v) of global vectors a (n_θ, n_el, 2)
        return c * a[..., 0] + s * a[..., 1], c * a[..., 1] - s * a[..., 0]

    shape = state.phi.shape + (stacks.n_dof,)
    fields = {}
    for part, acc, rate in (("per_w2", dd_node, state.ddphi), ("per_accel", d_node, state.dphi)):
        q = np.zeros(shape)
        (q[..., 0], q[..., 1]), (q[..., 3], q[..., 4]) = local(acc[:, left]), local(acc[:, right])
        q[..., 2] = q[..., 5] = rate
        fields[part] = q
    for part, frame in (("gravity", (0.0, 1.0)), ("gravity_x", (1.0, 0.0))):  # 1 m/s² along -Y, -X
        q = np.zeros(shape)  # the element components of the uniform frame acceleration
        q[..., 0] = q[..., 3] = c * frame[0] + s * frame[1]
        q[..., 1] = q[..., 4] = c * frame[1] - s * frame[0]
        fields[part] = q
    return fields


def element_loads(mech: Mechanism, stacks: ElementStacks, state: AngleState) -> ElementLoads:
    """The consistent element loads and the particle loads at the angles of ``state``."""
    kin = state.kinematics
    fields = rigid_fields(mech, stacks, state)
    T = state.T
    Tt = np.swapaxes(T, -1, -2)
    element = {k: -(Tt @ (stacks.mass @ q[..., None]))[..., 0] for k, q in fields.items()}

    axis = mech.node_axis[mech.mass_nodes]  # (n_mass, 2) the node frame of each particle
    normal = np.stack([-axis[:, 1], axis[:, 0]], axis=-1)
    _, d_p, dd_p = point_local(kin, mech.mass_link, mech.mass_local)
    up, right = np.broadcast_to([0.0, 1.0], d_p.shape), np.broadcast_to([1.0, 0.0], d_p.shape)
    m, J = mech.mass_value, mech.mass_inertia
    particle = {}
    for part, acc, rate in (("per_w2", dd_p, kin.ddphi), ("per_accel", d_p, kin.dphi), ("gravity", up, None),
                            ("gravity_x", right, None)):
        f = -m[:, None] * acc
        moment = np.zeros(f.shape[:-1]) if rate is None else -J * rate[:, mech.mass_link]
        particle[part] = np.stack([np.sum(f * axis, -1), np.sum(f * normal, -1), moment], axis=-1)
    return ElementLoads(element, particle)


def assemble_loads(mech: Mechanism, stacks: ElementStacks, pattern: Pattern, state: AngleState) -> LoadPieces:
    """The :class:`LoadPieces` at the angles of ``state``: element and particle loads scattered
    onto the free DOFs by :meth:`Pattern.scatter_vector`."""
    loads = element_loads(mech, stacks, state)
    vec = {k: pattern.scatter_vector(loads.element[k]) + pattern.scatter_vector(loads.particle[k], mech.mass_dofs)
           for k in PARTS}
    return LoadPieces(state.theta, state.ok, **vec)
