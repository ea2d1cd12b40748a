"""The model's first two layers: constant element stacks, and the state of the rigid motion at
an array of crank angles (docs/theory.md §3, §5, §8).

* :class:`ElementStacks` -- the element matrices in the element frame, (n_el, n_dof, n_dof):
  consistent mass m, secondary (skew) mass m_a, structural stiffness k_s and its factored form
  (strain operator B, weights w), the slider node frames, and the three basis stacks of the
  axial-force stiffness k_g (k_g is linear in the coefficients of F(ξ) = c₀ + c₁ξ + c₂ξ²).
  Independent of angle and speed: built once per model.
* :class:`AngleState` -- for an array of crank angles θ (n_θ,): the kinematics (vectorised), each
  element's direction φ_e and its link's φ', φ'' (n_θ, n_el), the transformations
  T (n_θ, n_el, n_dof, n_dof) with q_local = T q_dof (slider node frames included), and the mask
  ``ok`` of the angles at which the linkage can be assembled (elsewhere everything is NaN).
  Optionally the kinetostatic axial-force polynomials (n_θ, n_el, 3), per Ω² and per α.

Everything is numpy over elements and angles; nothing here loops over either.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model import elements as el
from fkev_slepc.model.element_types import ElementType
from fkev_slepc.model.kinematics import Kinematics, solve_kinematics
from fkev_slepc.model.kinetostatics import Loads, axial_polynomials, solve_loads, unknowns
from fkev_slepc.model.mechanism import Mechanism
from fkev_slepc.model.timoshenko import section_shear


def node_frames(mech, n_dof: int = 6) -> np.ndarray | None:
    """Per element blockdiag(Cₙ₁, 1, Cₙ₂, 1, I), Cₙ = [a, a⊥] with a = ``node_axis``: the node's
    translations taken along/normal to a slider's guide (docs/linkages.md); internal DOFs of
    higher-order elements (beyond the sixth) are unchanged. None if no node has a rotated frame
    (then the element transformation is T alone)."""
    a = mech.node_axis
    if np.all(a[:, 0] == 1.0):
        return None
    C = np.zeros((mech.elem_nodes.shape[0], n_dof, n_dof))
    C[:, 6:, 6:] = np.eye(n_dof - 6)
    for o, nodes in ((0, mech.elem_nodes[:, 0]), (3, mech.elem_nodes[:, 1])):
        ax, ay = a[nodes, 0], a[nodes, 1]
        C[:, o, o], C[:, o, o + 1], C[:, o + 1, o], C[:, o + 1, o + 1] = ax, -ay, ay, ax
        C[:, o + 2, o + 2] = 1.0
    return C


@dataclass(frozen=True)
class ElementStacks:
    """Constant element data of a mechanism, element frame (local DOFs of ``element``)."""

    element: ElementType
    length: np.ndarray  # (n_el,)
    mass: np.ndarray  # (n_el, n_dof, n_dof) m
    skew_mass: np.ndarray  # m_a (skew-symmetric)
    structural: np.ndarray  # k_s
    strain: np.ndarray  # (n_el, n_s, n_dof) B, with k_s = Bᵀ diag(w) B
    strain_weight: np.ndarray  # (n_el, n_s) w
    node_frames: np.ndarray | None  # (n_el, n_dof, n_dof) or None (no slider node)
    normal: np.ndarray | None = None  # n of the normal term -φ̇² n; None: the mass m (in plane, §6)
    shear_parameter: np.ndarray | None = None  # (n_el,) Φ of the Timoshenko element (§22), else None

    @property
    def n_el(self) -> int:
        return self.length.size

    @property
    def n_dof(self) -> int:
        return self.element.n_dof

    def axial_force(self, c: np.ndarray) -> np.ndarray:
        """k_g stacks (..., n_el, n_dof, n_dof) of the axial-force polynomials c (..., n_el, 3)."""
        lead = c.shape[:-2]
        l = np.broadcast_to(self.length, lead + (self.n_el,)).reshape(-1)
        if self.shear_parameter is None:
            k = self.element.axial_force(c.reshape(-1, 3), l)
        else:
            phi = np.broadcast_to(self.shear_parameter, lead + (self.n_el,)).reshape(-1)
            k = self.element.axial_force(c.reshape(-1, 3), l, phi)
        return k.reshape(lead + (self.n_el, self.n_dof, self.n_dof))


def element_stacks(mech: Mechanism, et: ElementType) -> ElementStacks:
    """The element stacks of ``mech`` for element type ``et``."""
    l, ra, ei = mech.elem_length, mech.elem_rho_a, mech.elem_ei
    if et.name != "timoshenko":
        B, w = et.strains(mech.elem_ea, ei, l)
        return ElementStacks(et, l, et.mass(ra, l), et.skew_mass(ra, l), et.structural(mech.elem_ea, ei, l), B, w,
                             node_frames(mech, et.n_dof))
    sh = section_shear(mech.elem_piece)
    B, w = et.strains(mech.elem_ea, ei, l, sh)
    return ElementStacks(et, l, et.mass(ra, l, sh, ei), et.skew_mass(ra, l, sh, ei),
                         et.structural(mech.elem_ea, ei, l, sh), B, w, node_frames(mech, et.n_dof),
                         normal=et.normal_mass(ra, l, sh, ei), shear_parameter=sh.parameter(ei, l))


@dataclass(frozen=True)
class AngleState:
    """The rigid motion at crank angles ``theta`` (n_θ,), per unit crank speed (docs/theory.md §3):
    a link's rates are φ̇ = φ'Ω and φ̈ = φ''Ω² + φ'α."""

    theta: np.ndarray  # (n_θ,) rad
    ok: np.ndarray  # (n_θ,) False where the linkage cannot be assembled (NaN data there)
    kinematics: Kinematics
    phi: np.ndarray  # (n_θ, n_el) direction of each element (its link's angle + its beam's)
    dphi: np.ndarray  # (n_θ, n_el) φ' of each element's link
    ddphi: np.ndarray  # (n_θ, n_el) φ'' of each element's link
    T: np.ndarray  # (n_θ, n_el, n_dof, n_dof): q_local = T q_dof (rotation x slider node frame)
    loads: Loads | None = None  # rigid-body kinetostatics (None unless asked for)
    axial: tuple[np.ndarray, np.ndarray] | None = None  # (per Ω², per α) (n_θ, n_el, 3)

    @property
    def size(self) -> int:
        return self.theta.size


def angle_state(mech: Mechanism, stacks: ElementStacks, theta, with_loads: bool = False,
                plan=None) -> AngleState:
    """The :class:`AngleState` of ``mech`` at crank angles ``theta`` (rad; scalar or array).

    ``with_loads``: also solve the rigid-body kinetostatics and the element axial-force
    polynomials (needed by the pseudo-normal term); ``plan``: the angle-independent
    :func:`~fkev_slepc.model.kinetostatics.unknowns` of ``mech``, if the caller keeps it.
    """
    kin = solve_kinematics(mech, theta)
    lk = mech.elem_link
    phi = kin.phi[:, lk] + mech.elem_angle
    T = el.rotation(phi.ravel(), stacks.n_dof).reshape(phi.shape + (stacks.n_dof, stacks.n_dof))
    if stacks.node_frames is not None:
        T = T @ stacks.node_frames
    T[~kin.ok] = np.nan  # every derived piece NaN there, as the kinematics are
    loads = axial = None
    if with_loads:
        loads = solve_loads(mech, kin, unknowns(mech) if plan is None else plan)
        axial = axial_polynomials(mech, kin, loads)
    return AngleState(kin.theta, kin.ok, kin, phi, kin.dphi[:, lk], kin.ddphi[:, lk], T, loads, axial)
