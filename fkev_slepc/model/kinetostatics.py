"""Rigid-body kinetostatics (docs/theory.md §7, docs/linkages.md): joint forces, driving torque,
guide reactions and axial forces.

The D'Alembert equations of all moving links (3 per link, each link a rigid body made of its
beams and the particles it carries) are solved for the joint forces and the driving torque.
Without gravity every load is linear in the accelerations, so each result is returned as two
parts: per Ω² (``*_w2``, at Ω = 1, α = 0) and per crank acceleration α (at Ω = 0, α = 1). The
actual value is ``Ω²·x_w2 + α·x_acc``.

Unknowns: at a revolute ground joint, the force on each link point it holds; at a moving joint
with k link points, the forces on the first k-1 (the last is minus their sum: the pin itself is
massless; a lumped mass rides on the link named in the scene); at a prismatic joint, the guide's
normal reaction (the slider block is a particle on its link: the guide takes no force along
itself); plus the driving torque on the driver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.kinematics import Kinematics, perp, rotate, unit_vector, point_local
from fkev_slepc.model.mechanism import Mechanism


@dataclass(frozen=True)
class Loads:
    """Kinetostatic results, each as (per-Ω² part, per-α part)."""

    end_force: tuple[np.ndarray, np.ndarray]  # (n_ang, n_link, 3 points, 2) force on a link point from its joint
    torque: tuple[np.ndarray, np.ndarray]  # (n_ang,) driving torque on the driver
    guide_reaction: tuple[np.ndarray, np.ndarray]  # (n_ang, n_joint) along the guide's left normal; NaN: not prismatic
    axial_right: tuple[np.ndarray, np.ndarray]  # (n_ang, n_el) axial force just inside each element's right node
    beam_accel: tuple[np.ndarray, np.ndarray]  # (n_ang, n_beam) axial rigid accel. of each beam's start


def unknowns(mech: Mechanism) -> tuple[np.ndarray, dict[int, int], int]:
    """Angle-independent: coefficients (n_link, 3, 2, n_unknown) of each link point's force in the unknown vector,
    the slot of each prismatic joint's reaction, and the number of unknowns (torque last)."""
    slot, reaction, n_unk = {}, {}, 0
    for jj, here in enumerate(mech.attach):
        if not np.isnan(mech.joint_guide[jj, 0]):
            reaction[jj] = n_unk
            n_unk += 1
            continue
        own = here if not np.isnan(mech.joint_ground[jj, 0]) else here[:-1]
        for lk, k in own:
            slot[(lk, k)] = n_unk
            n_unk += 2
    coef = np.zeros((mech.n_link, 3, 2, n_unk + 1))  # last column: driving torque
    for jj, here in enumerate(mech.attach):
        if jj in reaction:
            lk, k = here[0]
            coef[lk, k, :, reaction[jj]] = perp(mech.joint_guide[jj])
            continue
        for lk, k in here:
            if (lk, k) in slot:
                coef[lk, k, :, slot[(lk, k)] : slot[(lk, k)] + 2] = np.eye(2)
            else:  # the last point of a moving joint: minus the sum of the others
                for lk2, k2 in here[:-1]:
                    s = slot[(lk2, k2)]
                    coef[lk, k, :, s : s + 2] -= np.eye(2)
    return coef, reaction, n_unk + 1


def _equations(mech: Mechanism, kin: Kinematics, coef: np.ndarray, n_unk: int) -> np.ndarray:
    """The matrix (n_ang, 3 n_link, n_unk) of the D'Alembert equations of every link (force x, y
    and moment about its centroid) in the unknowns of :func:`unknowns`."""
    n_ang, n_link = kin.theta.size, mech.n_link
    if 3 * n_link != n_unk:
        raise ValueError(f"kinetostatics: {3 * n_link} equations for {n_unk} unknowns")
    pts = np.nan_to_num(mech.link_points - mech.body_centroid[:, None, :])  # absent points: coef is 0
    arm = rotate(kin.phi[:, :, None], pts[None])  # (n, l, 3, 2) from the centroid to each point
    A = np.zeros((n_ang, 3 * n_link, n_unk))
    A[:, 0::3] = coef[None, :, :, 0, :].sum(axis=2)
    A[:, 1::3] = coef[None, :, :, 1, :].sum(axis=2)
    A[:, 2::3] = np.einsum("alk,lkx->alx", arm[..., 0], coef[:, :, 1, :]) - np.einsum(
        "alk,lkx->alx", arm[..., 1], coef[:, :, 0, :]
    )
    A[:, 3 * mech.driver + 2, -1] = 1.0
    return A


def _solve(A: np.ndarray, rhs: np.ndarray, good: np.ndarray, coef: np.ndarray, reaction: dict[int, int],
           n_joint: int):
    """Unknowns u of A u = rhs at the ``good`` angles (NaN elsewhere), as (link-point forces
    (n, l, 3, 2), driving torque (n,), guide reactions (n, n_joint))."""
    u = np.full(rhs.shape[:1] + (A.shape[-1],), np.nan)
    if good.any():
        u[good] = np.linalg.solve(A[good], rhs[good][..., None])[..., 0]
    guide = np.full((u.shape[0], n_joint), np.nan)
    for jj, s in reaction.items():
        guide[:, jj] = u[:, s]
    return np.einsum("lkcx,ax->alkc", coef, u), u[:, -1], guide


def solve_loads(mech: Mechanism, kin: Kinematics, plan=None) -> Loads:
    """Joint forces, driving torque, guide reactions and element axial forces (§7) at every angle
    of ``kin``. ``plan``: :func:`unknowns` of ``mech`` when the caller keeps it (it does not
    depend on the angle; a Model builds it once)."""
    coef, reaction, n_unk = unknowns(mech) if plan is None else plan
    n_ang, n_link = kin.theta.size, mech.n_link
    A = _equations(mech, kin, coef, n_unk)
    G = point_local(kin, np.arange(n_link), mech.body_centroid)

    mid_local = 0.5 * (mech.node_local[mech.elem_nodes[:, 0]] + mech.node_local[mech.elem_nodes[:, 1]])
    P_mid = point_local(kin, mech.elem_link, mid_local)
    P_mass = point_local(kin, mech.mass_link, mech.mass_local)
    P_beam = point_local(kin, mech.beam_link, mech.beam_origin)
    e_beam = unit_vector(kin.phi[:, mech.beam_link] + mech.beam_angle)
    good = kin.ok
    results = []
    for part in (2, 1):
        acc_G, acc_phi = G[part], (kin.ddphi if part == 2 else kin.dphi)
        rhs = np.stack([mech.body_mass * acc_G[..., 0], mech.body_mass * acc_G[..., 1],
                        mech.body_inertia * acc_phi], axis=-1).reshape(n_ang, 3 * n_link)
        end_force, torque, guide = _solve(A, rhs, good, coef, reaction, len(mech.joint_names))
        axial = axial_right(mech, end_force, P_mid[part], P_mass[part], e_beam)
        beam_acc = np.einsum("abc,abc->ab", P_beam[part], e_beam)
        results.append((end_force, torque, guide, axial, beam_acc))
    return Loads(*(tuple(r[i] for r in results) for i in range(5)))


def solve_external(mech: Mechanism, kin: Kinematics, link: np.ndarray, point: np.ndarray, force: np.ndarray,
                   moment: np.ndarray, plan=None):
    """Joint forces, driving torque and guide reactions that hold the links, without inertia,
    against external forces ``force`` (n_ang, n_load, 2, ground frame) at link-frame points
    ``point`` (n_load, 2) of links ``link`` (n_load,) and moments ``moment`` (n_ang, n_load)
    (docs/response.md §1.2): the equations of :func:`solve_loads` with right-hand side -ΣF and
    -Σ(r × F + M) about each centroid. Returns (link-point forces, torque, guide reactions)."""
    coef, reaction, n_unk = unknowns(mech) if plan is None else plan
    n_ang, n_link = kin.theta.size, mech.n_link
    A = _equations(mech, kin, coef, n_unk)
    arm = rotate(kin.phi[:, link], np.asarray(point, float) - mech.body_centroid[link])  # centroid -> point
    per = np.stack([force[..., 0], force[..., 1],
                    arm[..., 0] * force[..., 1] - arm[..., 1] * force[..., 0] + moment], axis=-1)
    rhs = np.zeros((n_ang, n_link, 3))
    np.add.at(rhs, (slice(None), np.asarray(link, int)), -per)
    return _solve(A, rhs.reshape(n_ang, 3 * n_link), kin.ok, coef, reaction, len(mech.joint_names))


def axial_right(mech: Mechanism, end_force, acc_mid, acc_mass, e_beam, nodal=None) -> np.ndarray:
    """Axial force (tension > 0) just inside the right node of every element: the component
    along the beam of all forces on the part beyond the cut (joint forces, D'Alembert forces
    of the elements and particles there, and of a ternary branch starting there). ``nodal``:
    optional (nodes, forces (n_ang, n, 2)) of further concentrated forces (process loads)."""
    n_ang, n_node = end_force.shape[0], mech.node_local.shape[0]
    point = np.zeros((n_ang, n_node, 2))  # concentrated forces on each node
    has = mech.point_node >= 0
    np.add.at(point, (slice(None), mech.point_node[has]), end_force[:, has])
    if nodal is not None:
        np.add.at(point, (slice(None), nodal[0]), nodal[1])
    np.add.at(point, (slice(None), mech.mass_nodes), -mech.mass_value[None, :, None] * acc_mass)
    dist = -(mech.elem_rho_a * mech.elem_length)[None, :, None] * acc_mid  # over each element
    right, beam = mech.elem_nodes[:, 1], mech.elem_beam
    last = np.r_[np.flatnonzero(np.diff(beam)), beam.size - 1]  # last element of every beam
    first = np.r_[0, last[:-1] + 1]

    def beyond():  # Σ over each element and the ones after it on its beam
        y = point[:, right] + dist
        cs = np.cumsum(y, axis=1)
        return cs[:, last[beam]] - cs + y

    far = beyond()
    branch = np.flatnonzero(mech.beam_angle != 0.0)
    if branch.size:  # a branch loads its axis beam at its foot: add its total, sum again
        feet = mech.elem_nodes[first[branch], 0]
        np.add.at(point, (slice(None), feet), far[:, first[branch]])
        far = beyond()
    return np.einsum("aec,aec->ae", far - dist, e_beam[:, beam])


def axial_polynomials(mech: Mechanism, kin: Kinematics, loads: Loads, ang: int | None = None):
    """Coefficients (c₀, c₁, c₂) of F(ξ) = c₀ + c₁ξ + c₂ξ² for every element (docs/theory.md §5.4,
    §7.3), as (per-Ω² part, per-α part): each (n_el, 3) at angle index ``ang``, or
    (n_ang, n_el, 3) at every angle of ``kin`` when ``ang`` is None."""
    lk = mech.elem_link
    rho_a, l, s0 = mech.elem_rho_a, mech.elem_length, mech.elem_s0
    at = slice(None) if ang is None else ang
    dphi2 = kin.dphi[at, lk] ** 2
    out = []
    for part, w2 in ((0, dphi2), (1, np.zeros_like(dphi2))):
        F_r = loads.axial_right[part][at]
        a0 = loads.beam_accel[part][at, mech.elem_beam] - w2 * s0
        c0 = F_r - rho_a * a0 * l + 0.5 * rho_a * w2 * l**2
        c1 = rho_a * a0 * l
        c2 = -0.5 * rho_a * w2 * l**2
        out.append(np.stack([c0, c1, c2], axis=-1))
    return out[0], out[1]
