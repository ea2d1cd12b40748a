"""Rigid-body kinetostatics (docs/theory.md §7): joint forces, driving torque, axial forces.

The D'Alembert equations of all moving links (3 per link) are solved for the pin forces and
the driving torque. Without gravity every load is linear in the accelerations, so each result
is returned as two parts: per Ω² (``*_w2``, at Ω = 1, α = 0) and per crank acceleration α
(``*_acc``, at Ω = 0, α = 1). The actual value is ``Ω²·x_w2 + α·x_acc``.

Unknowns: at a ground joint, the force on each link end it holds; at a moving joint with k link
ends, the forces on the first k-1 (the last is minus their sum: the pin itself is massless; a
lumped mass rides on the link named in the scene); plus the driving torque on the driver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.kinematics import Kinematics, _unit, point_on_link
from fkev_slepc.model.mechanism import Mechanism


@dataclass(frozen=True)
class Loads:
    """Kinetostatic results, each as (per-Ω² part, per-α part)."""

    end_force: tuple[np.ndarray, np.ndarray]  # (n_ang, n_link, 2 ends, 2) force on link end from its joint
    torque: tuple[np.ndarray, np.ndarray]  # (n_ang,) driving torque on the driver
    tip_load: tuple[np.ndarray, np.ndarray]  # (n_ang, n_link) axial load at the tip, tension > 0
    root_accel: tuple[np.ndarray, np.ndarray]  # (n_ang, n_link) axial rigid accel. of the root


def _end_unknowns(mech: Mechanism) -> tuple[np.ndarray, int]:
    """Map (link, end) -> coefficients (2, n_unknown) of its force in the unknown vector."""
    ends = []  # (joint, link, end) in scene order
    for jj, joint in enumerate(mech.scene.joints):
        for e in joint.ends:
            ends.append((jj, mech.link_names.index(e.link), 1 if e.end == "tip" else 0))
    ground = ~np.isnan(mech.joint_ground[:, 0])
    n_unk = 0
    slot = {}
    for jj in range(len(mech.joint_names)):
        mine = [(lk, en) for (j2, lk, en) in ends if j2 == jj]
        own = mine if ground[jj] else mine[:-1]
        for lk, en in own:
            slot[(lk, en)] = n_unk
            n_unk += 2
    coef = np.zeros((mech.n_link, 2, 2, n_unk + 1))  # last column: driving torque
    for jj in range(len(mech.joint_names)):
        mine = [(lk, en) for (j2, lk, en) in ends if j2 == jj]
        for lk, en in mine:
            if (lk, en) in slot:
                k = slot[(lk, en)]
                coef[lk, en, :, k : k + 2] = np.eye(2)
            else:  # the last end of a moving joint: minus the sum of the others
                for lk2, en2 in mine[:-1]:
                    k = slot[(lk2, en2)]
                    coef[lk, en, :, k : k + 2] -= np.eye(2)
    return coef, n_unk + 1


def solve_loads(mech: Mechanism, kin: Kinematics) -> Loads:
    """Joint forces, driving torque and link tip loads from the rigid-body inertia loads (§7)."""
    coef, n_unk = _end_unknowns(mech)
    n_ang, n_link = kin.theta.size, mech.n_link
    if 3 * n_link != n_unk:
        raise ValueError(f"kinetostatics: {3 * n_link} equations for {n_unk} unknowns")
    m, L = mech.link_mass, mech.length
    J = m * L**2 / 12.0
    links = np.arange(n_link)
    G, dG, ddG = point_on_link(kin, mech, links, L / 2)
    # End positions relative to the centroid: root at -L/2 e, tip at +L/2 e.
    e = _unit(kin.phi)
    arm = np.stack([-0.5 * L[None, :, None] * e, 0.5 * L[None, :, None] * e], axis=2)  # (n,l,2,2)

    A = np.zeros((n_ang, 3 * n_link, n_unk))
    A[:, 0::3] = coef[None, :, :, 0, :].sum(axis=2)
    A[:, 1::3] = coef[None, :, :, 1, :].sum(axis=2)
    A[:, 2::3] = np.einsum("alk,lkx->alx", arm[..., 0], coef[:, :, 1, :]) - np.einsum(
        "alk,lkx->alx", arm[..., 1], coef[:, :, 0, :]
    )
    A[:, 3 * mech.driver + 2, -1] = 1.0

    # Lumped masses: particles at their joint, carried by a link end.
    mj = mech.mass_joint
    results = []
    for acc_G, acc_phi, acc_J in ((ddG, kin.ddphi, kin.ddpos), (dG, kin.dphi, kin.dpos)):
        F = -m[None, :, None] * acc_G  # D'Alembert forces (n, l, 2)
        Mz = -J[None, :] * acc_phi
        Fp = -mech.mass_value[None, :, None] * acc_J[:, mj]  # (n, n_mass, 2)
        rp = kin.pos[:, mj] - G[:, mech.mass_link]
        np.add.at(F, (slice(None), mech.mass_link), Fp)
        np.add.at(Mz, (slice(None), mech.mass_link), rp[..., 0] * Fp[..., 1] - rp[..., 1] * Fp[..., 0])
        rhs = -np.stack([F[..., 0], F[..., 1], Mz], axis=-1).reshape(n_ang, 3 * n_link)
        u = np.full((n_ang, n_unk), np.nan)
        good = kin.ok
        if good.any():
            u[good] = np.linalg.solve(A[good], rhs[good][..., None])[..., 0]
        end_force = np.einsum("lecx,ax->alec", coef, u)
        tip = end_force[:, :, 1, :].copy()
        tip_mass = mech.mass_at_tip
        np.add.at(tip, (slice(None), mech.mass_link[tip_mass]), Fp[:, tip_mass])
        results.append((end_force, u[:, -1], np.einsum("alc,alc->al", tip, e)))

    root_acc = (
        np.einsum("alc,alc->al", kin.ddroot, e),
        np.einsum("alc,alc->al", kin.droot, e),
    )
    return Loads(
        end_force=(results[0][0], results[1][0]),
        torque=(results[0][1], results[1][1]),
        tip_load=(results[0][2], results[1][2]),
        root_accel=root_acc,
    )


def axial_polynomials(mech: Mechanism, kin: Kinematics, loads: Loads, ang: int):
    """Coefficients (c₀, c₁, c₂) of F(ξ) = c₀ + c₁ξ + c₂ξ² for every element at angle index ``ang``
    (docs/theory.md §5.4, §7.3), as (per-Ω² part, per-α part), each (n_el, 3)."""
    lk = mech.elem_link
    rho_a, l, s0, L = mech.rho_a[lk], mech.elem_length, mech.elem_s0, mech.length[lk]
    out = []
    for part, w2 in ((0, kin.dphi[ang, lk] ** 2), (1, np.zeros(lk.size))):
        P = loads.tip_load[part][ang, lk]
        a_r = loads.root_accel[part][ang, lk]
        s1 = s0 + l
        F_r = P - rho_a * a_r * (L - s1) + 0.5 * rho_a * w2 * (L**2 - s1**2)
        a0 = a_r - w2 * s0
        c0 = F_r - rho_a * a0 * l + 0.5 * rho_a * w2 * l**2
        c1 = rho_a * a0 * l
        c2 = -0.5 * rho_a * w2 * l**2
        out.append(np.stack([c0, c1, c2], axis=1))
    return out[0], out[1]

