"""Meshing of the links into beams, nodes and frame elements (docs/linkages.md).

Every link has an *axis beam* from its root to its tip, made of one uniform segment or of
several (a stepped link), each meshed into equal elements; a node is inserted wherever a lumped
mass sits between nodes (so the mass is a nodal mass) and where a ternary link's branch starts.
A ternary link also has a *branch beam*, perpendicular to the axis, from that axis node (its
foot) to the third joint point; it shares the foot node, i.e. it is rigidly connected (all
three DOFs) to the axis beam there. Nodes carry their position in the link frame, so the
rigid-body position of any node is ``root + R(φ) local``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.scene import Scene

SNAP = 1e-9  # relative: a mass this close to an existing node sits on it


@dataclass(frozen=True)
class Mesh:
    """Beams, nodes and elements of every link (arrays, no DOFs yet)."""

    # beams (n_beam,)
    beam_link: np.ndarray
    beam_angle: np.ndarray  # direction relative to the link axis (0, or ±π/2 for a branch)
    beam_origin: np.ndarray  # (n_beam, 2) start point in the link frame
    # nodes (n_node,)
    node_link: np.ndarray
    node_beam: np.ndarray
    node_s: np.ndarray  # station along its beam from the beam's start, m
    node_local: np.ndarray  # (n_node, 2) position in the link frame
    # elements (n_el,), in order along each beam, beams one after another
    elem_link: np.ndarray
    elem_beam: np.ndarray
    elem_nodes: np.ndarray  # (n_el, 2) left (nearer the beam start) and right node
    elem_length: np.ndarray
    elem_s0: np.ndarray  # station of the left node along the beam
    elem_rho_a: np.ndarray
    elem_ea: np.ndarray
    elem_ei: np.ndarray
    # out-of-plane data (NaN where the scene gives none): E I_out, G J, ρ I_p
    elem_ei_out: np.ndarray
    elem_gj: np.ndarray
    elem_rho_ip: np.ndarray
    elem_piece: tuple  # the Segment of every element (section, material name)
    # the node at each link point (n_link, 3): root, tip, third (-1 if the link has none)
    point_node: np.ndarray
    link_points: np.ndarray  # (n_link, 3, 2) the points in the link frame (NaN: none)


def _stations(link, extra: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Node stations of a link's axis and the segment index of every element between them."""
    s, seg = [0.0], []
    start = 0.0
    for k, piece in enumerate(link.pieces):
        ends = start + piece.length * np.arange(1, piece.elements + 1) / piece.elements
        s.extend(ends.tolist())
        seg.extend([k] * piece.elements)
        start += piece.length
    s[-1] = link.length  # the tip exactly
    s, seg = np.array(s), np.array(seg)
    for x in extra:  # split the element that contains x, unless a node is already there
        if np.min(np.abs(s - x)) <= SNAP * link.length:
            continue
        i = int(np.searchsorted(s, x))
        s = np.insert(s, i, x)
        seg = np.insert(seg, i - 1, seg[i - 1])
    return s, seg


def build_mesh(scene: Scene) -> Mesh:
    """Mesh every link (axis beam, optional branch beam) of ``scene``."""
    index = {lk.name: i for i, lk in enumerate(scene.links)}
    extra: list[list[float]] = [[] for _ in scene.links]
    for m in scene.masses:
        if m.joint is None:
            extra[index[m.link]].append(m.position)
    beam_link, beam_angle, beam_origin = [], [], []
    nodes_link, nodes_beam, nodes_s, nodes_local = [], [], [], []
    el = {k: [] for k in ("link", "beam", "left", "right", "s0", "len", "piece")}
    point_node = -np.ones((len(scene.links), 3), dtype=int)
    link_points = np.full((len(scene.links), 3, 2), np.nan)
    n_node = 0

    def add_beam(lk, angle, origin, s, props, first_node):
        """Nodes at stations ``s`` (the first one is ``first_node`` if given) and elements."""
        nonlocal n_node
        b = len(beam_link)
        beam_link.append(lk)
        beam_angle.append(angle)
        beam_origin.append(origin)
        direction = np.array([np.cos(angle), np.sin(angle)])
        ids = []
        for k, sk in enumerate(s):
            if k == 0 and first_node is not None:
                ids.append(first_node)
                continue
            ids.append(n_node)
            n_node += 1
            nodes_link.append(lk)
            nodes_beam.append(b)
            nodes_s.append(sk)
            nodes_local.append(np.asarray(origin) + sk * direction)
        for k in range(len(s) - 1):
            el["link"].append(lk)
            el["beam"].append(b)
            el["left"].append(ids[k])
            el["right"].append(ids[k + 1])
            el["s0"].append(s[k])
            el["len"].append(s[k + 1] - s[k])
            el["piece"].append(props[k])
        return ids

    for i, link in enumerate(scene.links):
        foot = [] if link.third is None else [link.third[0]]
        s, seg = _stations(link, extra[i] + foot)
        props = [link.pieces[k] for k in seg]
        ids = add_beam(i, 0.0, (0.0, 0.0), s, props, None)
        point_node[i, 0], point_node[i, 1] = ids[0], ids[-1]
        link_points[i, 0], link_points[i, 1] = (0.0, 0.0), (link.length, 0.0)
        if link.third is not None:
            x, y = link.third
            link_points[i, 2] = (x, y)
            at = ids[int(np.argmin(np.abs(s - x)))]
            if y == 0.0:
                point_node[i, 2] = at  # a third joint on the axis: at the axis node
                continue
            n = link.third_elements
            sb = abs(y) * np.arange(n + 1) / n
            uniform = [link.uniform] * n
            angle = np.pi / 2 if y > 0 else -np.pi / 2
            branch = add_beam(i, angle, (x, 0.0), sb, uniform, at)
            point_node[i, 2] = branch[-1]

    sections = _section_arrays(el["piece"])
    return Mesh(
        beam_link=np.array(beam_link, dtype=int), beam_angle=np.array(beam_angle, dtype=float),
        beam_origin=np.array(beam_origin, dtype=float).reshape(-1, 2),
        node_link=np.array(nodes_link, dtype=int), node_beam=np.array(nodes_beam, dtype=int),
        node_s=np.array(nodes_s, dtype=float), node_local=np.array(nodes_local, dtype=float).reshape(-1, 2),
        elem_link=np.array(el["link"], dtype=int), elem_beam=np.array(el["beam"], dtype=int),
        elem_nodes=np.stack([np.array(el["left"], dtype=int), np.array(el["right"], dtype=int)], axis=1),
        elem_length=np.array(el["len"]), elem_s0=np.array(el["s0"]), elem_piece=tuple(el["piece"]), **sections,
        point_node=point_node, link_points=link_points,
    )  # fmt: skip


def _section_arrays(pieces) -> dict[str, np.ndarray]:
    """Per-element ρA, EA, EI and the out-of-plane E I_out, G J, ρ I_p (NaN where not given)."""
    def field(name):
        return np.array([np.nan if getattr(p, name) is None else getattr(p, name) for p in pieces], dtype=float)

    e_mod, rho = field("youngs_modulus"), field("density")
    with np.errstate(over="ignore"):  # an overflowing product (E = 1e155 ...) is refused by solve/finite.py
        return _products(e_mod, rho, field)


def _products(e_mod, rho, field) -> dict[str, np.ndarray]:
    return {"elem_rho_a": rho * field("area"), "elem_ea": e_mod * field("area"),
            "elem_ei": e_mod * field("second_moment"), "elem_ei_out": e_mod * field("second_moment_out"),
            "elem_gj": field("shear_modulus") * field("torsion_constant"), "elem_rho_ip": rho * field("polar_moment")}


def rigid_body(mesh: Mesh, n_link: int, particles) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mass, centroid (link frame) and centroidal moment of inertia of every link as a rigid body:
    its elements (uniform slender rods) plus ``particles`` = (link, local (n, 2), mass, inertia)."""
    lk, local, mass, inertia = particles
    mid = 0.5 * (mesh.node_local[mesh.elem_nodes[:, 0]] + mesh.node_local[mesh.elem_nodes[:, 1]])
    me = mesh.elem_rho_a * mesh.elem_length
    owner = np.concatenate([mesh.elem_link, lk])
    m = np.concatenate([me, mass])
    c = np.concatenate([mid, local.reshape(-1, 2)])
    j_own = np.concatenate([me * mesh.elem_length**2 / 12.0, inertia])
    total = np.bincount(owner, weights=m, minlength=n_link)
    centroid = np.stack([np.bincount(owner, weights=m * c[:, k], minlength=n_link) for k in (0, 1)], axis=1)
    centroid /= total[:, None]
    r2 = ((c - centroid[owner]) ** 2).sum(axis=1)
    j = np.bincount(owner, weights=j_own + m * r2, minlength=n_link)
    return total, centroid, j
