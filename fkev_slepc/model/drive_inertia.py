"""The rigid linkage as the drive sees it (docs/theory.md §20.2): its equivalent inertia J_L(θ)
= 2T/θ̇², the derivative J_L′(θ) from the second derivatives of the kinematics, and the load
torque T_L(θ) of gravity and the process loads (the driving torque of ``fkev loads`` at
Ω = α = 0), vectorised over crank angles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.joint_loads import gravity_kinematics
from fkev_slepc.model.kinematics import Kinematics, point_local, solve_kinematics
from fkev_slepc.model.kinetostatics import solve_loads
from fkev_slepc.model.mechanism import Mechanism
from fkev_slepc.model.process_loads import process_kinetostatics, process_points


@dataclass(frozen=True)
class LinkageInertia:
    """J_L, J_L′ (kg m²) and T_L (N m) at crank angles ``theta`` (rad)."""

    theta: np.ndarray
    inertia: np.ndarray  # J_L(θ)
    inertia_slope: np.ndarray  # dJ_L/dθ
    load_torque: np.ndarray  # T_L(θ): gravity and process loads, held quasi-statically


def equivalent_inertia(mech: Mechanism, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    """(J_L, J_L′) at the angles of ``kin``: Σ m|G′|² + I φ′² over the links as rigid bodies and
    its θ-derivative 2Σ (m G′·G″ + I φ′φ″)."""
    _, dG, ddG = point_local(kin, np.arange(mech.n_link), mech.body_centroid)
    m, I = mech.body_mass, mech.body_inertia
    J = (m * (dG**2).sum(-1) + I * kin.dphi**2).sum(-1)
    dJ = 2.0 * (m * (dG * ddG).sum(-1) + I * kin.dphi * kin.ddphi).sum(-1)
    return J, dJ


def load_torque(mech: Mechanism, kin: Kinematics, gravity=(0.0, 0.0)) -> np.ndarray:
    """T_L(θ): the driving torque that holds gravity ``gravity`` (m/s², ground frame) and the
    scene's process loads in equilibrium, by the kinetostatics of ``fkev loads`` at Ω = α = 0."""
    g = np.asarray(gravity, dtype=float).reshape(2)
    torque = np.zeros(kin.theta.size)
    if np.any(g):
        torque = torque + solve_loads(mech, gravity_kinematics(kin, g)).torque[0]
    points = process_points(mech)
    if points.size:
        torque = torque + process_kinetostatics(mech, kin, points).torque
    return torque


def linkage_inertia(mech: Mechanism, theta, gravity=(0.0, 0.0)) -> LinkageInertia:
    """:class:`LinkageInertia` at crank angles ``theta`` (rad); every angle must assemble."""
    theta = np.asarray(theta, dtype=float)
    kin = solve_kinematics(mech, theta)
    if not kin.ok.all():
        bad = np.degrees(theta[~kin.ok][0])
        raise ValueError(f"the linkage cannot be assembled at crank angle {bad:g} deg")
    J, dJ = equivalent_inertia(mech, kin)
    return LinkageInertia(theta, J, dJ, load_torque(mech, kin, gravity))
