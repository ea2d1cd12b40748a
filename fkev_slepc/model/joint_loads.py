"""Rigid-body kinetostatics as a result (docs/response.md §1): joint forces, link axial forces,
guide reactions and the driving torque over the crank cycle at one crank speed.

:mod:`fkev_slepc.model.kinetostatics` solves the D'Alembert equations of every link for the
joint forces, as a per-Ω² part and a per-crank-acceleration part (it needs them for the
axial-force stiffness). This module combines them for an operating point (Ω, α, gravity),
vectorised over crank angles, and names them the way a designer reads them:

* ``end_force[a, l, k]``: the force (ground frame, N) that the joint at point ``k`` (root, tip,
  third) of link ``l`` exerts on the link, with its components along the link (root -> tip)
  and along the link's left normal;
* per joint, ``joint_force``: at a ground joint the bearing reaction, the total force of the
  ground on the linkage there (the bearing carries its opposite); at a moving pin the force on
  the first link end the scene's ``connects`` names (the other link feels its opposite, or
  with three link ends see ``end_force``); at a slider the guide's normal reaction on the link;
* the axial force (tension > 0) along every element, F(ξ) = c₀ + c₁ξ + c₂ξ²
  (kinetostatics.axial_polynomials, evaluated for all angles at once);
* the driving torque on the crank and the power balance τΩ = dE_k/dt + dE_p/dt.

Gravity (``gravity_m_s2``, a ground-frame vector) enters as the uniform acceleration -g of every
material point in the D'Alembert equations: joint forces solve Σ F = m (a - g).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fkev_slepc.model.kinematics import Kinematics, perp, unit_vector, point_local, solve_kinematics
from fkev_slepc.model.kinetostatics import solve_loads
from fkev_slepc.model.mechanism import Mechanism
from fkev_slepc.model.process_loads import process_kinetostatics, process_points
from fkev_slepc.status import json_list

POINT_NAMES = ("root", "tip", "third")


@dataclass(frozen=True)
class JointLoads:
    """Kinetostatic loads at crank angles ``theta`` for speed Ω, acceleration α and gravity g.

    Arrays are over angles first; NaN where the linkage cannot be assembled (``ok`` False).
    """

    theta: np.ndarray  # (n,) rad
    ok: np.ndarray  # (n,)
    speed: float  # Ω, rad/s
    accel: float  # α, rad/s²
    gravity: np.ndarray  # (2,) m/s², ground frame
    joint_names: tuple[str, ...]
    link_names: tuple[str, ...]
    attach: tuple[tuple[tuple[int, int], ...], ...]  # per joint: (link, point) it holds
    joint_ground: np.ndarray  # (n_joint,) bool: a revolute ground joint (bearing)
    end_force: np.ndarray  # (n, n_link, 3, 2) N, force from the joint on each link point (NaN: none)
    end_along: np.ndarray  # (n, n_link, 3) along the link, root -> tip
    end_normal: np.ndarray  # (n, n_link, 3) along the link's left normal
    joint_force: np.ndarray  # (n, n_joint, 2) N (see the module docstring)
    guide_reaction: np.ndarray  # (n, n_joint) N along the guide's left normal; NaN: not prismatic
    torque: np.ndarray  # (n,) N m on the driver
    elem_link: np.ndarray  # (n_el,)
    elem_axis: np.ndarray  # (n_el,) bool: on its link's axis beam (not a ternary branch)
    elem_s: np.ndarray  # (n_el, 2) stations of each element's ends along its beam, m
    axial_coef: np.ndarray  # (n, n_el, 3) F(ξ) = c₀ + c₁ξ + c₂ξ², N (tension > 0)
    kinetic_energy: np.ndarray  # (n,) J
    power: np.ndarray  # (n,) τΩ, W
    energy_rate: np.ndarray  # (n,) dE_k/dt + dE_p/dt from the accelerations, W
    angle_deg: np.ndarray | None = None  # the crank angles as requested, deg (default: from theta)
    # the slider block as a body, and every pin as its links' bearings see it (docs/response.md §1.1)
    pin_force: np.ndarray | None = None  # (n, n_joint, 2) N, the link end's force on a slider block; NaN: no slider
    bearing_force: np.ndarray | None = None  # (n, n_link, 3, 2) N, the pin's force on each link point
    bearing_along: np.ndarray | None = None  # (n, n_link, 3) bearing_force along the link, root -> tip
    bearing_normal: np.ndarray | None = None  # (n, n_link, 3) along the link's left normal
    # process loads ([[loads]], docs/response.md §1.2)
    process_names: tuple[str, ...] = ()
    process_force: np.ndarray | None = None  # (n, n_load, 2) N, ground frame
    process_moment: np.ndarray | None = None  # (n, n_load) N m
    process_power: np.ndarray | None = None  # (n,) W, Σ F·v + M ω

    @property
    def crank_angle_deg(self) -> np.ndarray:
        return np.degrees(self.theta) if self.angle_deg is None else self.angle_deg

    @property
    def joint_magnitude(self) -> np.ndarray:
        """|F| of every joint force (n, n_joint), N."""
        return np.hypot(self.joint_force[..., 0], self.joint_force[..., 1])

    @property
    def power_residual(self) -> float:
        """max |τΩ − dE/dt| / max |τΩ| over the assembled angles (0 if no power flows)."""
        ok = self.ok
        put_in = self.power if self.process_power is None else self.power + self.process_power
        scale = max(np.abs(put_in[ok]).max(initial=0.0), np.abs(self.energy_rate[ok]).max(initial=0.0))
        return float(np.abs(put_in[ok] - self.energy_rate[ok]).max(initial=0.0) / scale) if scale else 0.0

    def axial_force(self, xi: float | np.ndarray = (0.0, 1.0)) -> np.ndarray:
        """Axial force (n, n_el, n_xi) at element coordinates ``xi`` (0: left node, 1: right)."""
        xi = np.atleast_1d(np.asarray(xi, dtype=float))
        c = self.axial_coef
        return c[..., 0:1] + c[..., 1:2] * xi + c[..., 2:3] * xi**2

    def link_axial(self, link: int) -> tuple[np.ndarray, np.ndarray]:
        """Stations s (m, from the link's root, along its axis beam) and axial force (n, n_s) at
        every node of the link's axis: both ends of each element (a lumped mass or a pin on the
        link makes a jump, so a node shared by two elements appears twice)."""
        sel = np.flatnonzero((self.elem_link == link) & self.elem_axis)
        return self.elem_s[sel].ravel(), self.axial_force()[:, sel].reshape(self.theta.size, -1)

    def end_label(self, link: int, point: int) -> str:
        return f"{self.link_names[link]}.{POINT_NAMES[point]}"

    def _peak(self, key: str, magnitude: np.ndarray) -> dict:
        """``{key}_n`` and ``{key}_crank_angle_deg``: the largest value and where (None if none)."""
        if not np.isfinite(magnitude).any():
            return {f"{key}_n": None, f"{key}_crank_angle_deg": None}
        k = int(np.nanargmax(magnitude))
        return {f"{key}_n": float(magnitude[k]), f"{key}_crank_angle_deg": float(self.crank_angle_deg[k])}

    def as_dict(self) -> dict:
        """The JSON of ``fkev loads --json`` (lists over the crank angles; SI units)."""
        mag = self.joint_magnitude
        joints = {}
        for jj, name in enumerate(self.joint_names):
            lk, k = self.attach[jj][0]
            joints[name] = {
                "kind": "ground" if self.joint_ground[jj] else ("prismatic" if not np.isnan(
                    self.guide_reaction[:, jj]).all() else "pin"),
                "on": "ground reaction on the linkage" if self.joint_ground[jj] else self.end_label(lk, k),
                "fx_n": json_list(self.joint_force[:, jj, 0]), "fy_n": json_list(self.joint_force[:, jj, 1]),
                "magnitude_n": json_list(mag[:, jj]), **self._peak("peak", mag[:, jj]),
                "in_link": {self.link_names[l2]: {"along_n": json_list(self.bearing_along[:, l2, k2]),
                                                  "normal_n": json_list(self.bearing_normal[:, l2, k2])}
                            for l2, k2 in self.attach[jj]},
            }
            if not np.isnan(self.pin_force[:, jj]).all():
                joints[name].update(pin_fx_n=json_list(self.pin_force[:, jj, 0]), pin_fy_n=json_list(self.pin_force[:, jj, 1]),
                                    pin_magnitude_n=json_list(np.hypot(*self.pin_force[:, jj].T)),
                                    **self._peak("pin_peak", np.hypot(*self.pin_force[:, jj].T)))
        ends = {}
        for jj, here in enumerate(self.attach):
            for lk, k in here:
                f = self.end_force[:, lk, k]
                ends[self.end_label(lk, k)] = {
                    "joint": self.joint_names[jj], "fx_n": json_list(f[:, 0]), "fy_n": json_list(f[:, 1]),
                    "along_n": json_list(self.end_along[:, lk, k]), "normal_n": json_list(self.end_normal[:, lk, k])}
        links = {}
        for lk, name in enumerate(self.link_names):
            s, N = self.link_axial(lk)
            links[name] = {"s_m": json_list(s), "axial_force_n": [json_list(row) for row in N]}
        guides = {self.joint_names[jj]: json_list(self.guide_reaction[:, jj])
                  for jj in range(len(self.joint_names)) if not np.isnan(self.guide_reaction[:, jj]).all()}
        return {
            "speed_rad_s": self.speed, "acceleration_rad_s2": self.accel, "gravity_m_s2": json_list(self.gravity),
            "crank_angle_deg": json_list(self.crank_angle_deg), "ok": self.ok.tolist(),
            "joints": joints, "link_ends": ends, "links": links, "guide_reaction_n": guides,
            "driving_torque_n_m": json_list(self.torque), "power_w": json_list(self.power),
            "energy_rate_w": json_list(self.energy_rate), "power_residual": self.power_residual,
            "process_loads": {name: {"fx_n": json_list(self.process_force[:, i, 0]), "fy_n": json_list(self.process_force[:, i, 1]),
                                     "moment_n_m": json_list(self.process_moment[:, i])}
                              for i, name in enumerate(self.process_names)},
            "process_power_w": json_list(self.process_power),
        }


def gravity_kinematics(kin: Kinematics, gravity: np.ndarray) -> Kinematics:
    """The kinematics whose per-Ω² accelerations are -g at every point (no rotation rates):
    kinetostatics.solve_loads on it gives the joint forces that hold the links against gravity."""
    g = np.broadcast_to(-np.asarray(gravity, dtype=float), kin.root.shape)
    zero = np.zeros_like(kin.dphi)
    return replace(kin, dphi=zero, ddphi=zero, droot=np.zeros_like(kin.root), ddroot=g.copy(),
                   dpos=np.zeros_like(kin.pos), ddpos=np.broadcast_to(-np.asarray(gravity, float), kin.pos.shape).copy())


def element_axial_coefficients(mech: Mechanism, kin: Kinematics, loads, part: int) -> np.ndarray:
    """Axial-force coefficients (n, n_el, 3) of one part of ``loads`` (0: per Ω², 1: per α),
    over every angle at once (kinetostatics.axial_polynomials does one angle)."""
    lk = mech.elem_link
    rho_a, l, s0 = mech.elem_rho_a, mech.elem_length, mech.elem_s0
    w2 = kin.dphi[:, lk] ** 2 if part == 0 else np.zeros((kin.theta.size, lk.size))
    F_r = loads.axial_right[part]
    a0 = loads.beam_accel[part][:, mech.elem_beam] - w2 * s0
    return np.stack([F_r - rho_a * a0 * l + 0.5 * rho_a * w2 * l**2, rho_a * a0 * l, -0.5 * rho_a * w2 * l**2],
                    axis=-1)


def joint_loads(mech: Mechanism, theta, speed: float, accel: float = 0.0, gravity=(0.0, 0.0),
                kin: Kinematics | None = None) -> JointLoads:
    """Kinetostatic loads at crank angles ``theta`` (rad), crank speed ``speed`` (rad/s), crank
    acceleration ``accel`` (rad/s²) and gravity ``gravity`` (m/s², ground frame)."""
    kin = solve_kinematics(mech, theta) if kin is None else kin
    g = np.asarray(gravity, dtype=float).reshape(2)
    w2, acc = float(speed) ** 2, float(accel)
    loads = solve_loads(mech, kin)

    def combine(pair, extra=None):
        out = w2 * pair[0] + acc * pair[1]
        return out if extra is None else out + extra[0]

    grav = solve_loads(mech, gravity_kinematics(kin, g)) if np.any(g) else None
    end = combine(loads.end_force, grav and grav.end_force)
    torque = combine(loads.torque, grav and grav.torque)
    guide = combine(loads.guide_reaction, grav and grav.guide_reaction)
    coef = w2 * element_axial_coefficients(mech, kin, loads, 0) + acc * element_axial_coefficients(mech, kin, loads, 1)
    if grav is not None:
        coef = coef + element_axial_coefficients(mech, gravity_kinematics(kin, g), grav, 0)
    points = process_points(mech)
    proc = process_kinetostatics(mech, kin, points) if points.size else None
    if proc is not None:
        end, torque, guide = end + proc.end_force, torque + proc.torque, guide + np.nan_to_num(proc.guide_reaction)
        coef = coef + proc.axial_coef

    present = ~np.isnan(mech.link_points[..., 0])  # (n_link, 3)
    end = np.where(present[None, :, :, None], end, np.nan)
    e = unit_vector(kin.phi)[:, :, None, :]  # (n, l, 1, 2)
    along = (end * e).sum(-1)
    normal = (end * perp(e)).sum(-1)

    n, nj = kin.theta.size, len(mech.joint_names)
    jforce = np.zeros((n, nj, 2))
    ground = ~np.isnan(mech.joint_ground[:, 0])
    for jj, here in enumerate(mech.attach):
        if ground[jj]:
            jforce[:, jj] = sum(end[:, lk, k] for lk, k in here)
        else:
            lk, k = here[0]
            jforce[:, jj] = end[:, lk, k]

    pin, bearing = _slider_blocks(mech, kin, end, w2, acc, g, points, proc)
    b_along, b_normal = (bearing * e).sum(-1), (bearing * perp(e)).sum(-1)
    E, rate = _energy(mech, kin, float(speed), acc, g)
    axis_beam = np.zeros(mech.beam_link.size, dtype=bool)
    axis_beam[np.unique(mech.beam_link, return_index=True)[1]] = True
    s0 = mech.elem_s0
    return JointLoads(
        theta=kin.theta, ok=kin.ok, speed=float(speed), accel=acc, gravity=g, joint_names=mech.joint_names,
        link_names=mech.link_names, attach=mech.attach, joint_ground=ground, end_force=end, end_along=along,
        end_normal=normal, joint_force=jforce, guide_reaction=guide, torque=torque, elem_link=mech.elem_link,
        elem_axis=axis_beam[mech.elem_beam], elem_s=np.stack([s0, s0 + mech.elem_length], axis=1),
        axial_coef=coef, kinetic_energy=E, power=torque * float(speed), energy_rate=rate,
        pin_force=pin, bearing_force=bearing, bearing_along=b_along, bearing_normal=b_normal,
        process_names=points.names, process_force=None if proc is None else proc.force,
        process_moment=None if proc is None else proc.moment,
        process_power=np.zeros(n) if proc is None else float(speed) * proc.power_per_speed,
    )


def _slider_blocks(mech: Mechanism, kin: Kinematics, end, w2, acc, g, points, proc):
    """The slider blocks as bodies of their own: the force of the link end on each block
    (pin_force, (n, n_joint, 2), NaN at other joints) from the block's D'Alembert equation
    P + R n + F_process + m g = m a, with R n the guide's force (the end force of the merged
    link + block); and the pins' forces on every link point (``end``, the block's pin force
    reversed at a slider)."""
    n, nj = kin.theta.size, len(mech.joint_names)
    pin = np.full((n, nj, 2), np.nan)
    bearing = end.copy()
    for jj in np.flatnonzero(~np.isnan(mech.joint_guide[:, 0])):
        lk, k = mech.attach[jj][0]
        m = mech.scene.joints[jj].slider_mass
        a = w2 * kin.ddpos[:, jj] + acc * kin.dpos[:, jj]
        on_block = m * (a - g) - end[:, lk, k]
        if proc is not None:
            on_block = on_block - proc.force[:, points.joint == jj].sum(axis=1)
        pin[:, jj] = on_block
        bearing[:, lk, k] = -on_block
    return pin, bearing


def _energy(mech: Mechanism, kin: Kinematics, speed: float, accel: float, g: np.ndarray):
    """Kinetic energy and dE_k/dt + dE_p/dt of the links as rigid bodies (mass, centroid,
    inertia about the centroid), from the velocities and accelerations (no differencing)."""
    links = np.arange(mech.n_link)
    _, dG, ddG = point_local(kin, links, mech.body_centroid)
    m, J = mech.body_mass, mech.body_inertia
    v = speed * dG
    a = speed**2 * ddG + accel * dG
    w = speed * kin.dphi
    dw = speed**2 * kin.ddphi + accel * kin.dphi
    E = 0.5 * (m * (v**2).sum(-1) + J * w**2).sum(-1)
    rate = (m * ((v * a).sum(-1) - v @ g) + J * w * dw).sum(-1)
    return E, rate
