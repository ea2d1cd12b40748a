"""Newton-Euler and power checks of a mechanism's kinetostatics from first principles: every
element a uniform slender rod, every particle (lumped mass, slider block) a point mass with its
rotary inertia; no use of the links' composite rigid-body properties."""

from __future__ import annotations

import numpy as np

from fkev_slepc.model.kinematics import point_local, solve_kinematics
from fkev_slepc.model.kinetostatics import solve_loads


def _cross(r, f):
    return r[..., 0] * f[..., 1] - r[..., 1] * f[..., 0]


def _pieces(mech):
    """(link, link-frame point, mass, own rotary inertia) of every element and particle."""
    mid = 0.5 * (mech.node_local[mech.elem_nodes[:, 0]] + mech.node_local[mech.elem_nodes[:, 1]])
    me = mech.elem_rho_a * mech.elem_length
    link = np.concatenate([mech.elem_link, mech.mass_link])
    local = np.concatenate([mid, mech.mass_local.reshape(-1, 2)])
    mass = np.concatenate([me, mech.mass_value])
    inertia = np.concatenate([me * mech.elem_length**2 / 12, mech.mass_inertia])
    return link, local, mass, inertia


def newton_euler_residual(mech, theta, omega, alpha):
    """Largest relative residual of ΣF = Σ m a and ΣM_root = Σ (r × m a + J φ̈) over all links."""
    kin = solve_kinematics(mech, theta)
    loads = solve_loads(mech, kin)
    f = omega**2 * loads.end_force[0] + alpha * loads.end_force[1]  # (n, link, point, 2)
    torque = omega**2 * loads.torque[0] + alpha * loads.torque[1]
    return newton_euler_of(mech, kin, f, torque, omega, alpha)


def newton_euler_of(mech, kin, f, torque, omega, alpha, gravity=(0.0, 0.0)):
    """The same residual for given link-point forces ``f`` (n, link, point, 2; NaN or 0 where a
    link has no such point) and driving torque, under gravity ``gravity`` (m/s²): ΣF + Σ m g =
    Σ m a and ΣM_root + Σ r × m g = Σ (r × m a + J φ̈)."""
    theta = kin.theta
    f = np.nan_to_num(f)
    g = np.asarray(gravity, dtype=float)
    link, local, mass, inertia = _pieces(mech)
    _, dp, ddp = point_local(kin, link, local)
    acc = omega**2 * ddp + alpha * dp - g  # D'Alembert: gravity as the acceleration -g
    th_dd = omega**2 * kin.ddphi + alpha * kin.dphi
    pts = np.nan_to_num(mech.link_points)
    x_pts = point_local(kin, np.repeat(np.arange(mech.n_link), 3), pts.reshape(-1, 2))[0]
    x_pts = x_pts.reshape(theta.size, mech.n_link, 3, 2)
    p = point_local(kin, link, local)[0]
    n, nl = theta.size, mech.n_link
    need_F = np.zeros((n, nl, 2))
    need_M = np.zeros((n, nl))
    np.add.at(need_F, (slice(None), link), mass[None, :, None] * acc)
    np.add.at(need_M, (slice(None), link),
              _cross(p - kin.root[:, link], mass[None, :, None] * acc) + inertia * th_dd[:, link])
    sumF = f.sum(axis=2)
    sumM = _cross(x_pts - kin.root[:, :, None], f).sum(axis=2)
    sumM[:, mech.driver] += torque
    scale_F = np.abs(need_F).max() + np.abs(f).max()
    scale_M = np.abs(need_M).max() + np.abs(sumM).max()
    return max(np.abs(sumF - need_F).max() / scale_F, np.abs(sumM - need_M).max() / scale_M)


def kinetic_energy(mech, theta, omega):
    """E_k at crank speed ``omega`` and angles ``theta``."""
    kin = solve_kinematics(mech, theta)
    link, local, mass, inertia = _pieces(mech)
    _, dp, _ = point_local(kin, link, local)
    return 0.5 * omega**2 * (mass * (dp**2).sum(-1) + inertia * kin.dphi[:, link] ** 2).sum(-1)


def power_residual(mech, theta, omega=700.0, h=1e-5):
    """T·Ω against dE_k/dt (central difference) at constant crank speed: (T Ω, dE/dt)."""
    dE = (kinetic_energy(mech, theta + h, omega) - kinetic_energy(mech, theta - h, omega)) / (2 * h) * omega
    kin = solve_kinematics(mech, theta)
    torque = omega**2 * solve_loads(mech, kin).torque[0]
    return torque * omega, dE
