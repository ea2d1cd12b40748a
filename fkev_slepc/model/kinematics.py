"""Rigid-body kinematics (docs/theory.md §3), vectorised over crank angles.

Everything is returned per unit crank speed: with crank angle θ, speed Ω = θ̇ and acceleration
α = θ̈, a link angle obeys φ̇ = φ'Ω and φ̈ = φ''Ω² + φ'α, and a point p obeys ṗ = p'Ω,
p̈ = p''Ω² + p'α, where ' is d/dθ. That split is what lets the operators be assembled once per
angle and combined per speed.

Joints are located in the order planned by :mod:`mechanism`: the driver (clamped at its ground
pivot, direction θ), then RRR dyads in closed form. For the four-bar's dyad at B this is the RBK
routine of the thesis (γ ≥ 0 is the ``left`` branch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.mechanism import Mechanism
from fkev_slepc.scene import Problem, Scene, SceneError


@dataclass(frozen=True)
class Kinematics:
    theta: np.ndarray  # (n_ang,) crank angle, rad
    ok: np.ndarray  # (n_ang,) False where the linkage cannot be assembled
    phi: np.ndarray  # (n_ang, n_link) link angles (root -> tip), rad
    dphi: np.ndarray  # dφ/dθ
    ddphi: np.ndarray  # d²φ/dθ²
    pos: np.ndarray  # (n_ang, n_joint, 2) joint positions, m
    dpos: np.ndarray
    ddpos: np.ndarray
    root: np.ndarray  # (n_ang, n_link, 2) link root positions, and derivatives
    droot: np.ndarray
    ddroot: np.ndarray


def _perp(u: np.ndarray) -> np.ndarray:
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


def _unit(angle: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def _solve2(c1: np.ndarray, c2: np.ndarray, det: np.ndarray, rhs: np.ndarray):
    """Solve [c1 c2] [x; y] = rhs by Cramer's rule, vectorised over angles (NaN where det = 0)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (rhs[:, 0] * c2[:, 1] - rhs[:, 1] * c2[:, 0]) / det
        y = (c1[:, 0] * rhs[:, 1] - c1[:, 1] * rhs[:, 0]) / det
    return x, y


def solve_kinematics(mech: Mechanism, theta) -> Kinematics:
    """Positions, d/dθ and d²/dθ² of every joint and link angle at crank angles ``theta`` (rad)."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    n, nj, nl = theta.size, len(mech.joint_names), mech.n_link
    pos = np.full((n, nj, 2), np.nan)
    dpos = np.zeros((n, nj, 2))
    ddpos = np.zeros((n, nj, 2))
    phi = np.full((n, nl), np.nan)
    dphi = np.zeros((n, nl))
    ddphi = np.zeros((n, nl))
    ok = np.ones(n, dtype=bool)
    ground = ~np.isnan(mech.joint_ground[:, 0])
    pos[:, ground] = mech.joint_ground[ground]

    d = mech.driver
    phi[:, d], dphi[:, d] = theta, 1.0
    if mech.link_tip_joint[d] >= 0:
        L, e = mech.length[d], _unit(theta)
        r = pos[:, mech.link_root_joint[d]]
        t = mech.link_tip_joint[d]
        pos[:, t] = r + L * e
        dpos[:, t] = L * _perp(e)
        ddpos[:, t] = -L * e

    for st in mech.dyads:
        La, Lb = mech.length[st.link_a], mech.length[st.link_b]
        P, dP, ddP = pos[:, st.p], dpos[:, st.p], ddpos[:, st.p]
        Q, dQ, ddQ = pos[:, st.q], dpos[:, st.q], ddpos[:, st.q]
        dq = Q - P
        dist = np.hypot(dq[:, 0], dq[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            cos_g = (La**2 + dist**2 - Lb**2) / (2 * La * dist)
        good = np.abs(cos_g) <= 1.0
        psi_a = np.arctan2(dq[:, 1], dq[:, 0]) + st.sign * np.arccos(np.clip(cos_g, -1, 1))
        ua = _unit(psi_a)
        J = P + La * ua
        vb = J - Q
        psi_b = np.arctan2(vb[:, 1], vb[:, 0])
        ub = _unit(psi_b)
        # [La ua⊥, -Lb ub⊥] [ψa'; ψb'] = Q' - P'   (loop closure differentiated once, twice)
        c1, c2 = La * _perp(ua), -Lb * _perp(ub)
        det = c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]
        good &= np.abs(det) > 1e-12 * La * Lb  # toggle (dead-centre) positions are singular

        da, db = _solve2(c1, c2, det, dQ - dP)
        rhs2 = ddQ - ddP + La * da[:, None] ** 2 * ua - Lb * db[:, None] ** 2 * ub
        dda, ddb = _solve2(c1, c2, det, rhs2)
        pos[:, st.joint] = J
        dpos[:, st.joint] = dP + La * (da[:, None] * _perp(ua))
        ddpos[:, st.joint] = ddP + La * (dda[:, None] * _perp(ua) - da[:, None] ** 2 * ua)
        # A link's own angle runs root -> tip: flip by π when its root is at the dyad joint.
        phi[:, st.link_a] = psi_a + (0.0 if st.a_tip_at_joint else np.pi)
        phi[:, st.link_b] = psi_b + (0.0 if st.b_tip_at_joint else np.pi)
        dphi[:, st.link_a], ddphi[:, st.link_a] = da, dda
        dphi[:, st.link_b], ddphi[:, st.link_b] = db, ddb
        ok &= good

    phi = np.mod(phi + np.pi, 2 * np.pi) - np.pi
    rj = mech.link_root_joint
    root, droot, ddroot = pos[:, rj], dpos[:, rj], ddpos[:, rj]
    bad = ~ok
    for arr in (phi, dphi, ddphi, pos, dpos, ddpos, root, droot, ddroot):
        arr[bad] = np.nan
    return Kinematics(theta, ok, phi, dphi, ddphi, pos, dpos, ddpos, root, droot, ddroot)


def point_on_link(kin: Kinematics, mech: Mechanism, link: np.ndarray, s: np.ndarray):
    """Position, d/dθ, d²/dθ² of points at stations ``s`` on links ``link``: arrays (n_ang, n_pt, 2)."""
    e = _unit(kin.phi[:, link])
    ep = _perp(e)
    dphi, ddphi = kin.dphi[:, link, None], kin.ddphi[:, link, None]
    s = np.asarray(s, dtype=float)[None, :, None]
    p = kin.root[:, link] + s * e
    dp = kin.droot[:, link] + s * dphi * ep
    ddp = kin.ddroot[:, link] + s * (ddphi * ep - dphi**2 * e)
    return p, dp, ddp


def assembly_problems(scene: Scene) -> list[Problem]:
    """One problem per requested crank angle at which the linkage cannot be assembled."""
    from fkev_slepc.model.mechanism import build_mechanism

    try:
        mech = build_mechanism(scene)
    except SceneError as err:
        return err.problems
    angles = np.asarray(scene.analysis.crank_angles_deg, dtype=float)
    kin = solve_kinematics(mech, np.radians(angles))
    return [
        Problem(
            f"analysis.crank_angles_deg[{i}]",
            f"the linkage cannot be assembled at crank angle {angles[i]:g} deg "
            "(a dyad cannot close, or it is at a dead-centre position)",
        )
        for i in np.flatnonzero(~kin.ok)
    ]
