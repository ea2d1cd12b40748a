"""Process loads (the scene's ``[[loads]]``, docs/response.md §1.2): external forces and moments
given as periodic piecewise-linear tables over the crank angle, located on the mesh, evaluated
over crank angles, and turned into

* their share of the rigid-body kinetostatics (joint forces, driving torque, guide reactions
  and the axial force along the links, :func:`process_kinetostatics`), with the power they put
  in (Σ F·v + M φ̇) for the power check;
* the consistent nodal load vectors of the elastic model (:func:`process_load_vectors`): a
  point force and moment on a beam element gives Nᵀ f on its DOFs (element_types.point_load).

A load at a slider's joint acts on the slider block (the link end's node in the elastic model;
its component normal to the guide goes into the guide); ``frame = "link"`` there means the
guide's frame. Process loads do not enter the axial-force stiffness (neither does gravity).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.element_types import point_load
from fkev_slepc.model.kinematics import Kinematics, rotate, unit_vector, point_local
from fkev_slepc.model.kinetostatics import axial_right, solve_external
from fkev_slepc.model.mechanism import POINT_INDEX, Mechanism


@dataclass(frozen=True)
class ProcessPoints:
    """Where the ``[[loads]]`` of a mechanism act (one row per load)."""

    names: tuple[str, ...]
    link: np.ndarray  # (n_load,) link index
    local: np.ndarray  # (n_load, 2) point in the link frame
    joint: np.ndarray  # (n_load,) joint index when ``at`` named a joint, else -1
    frame_angle: np.ndarray  # (n_load,) fixed frame angle (rad): 0 ground, the guide's at a slider; NaN: the link's
    elem: np.ndarray  # (n_load,) element that carries it in the elastic model
    xi: np.ndarray  # (n_load,) its element coordinate there
    tables: tuple  # scene ProcessLoad items

    @property
    def size(self) -> int:
        return len(self.names)


def process_points(mech: Mechanism) -> ProcessPoints:
    """Locate the scene's process loads on ``mech`` (its links, joints and elements)."""
    items = mech.scene.process_loads
    index = {n: i for i, n in enumerate(mech.link_names)}
    jindex = {n: i for i, n in enumerate(mech.joint_names)}
    rows = []
    for pl in items:
        lk = index[pl.link]
        jj = jindex.get(pl.joint, -1) if pl.joint is not None else -1
        if isinstance(pl.point, str):
            local = mech.link_points[lk, POINT_INDEX[pl.point]]
            node = int(mech.point_node[lk, POINT_INDEX[pl.point]])
            right = np.flatnonzero(mech.elem_nodes[:, 1] == node)
            e, xi = (int(right[0]), 1.0) if right.size else (int(np.flatnonzero(mech.elem_nodes[:, 0] == node)[0]), 0.0)
        else:  # a station on the axis beam (the link's first beam)
            local = np.array([pl.point, 0.0])
            axis = np.flatnonzero((mech.elem_link == lk) & (mech.elem_beam == mech.elem_beam[mech.elem_link == lk][0]))
            end = mech.elem_s0[axis] + mech.elem_length[axis]
            e = int(axis[min(np.searchsorted(end, pl.point * (1 - 1e-12)), axis.size - 1)])
            xi = float(np.clip((pl.point - mech.elem_s0[e]) / mech.elem_length[e], 0.0, 1.0))
        if jj >= 0 and not np.isnan(mech.joint_guide[jj, 0]):
            angle = float(np.arctan2(mech.joint_guide[jj, 1], mech.joint_guide[jj, 0])) if pl.frame == "link" else 0.0
        else:
            angle = np.nan if pl.frame == "link" else 0.0
        rows.append((lk, local, jj, angle, e, xi))
    if not rows:
        return ProcessPoints((), np.zeros(0, int), np.zeros((0, 2)), np.zeros(0, int), np.zeros(0), np.zeros(0, int),
                             np.zeros(0), ())
    lk, local, jj, angle, e, xi = zip(*rows)
    return ProcessPoints(tuple(p.name for p in items), np.array(lk), np.array(local, float), np.array(jj),
                         np.array(angle, float), np.array(e), np.array(xi, float), tuple(items))


def ground_loads(points: ProcessPoints, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    """Force (n_ang, n_load, 2, ground frame, N) and moment (n_ang, n_load, N m) of every process
    load at the crank angles of ``kin``: each table interpolated linearly, periodic over 360°,
    and a ``link``-frame force turned by its link's (or a slider's guide's) angle."""
    deg = np.mod(np.degrees(kin.theta), 360.0)
    table = np.zeros((kin.theta.size, points.size, 3))
    for i, pl in enumerate(points.tables):
        for c, col in enumerate((pl.fx, pl.fy, pl.moment)):
            table[:, i, c] = np.interp(deg, pl.crank_angle_deg, col, period=360.0)
    angle = np.where(np.isnan(points.frame_angle), kin.phi[:, points.link], points.frame_angle)
    return rotate(angle, table[..., :2]), table[..., 2]


@dataclass(frozen=True)
class ProcessKinetostatics:
    """The process loads' share of the kinetostatics at the angles of ``kin``."""

    force: np.ndarray  # (n, n_load, 2) N, ground frame
    moment: np.ndarray  # (n, n_load) N m
    end_force: np.ndarray  # (n, n_link, 3, 2) on each link point from its joint
    torque: np.ndarray  # (n,) driving torque
    guide_reaction: np.ndarray  # (n, n_joint)
    axial_coef: np.ndarray  # (n, n_el, 3) F(ξ) = c₀ + c₁ξ (c₂ = 0)
    power_per_speed: np.ndarray  # (n,) Σ F·p' + M φ': the power put in per unit crank speed, W s


def process_kinetostatics(mech: Mechanism, kin: Kinematics, points: ProcessPoints | None = None,
                          plan=None) -> ProcessKinetostatics:
    """Joint forces, torque, guide reactions and axial forces that balance the process loads
    (kinetostatics.solve_external). The axial force is exact at every element end: a load
    inside an element acts on the right-node cuts like a force at its left node, and on the
    element's left end too (c₀ += F_along, c₁ -= F_along: linear in between)."""
    points = process_points(mech) if points is None else points
    force, moment = ground_loads(points, kin)
    end, torque, guide = solve_external(mech, kin, points.link, points.local, force, moment, plan)
    n, n_el = kin.theta.size, mech.elem_link.size
    e_beam = unit_vector(kin.phi[:, mech.beam_link] + mech.beam_angle)
    inside = (points.xi > 0.0) & (points.xi < 1.0)
    nodes = np.where(points.xi < 1.0, mech.elem_nodes[points.elem, 0], mech.elem_nodes[points.elem, 1])
    zero_el, zero_mass = np.zeros((n, n_el, 2)), np.zeros((n, mech.mass_nodes.size, 2))
    F_r = axial_right(mech, np.nan_to_num(end), zero_el, zero_mass, e_beam, (nodes, force))
    coef = np.zeros((n, n_el, 3))
    coef[..., 0] = F_r
    along = np.einsum("anc,anc->an", force, e_beam[:, mech.elem_beam[points.elem]])
    np.add.at(coef, (slice(None), points.elem[inside], 0), along[:, inside])
    np.add.at(coef, (slice(None), points.elem[inside], 1), -along[:, inside])
    _, dp, _ = point_local(kin, points.link, points.local)
    power = np.einsum("anc,anc->a", force, dp) + (moment * kin.dphi[:, points.link]).sum(-1)
    return ProcessKinetostatics(force, moment, end, torque, guide, coef, power)


def process_load_vectors(model, theta) -> np.ndarray:
    """Consistent nodal load vectors (n_θ, n_free) of the process loads at crank angles ``theta``
    (rad) on the DOFs of ``model.pattern`` (zeros without ``[[loads]]``): each force and moment,
    in its element's components, through element_types.point_load and the element's frame."""
    mech = model.mechanism
    theta = np.atleast_1d(np.asarray(theta, dtype=float)).ravel()
    points = process_points(mech)
    if not points.size:
        return np.zeros((theta.size, model.n_free))
    state = model.angle_state(theta, with_loads=False)
    force, moment = ground_loads(points, state.kinematics)
    phi = state.phi[:, points.elem]
    c, s = np.cos(phi), np.sin(phi)
    local = np.stack([c * force[..., 0] + s * force[..., 1], c * force[..., 1] - s * force[..., 0], moment], -1)
    shear = model.stacks.shear_parameter  # Timoshenko: its own N_v, N_ψ (docs/theory.md §22.2)
    f_e = point_load(points.xi, mech.elem_length[points.elem], model.stacks.n_dof, local,
                     None if shear is None else shear[points.elem])
    T = state.T[:, points.elem]
    f_dof = (np.swapaxes(T, -1, -2) @ f_e[..., None])[..., 0]
    return model.pattern.scatter_vector(f_dof, mech.elem_dofs[points.elem])
