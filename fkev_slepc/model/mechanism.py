"""Topology, meshing and DOF numbering of a planar linkage of elastic links.

Independent of crank angle and speed. Links are meshed into frame elements by
:mod:`fkev_slepc.model.mesh` (axis beam, segments, mass nodes, a ternary link's branch); every
node has (U, V, Φ) in the global frame (docs/theory.md §4). Revolute joints share the
translations of the link points they connect and leave their rotations independent (§9.2);
ground joints fix the translations; the driven link is clamped at its ground pivot (§9.3).

A prismatic joint (a slider on a ground guide, docs/linkages.md) constrains only the
displacement normal to the guide: the translations of its node are taken in the guide frame
(``node_axis``: direction of the node's first translational DOF; its second, the normal one,
is fixed), which the element transformation includes (``element_frames``). The slider's mass
rides on the along-guide DOF. The kinematic solution order is planned by
:mod:`fkev_slepc.model.joint_order`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.element_types import element_type
from fkev_slepc.model.mesh import build_mesh, rigid_body
from fkev_slepc.model.joint_order import Step, order_steps
from fkev_slepc.scene import THIRD, Problem, Scene, SceneError

POINT_INDEX = {"root": 0, "tip": 1, THIRD: 2}


@dataclass(frozen=True)
class Mechanism:
    scene: Scene
    link_names: tuple[str, ...]
    length: np.ndarray  # (n_link,) root -> tip
    # beams, nodes, elements (see mesh.Mesh)
    beam_link: np.ndarray
    beam_angle: np.ndarray
    beam_origin: np.ndarray
    node_link: np.ndarray
    node_s: np.ndarray  # station along the node's beam from the beam's start, m
    node_local: np.ndarray  # (n_node, 2) link frame
    node_dofs: np.ndarray  # (n_node, 3) free DOF index or -1
    node_axis: np.ndarray  # (n_node, 2) direction of the first translational DOF (x, or a guide)
    elem_link: np.ndarray
    elem_beam: np.ndarray
    elem_nodes: np.ndarray  # (n_el, 2)
    elem_length: np.ndarray
    elem_s0: np.ndarray  # station of the left node along the beam
    elem_rho_a: np.ndarray  # mass per unit length
    elem_ea: np.ndarray
    elem_ei: np.ndarray
    # out-of-plane bending and torsion (NaN where the scene gives no out-of-plane data)
    elem_ei_out: np.ndarray  # E I_out, bending about the in-plane axis normal to the link
    elem_gj: np.ndarray  # G J, St-Venant torsion
    elem_rho_ip: np.ndarray  # ρ I_p, torsional rotary inertia per unit length
    elem_piece: tuple  # the scene Segment of every element (its section and material name)
    elem_dofs: np.ndarray  # (n_el, n_dof): nodal (u1 v1 φ1 u2 v2 φ2), then internal (element_types)
    n_free: int
    # joints
    joint_names: tuple[str, ...]
    joint_ground: np.ndarray  # (n_joint, 2) pivot of revolute ground joints, NaN otherwise
    joint_guide: np.ndarray  # (n_joint, 2) guide direction of prismatic joints, NaN otherwise
    joint_guide_point: np.ndarray  # (n_joint, 2) a point of the guide, NaN otherwise
    attach: tuple[tuple[tuple[int, int], ...], ...]  # per joint: (link, point index 0/1/2)
    link_points: np.ndarray  # (n_link, 3, 2) root, tip, third in the link frame (NaN: none)
    point_node: np.ndarray  # (n_link, 3) node at each link point (-1: none)
    link_root_joint: np.ndarray  # (n_link,) joint index at the root (-1 if free)
    link_tip_joint: np.ndarray  # (n_link,) joint index at the tip (-1 if free)
    driver: int
    steps: tuple[Step, ...]
    # particles: lumped masses and slider blocks (link, link-frame point, mass, rotary inertia)
    mass_link: np.ndarray
    mass_local: np.ndarray  # (n_mass, 2)
    mass_value: np.ndarray
    mass_inertia: np.ndarray
    mass_nodes: np.ndarray  # (n_mass,)
    mass_dofs: np.ndarray  # (n_mass, 3) free DOFs (U, V, Φ) at the mass node (-1 if fixed)
    # the links as rigid bodies (elements + particles)
    body_mass: np.ndarray
    body_centroid: np.ndarray  # (n_link, 2) link frame
    body_inertia: np.ndarray  # about the centroid

    @property
    def n_link(self) -> int:
        return len(self.link_names)

    @property
    def elem_angle(self) -> np.ndarray:
        """Direction of each element relative to its link's axis."""
        return self.beam_angle[self.elem_beam]


def build_mechanism(scene: Scene) -> Mechanism:
    """Mesh the links, number the DOFs and plan the kinematic solution (docs/theory.md §4, §9).

    Raises
    ------
    SceneError
        If the topology is not a single-DOF linkage that decomposes into a driver and dyads.
    """
    names = tuple(lk.name for lk in scene.links)
    index = {n: i for i, n in enumerate(names)}
    mesh = build_mesh(scene)
    n_node = mesh.node_link.size

    # Raw DOF 3*node+c; joints merge translations (union into the first point), ground fixes them.
    rep = np.arange(3 * n_node)
    fixed = np.zeros(3 * n_node, dtype=bool)
    axis = np.tile([1.0, 0.0], (n_node, 1))
    n_joint = len(scene.joints)
    joint_ground = np.full((n_joint, 2), np.nan)
    guide = np.full((n_joint, 2), np.nan)
    guide_point = np.full((n_joint, 2), np.nan)
    root_joint = -np.ones(len(names), dtype=int)
    tip_joint = -np.ones(len(names), dtype=int)
    attach = []
    for jj, joint in enumerate(scene.joints):
        here = tuple((index[e.link], POINT_INDEX[e.end]) for e in joint.ends)
        attach.append(here)
        nodes = [int(mesh.point_node[lk, k]) for lk, k in here]
        for lk, k in here:
            if k < 2:
                (tip_joint if k == 1 else root_joint)[lk] = jj
        for c in (0, 1):
            rep[[3 * n + c for n in nodes]] = 3 * nodes[0] + c
        if joint.prismatic:
            # translations in the guide frame: along (free, carries the slider), normal (fixed)
            guide[jj] = (np.cos(joint.guide_angle), np.sin(joint.guide_angle))
            guide_point[jj] = joint.ground
            axis[nodes] = guide[jj]
            fixed[[3 * n + 1 for n in nodes]] = True
        elif joint.ground is not None:
            joint_ground[jj] = joint.ground
            fixed[[3 * n + c for n in nodes for c in (0, 1)]] = True
    driver = index[scene.driver.link]
    problems: list[Problem] = []
    if root_joint[driver] < 0 or np.isnan(joint_ground[root_joint[driver]]).any():
        problems.append(Problem("driver.link", f"the root of {names[driver]!r} must be at a ground joint"))
    else:
        fixed[3 * mesh.point_node[driver, 0] + 2] = True  # driven crank: clamped root (§9.3)

    node_dofs, n_free = number_dofs(rep, fixed, n_node)
    elem_dofs = np.concatenate([node_dofs[mesh.elem_nodes[:, 0]], node_dofs[mesh.elem_nodes[:, 1]]], axis=1)
    # Internal DOFs of higher-order elements (element_types.py) follow every nodal DOF.
    n_el = mesh.elem_link.size
    n_int = element_type(scene.analysis.element).n_internal
    internal = n_free + np.arange(n_el * n_int).reshape(n_el, n_int)
    elem_dofs = np.concatenate([elem_dofs, internal], axis=1)
    n_free += internal.size

    ground_known = ~np.isnan(joint_ground[:, 0])
    prismatic = np.array([j.prismatic for j in scene.joints], dtype=bool)
    steps = order_steps(scene, names, attach, mesh.link_points, ground_known, prismatic, driver, problems)
    for lk in range(len(names)):
        if lk != driver and (root_joint[lk] < 0 or tip_joint[lk] < 0):
            problems.append(Problem(f"links[{lk}]", f"link {names[lk]!r} has a free end; only the driver may"))
    if problems:
        raise SceneError(scene.source, problems)

    particles = _particles(scene, index, mesh, attach)
    m_link, m_local, m_val, m_inertia, m_node = particles
    mass_dofs = node_dofs[m_node] if m_node.size else np.zeros((0, 3), dtype=int)
    body = rigid_body(mesh, len(names), (m_link, m_local, m_val, m_inertia))

    return Mechanism(
        scene=scene, link_names=names, length=np.array([lk.length for lk in scene.links], dtype=float),
        beam_link=mesh.beam_link, beam_angle=mesh.beam_angle, beam_origin=mesh.beam_origin,
        node_link=mesh.node_link, node_s=mesh.node_s, node_local=mesh.node_local,
        node_dofs=node_dofs, node_axis=axis, elem_link=mesh.elem_link, elem_beam=mesh.elem_beam,
        elem_nodes=mesh.elem_nodes, elem_length=mesh.elem_length, elem_s0=mesh.elem_s0,
        elem_rho_a=mesh.elem_rho_a, elem_ea=mesh.elem_ea, elem_ei=mesh.elem_ei, elem_ei_out=mesh.elem_ei_out,
        elem_gj=mesh.elem_gj, elem_rho_ip=mesh.elem_rho_ip, elem_piece=mesh.elem_piece, elem_dofs=elem_dofs,
        n_free=n_free, joint_names=tuple(j.name for j in scene.joints), joint_ground=joint_ground,
        joint_guide=guide, joint_guide_point=guide_point, attach=tuple(attach), link_points=mesh.link_points,
        point_node=mesh.point_node,
        link_root_joint=root_joint, link_tip_joint=tip_joint, driver=driver, steps=tuple(steps),
        mass_link=m_link, mass_local=m_local, mass_value=m_val, mass_inertia=m_inertia, mass_nodes=m_node,
        mass_dofs=mass_dofs, body_mass=body[0], body_centroid=body[1], body_inertia=body[2],
    )  # fmt: skip


def node_displacement(mesh, q: np.ndarray, axes: np.ndarray | None = None) -> np.ndarray:
    """Global (x, y, rotation) displacement (..., n_node, 3) of every node of ``mesh`` (anything with
    ``node_dofs``, (n_node, 3) free DOF index or -1) from the free-DOF values ``q`` (..., n_free; real or
    complex); a constrained DOF is 0; ``axes`` (n_node, 2): the direction of each node's first
    translational DOF (``Mechanism.node_axis``), its values (a, n) along/normal to it turned to (x, y)."""
    q = np.asarray(q)
    vals = np.concatenate([q, np.zeros(q.shape[:-1] + (1,), q.dtype)], axis=-1)[..., mesh.node_dofs]  # -1 -> 0
    if axes is not None:  # (a, n) in the node's frame -> (U, V)
        a, n = vals[..., 0].copy(), vals[..., 1].copy()
        vals[..., 0] = a * axes[:, 0] - n * axes[:, 1]
        vals[..., 1] = a * axes[:, 1] + n * axes[:, 0]
    return vals


def number_dofs(rep: np.ndarray, fixed: np.ndarray, n_node: int) -> tuple[np.ndarray, int]:
    """Free DOF numbers (n_node, 3) (-1: fixed) and their count, from the raw DOFs 3·node + c:
    ``rep`` the raw DOF each one is merged into (itself if none), ``fixed`` the constrained ones."""
    keep = (rep == np.arange(rep.size)) & ~fixed
    free_index = -np.ones(rep.size, dtype=int)
    free_index[keep] = np.arange(int(keep.sum()))
    dof_of_raw = np.where(fixed | fixed[rep], -1, free_index[rep])
    return dof_of_raw.reshape(n_node, 3), int(keep.sum())


def _particles(scene: Scene, index, mesh, attach):
    """(link, link-frame point, mass, inertia, node) of every lumped mass and slider block.

    A mass at a joint rides on the named link's point there; a slider block on the link point
    that its prismatic joint holds (for kinetostatics it is a particle at that point: the guide
    takes only normal forces, so the block's inertia force goes into the link).
    """
    jindex = {j.name: i for i, j in enumerate(scene.joints)}
    rows = []
    for m in scene.masses:
        lk = index[m.link]
        if m.joint is not None:
            k = next(k for (l2, k) in attach[jindex[m.joint]] if l2 == lk)
            node = int(mesh.point_node[lk, k])
        else:
            on_axis = np.flatnonzero((mesh.node_link == lk) & (mesh.node_beam == mesh.node_beam[mesh.point_node[lk, 0]]))
            node = int(on_axis[np.argmin(np.abs(mesh.node_s[on_axis] - m.position))])
        rows.append((lk, mesh.node_local[node], m.mass, m.inertia, node))
    for jj, joint in enumerate(scene.joints):
        if joint.prismatic and joint.slider_mass > 0:
            lk, k = attach[jj][0]
            node = int(mesh.point_node[lk, k])
            rows.append((lk, mesh.node_local[node], joint.slider_mass, 0.0, node))
    if not rows:
        z = np.zeros(0)
        return np.zeros(0, dtype=int), np.zeros((0, 2)), z, z, np.zeros(0, dtype=int)
    lk, local, mass, inertia, node = zip(*rows)
    return (np.array(lk, dtype=int), np.array(local, dtype=float), np.array(mass, dtype=float),
            np.array(inertia, dtype=float), np.array(node, dtype=int))
