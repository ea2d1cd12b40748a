"""Topology, meshing and DOF numbering of a planar linkage of elastic links.

Independent of crank angle and speed. Every link is a straight beam from its root to its tip,
meshed into equal frame elements; every node has (U, V, Φ) in the global frame
(docs/theory.md §4). Revolute joints share the translations of the link ends they connect and
leave their rotations independent (§9.2); ground joints fix the translations; the driven link
is clamped at its ground pivot (§9.3). The kinematic solution order (a driver, then RRR dyads)
is planned here once, so that any single-DOF linkage of binary links that decomposes into
dyads (four-bars, Watt/Stephenson-type chains with compound joints) is handled the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.element_types import element_type
from fkev_slepc.scene import Problem, Scene, SceneError


@dataclass(frozen=True)
class DyadStep:
    """Solve joint ``joint`` from links a (other end at joint ``p``) and b (other end at ``q``)."""

    joint: int
    link_a: int
    a_tip_at_joint: bool  # True if link a's tip is at ``joint`` (so its root is at ``p``)
    p: int
    link_b: int
    b_tip_at_joint: bool
    q: int
    sign: float  # +1: joint to the left of the ray P->Q


@dataclass(frozen=True)
class Mechanism:
    scene: Scene
    link_names: tuple[str, ...]
    length: np.ndarray  # (n_link,)
    rho_a: np.ndarray  # (n_link,) mass per unit length
    ea: np.ndarray
    ei: np.ndarray
    n_elem: np.ndarray  # (n_link,) elements per link
    # nodes (n_node,)
    node_link: np.ndarray
    node_s: np.ndarray  # station along the link from its root, m
    node_dofs: np.ndarray  # (n_node, 3) free DOF index or -1
    # elements (n_el,)
    elem_link: np.ndarray
    elem_nodes: np.ndarray  # (n_el, 2)
    elem_length: np.ndarray
    elem_s0: np.ndarray  # station of the left node
    elem_dofs: np.ndarray  # (n_el, n_dof): nodal (u1 v1 φ1 u2 v2 φ2), then internal (element_types)
    n_free: int
    # joints
    joint_names: tuple[str, ...]
    joint_ground: np.ndarray  # (n_joint, 2) position for ground joints, NaN otherwise
    link_root_joint: np.ndarray  # (n_link,) joint index at the root (-1 if free)
    link_tip_joint: np.ndarray  # (n_link,) joint index at the tip (-1 if free)
    driver: int
    dyads: tuple[DyadStep, ...]
    # lumped masses: (joint, carrying link, end is tip, mass)
    mass_joint: np.ndarray
    mass_link: np.ndarray
    mass_at_tip: np.ndarray
    mass_value: np.ndarray
    mass_dofs: np.ndarray  # (n_mass, 2) free translation DOFs (-1 if fixed)

    @property
    def n_link(self) -> int:
        return len(self.link_names)

    @property
    def link_mass(self) -> np.ndarray:
        return self.rho_a * self.length


def build_mechanism(scene: Scene) -> Mechanism:
    """Mesh the links, number the DOFs and plan the kinematic solution (docs/theory.md §4, §9).

    Raises
    ------
    SceneError
        If the topology is not a single-DOF linkage that decomposes into a driver and dyads.
    """
    names = tuple(lk.name for lk in scene.links)
    index = {n: i for i, n in enumerate(names)}
    length = np.array([lk.length for lk in scene.links], dtype=float)
    n_elem = np.array([lk.elements for lk in scene.links], dtype=int)
    rho_a = np.array([lk.density * lk.area for lk in scene.links])
    ea = np.array([lk.youngs_modulus * lk.area for lk in scene.links])
    ei = np.array([lk.youngs_modulus * lk.second_moment for lk in scene.links])

    # Nodes: link j owns nodes offset[j] .. offset[j] + n_j (root .. tip).
    offset = np.concatenate([[0], np.cumsum(n_elem + 1)])
    n_node = int(offset[-1])
    node_link = np.repeat(np.arange(len(names)), n_elem + 1)
    local = np.arange(n_node) - offset[node_link]
    node_s = local * (length / n_elem)[node_link]
    elem_link = np.repeat(np.arange(len(names)), n_elem)
    first_node = np.arange(elem_link.size) + elem_link  # skips each link's tip node
    elem_nodes = np.stack([first_node, first_node + 1], axis=1)
    elem_length = (length / n_elem)[elem_link]
    elem_s0 = node_s[first_node]

    def end_node(link: int, end: str) -> int:
        return int(offset[link] + (n_elem[link] if end == "tip" else 0))

    # Raw DOF 3*node+c; joints merge translations (union into the first end), ground fixes them.
    rep = np.arange(3 * n_node)
    fixed = np.zeros(3 * n_node, dtype=bool)
    n_joint = len(scene.joints)
    joint_ground = np.full((n_joint, 2), np.nan)
    root_joint = -np.ones(len(names), dtype=int)
    tip_joint = -np.ones(len(names), dtype=int)
    for jj, joint in enumerate(scene.joints):
        nodes = [end_node(index[e.link], e.end) for e in joint.ends]
        for e in joint.ends:
            (tip_joint if e.end == "tip" else root_joint)[index[e.link]] = jj
        for c in (0, 1):
            rep[[3 * n + c for n in nodes]] = 3 * nodes[0] + c
            if joint.ground is not None:
                fixed[[3 * n + c for n in nodes]] = True
        if joint.ground is not None:
            joint_ground[jj] = joint.ground
    driver = index[scene.driver.link]
    problems: list[Problem] = []
    if root_joint[driver] < 0 or np.isnan(joint_ground[root_joint[driver]]).any():
        problems.append(Problem("driver.link", f"the root of {names[driver]!r} must be at a ground joint"))
    else:
        fixed[3 * end_node(driver, "root") + 2] = True  # driven crank: clamped root (§9.3)

    keep = (rep == np.arange(rep.size)) & ~fixed
    free_index = -np.ones(rep.size, dtype=int)
    free_index[keep] = np.arange(int(keep.sum()))
    dof_of_raw = np.where(fixed, -1, free_index[rep])
    node_dofs = dof_of_raw.reshape(n_node, 3)
    elem_dofs = np.concatenate([node_dofs[elem_nodes[:, 0]], node_dofs[elem_nodes[:, 1]]], axis=1)
    n_free = int(keep.sum())
    # Internal DOFs of higher-order elements (element_types.py) follow every nodal DOF.
    n_int = element_type(scene.analysis.element).n_internal
    internal = n_free + np.arange(elem_link.size * n_int).reshape(elem_link.size, n_int)
    elem_dofs = np.concatenate([elem_dofs, internal], axis=1)
    n_free += internal.size

    dyads = _plan_dyads(scene, names, root_joint, tip_joint, joint_ground, driver, problems)
    if problems:
        raise SceneError(scene.source, problems)

    m_joint, m_link, m_tip, m_val = [], [], [], []
    jindex = {j.name: i for i, j in enumerate(scene.joints)}
    for m in scene.masses:
        m_joint.append(jindex[m.joint])
        m_link.append(index[m.link])
        m_tip.append(tip_joint[index[m.link]] == jindex[m.joint])
        m_val.append(m.mass)
    m_joint_a = np.array(m_joint, dtype=int)
    m_link_a = np.array(m_link, dtype=int)
    m_tip_a = np.array(m_tip, dtype=bool)
    mass_nodes = np.array(
        [end_node(lk, "tip" if t else "root") for lk, t in zip(m_link_a, m_tip_a)], dtype=int
    )
    mass_dofs = node_dofs[mass_nodes, :2] if mass_nodes.size else np.zeros((0, 2), dtype=int)

    return Mechanism(
        scene=scene, link_names=names, length=length, rho_a=rho_a, ea=ea, ei=ei, n_elem=n_elem,
        node_link=node_link, node_s=node_s, node_dofs=node_dofs, elem_link=elem_link,
        elem_nodes=elem_nodes, elem_length=elem_length, elem_s0=elem_s0, elem_dofs=elem_dofs,
        n_free=n_free, joint_names=tuple(j.name for j in scene.joints),
        joint_ground=joint_ground, link_root_joint=root_joint, link_tip_joint=tip_joint,
        driver=driver, dyads=tuple(dyads), mass_joint=m_joint_a, mass_link=m_link_a,
        mass_at_tip=m_tip_a, mass_value=np.array(m_val, dtype=float), mass_dofs=mass_dofs,
    )  # fmt: skip


def _plan_dyads(scene, names, root_joint, tip_joint, joint_ground, driver, problems) -> list[DyadStep]:
    """Order in which joints are located: the driver first, then RRR dyads (two unplaced links
    meeting at an unknown joint, each with its other end at a known joint)."""
    n_link = len(names)
    known = ~np.isnan(joint_ground[:, 0])
    placed = np.zeros(n_link, dtype=bool)
    placed[driver] = True
    if tip_joint[driver] >= 0:
        known[tip_joint[driver]] = True
    steps: list[DyadStep] = []
    progress = True
    while progress and not placed.all():
        progress = False
        for jj, joint in enumerate(scene.joints):
            if known[jj]:
                continue
            cands = []
            for e in joint.ends:
                lk = names.index(e.link)
                other = root_joint[lk] if e.end == "tip" else tip_joint[lk]
                if not placed[lk] and other >= 0 and known[other]:
                    cands.append((lk, e.end == "tip", other))
            if len(cands) >= 2:
                (a, a_tip, p), (b, b_tip, q) = cands[:2]
                sign = 1.0 if joint.assembly == "left" else -1.0
                steps.append(DyadStep(jj, a, a_tip, int(p), b, b_tip, int(q), sign))
                placed[[a, b]] = True
                known[jj] = True
                progress = True
    for lk in np.flatnonzero(~placed):
        problems.append(
            Problem(
                f"links[{lk}]",
                f"link {names[lk]!r} cannot be located: the linkage must be the driven link plus "
                "dyads (two links meeting at a joint, their other ends at located joints)",
            )
        )
    for lk in range(n_link):
        if lk != driver and (root_joint[lk] < 0 or tip_joint[lk] < 0) and placed[lk]:
            problems.append(Problem(f"links[{lk}]", f"link {names[lk]!r} has a free end; only the driver may"))
    return steps
