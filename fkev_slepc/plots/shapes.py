"""Mode shapes drawn on the undeformed linkage (thesis Figs 3.22-3.25).

The archive holds nodal DOFs (U, V, Φ) in the global frame and the undeformed node positions.
Between nodes the displacement is interpolated with the element's own shape functions
(docs/theory.md §4) in its link frame: linear for the axial displacement u, cubic Hermite
for the transverse displacement v (which uses the nodal rotations Φ). Drawing straight
segments between displaced nodes would hide the bending that distinguishes the modes.

Prismatic joints (docs/linkages.md) are drawn as their guide line with the slider block on it;
the slider node's one translational DOF is along its guide: the archived ``/mesh/node_axis``
(``Mechanism.node_axis``). Archives written before it existed fall back to the guides of the
archived scene text, the nearest guide to each slider node.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from fkev_slepc.plots.common import (  # align_phase, node_displacement: re-exported (api/results.py)
    align_phase,
    case_label,
    case_style,
    mode_grid,
    node_displacement,
    pick_angle,
    pick_cases,
    pick_modes,
    pick_speed,
    scene_heading,
    speed_label,
    suptitle,
)
from fkev_slepc.archive.reader import ArchiveError, NodeDofMap, SweepResults
from fkev_slepc.model.plane import Plane
from fkev_slepc.plots.out_of_plane import out_of_plane_figure
from fkev_slepc.scene import SceneError, parse_scene

N_SUB = 17  # samples per element: enough for a smooth cubic at figure resolution
AMPLITUDE = 0.12  # drawn peak displacement as a fraction of the linkage's extent


def guides(scene_toml: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """(point, unit direction) of every prismatic joint's guide in an archived scene text."""
    try:
        scene = parse_scene(scene_toml, "archive")
    except SceneError:
        return []
    return [(np.asarray(j.ground, float), np.array([np.cos(j.guide_angle), np.sin(j.guide_angle)]))
            for j in scene.joints if j.prismatic]


def archived_guides(mesh: NodeDofMap, node_xy: np.ndarray, axes: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(point, unit direction) of the guide of every slider node (U free, V fixed): through the
    node, along its archived axis (``/mesh/node_axis``)."""
    slider = np.flatnonzero((mesh.node_dofs[:, 0] >= 0) & (mesh.node_dofs[:, 1] < 0))
    return [(np.asarray(node_xy[n], float), np.asarray(axes[n], float)) for n in slider]


def node_axes(mesh: NodeDofMap, node_xy: np.ndarray, lines) -> np.ndarray:
    """Direction (n_node, 2) of each node's first translational DOF: x, except at a slider node
    (U free, V fixed), whose DOF runs along the guide it lies on (``lines`` from :func:`guides`)."""
    axes = np.tile([1.0, 0.0], (node_xy.shape[0], 1))
    slider = np.flatnonzero((mesh.node_dofs[:, 0] >= 0) & (mesh.node_dofs[:, 1] < 0))
    if slider.size and lines:
        for n in slider:
            off = [abs(np.cross(t, node_xy[n] - p)) for p, t in lines]
            axes[n] = lines[int(np.argmin(off))][1]
    return axes


def element_displacement(mesh: NodeDofMap, node_xy: np.ndarray, q: np.ndarray, xi: np.ndarray,
                         axes: np.ndarray | None = None) -> np.ndarray:
    """Global displacement (n_el, n_xi, 2) of every element at stations ``xi`` ∈ [0, 1].

    Parameters
    ----------
    mesh : NodeDofMap
        Node/DOF map (``node_dofs`` -1 marks a constrained, i.e. zero, DOF).
    node_xy : (n_node, 2) array
        Undeformed node positions (m); they define each element's frame and length.
    q : (n_free,) real array
        Nodal DOF values (U, V in m; Φ in rad) in the global frame.
    xi : (n_xi,) array
        Stations along each element from its left node (0) to its right node (1).
    axes : (n_node, 2) array, optional
        Direction of each node's first translational DOF (:func:`node_axes`; default x).
    """
    vals = node_displacement(mesh, np.asarray(q, dtype=float), axes)
    n1, n2 = mesh.elem_nodes[:, 0], mesh.elem_nodes[:, 1]
    d = node_xy[n2] - node_xy[n1]
    ln = np.linalg.norm(d, axis=1)
    e = d / ln[:, None]
    en = np.stack([-e[:, 1], e[:, 0]], axis=1)
    # q_local = T q_global (docs/theory.md §8): translations rotated into the link frame, Φ unchanged
    u1, u2 = np.sum(vals[n1, :2] * e, 1), np.sum(vals[n2, :2] * e, 1)
    v1, v2 = np.sum(vals[n1, :2] * en, 1), np.sum(vals[n2, :2] * en, 1)
    p1, p2 = vals[n1, 2], vals[n2, 2]
    x = np.asarray(xi, dtype=float)[None, :]
    L = ln[:, None]
    u = (1 - x) * u1[:, None] + x * u2[:, None]
    v = (
        (1 - 3 * x**2 + 2 * x**3) * v1[:, None]
        + L * x * (1 - x) ** 2 * p1[:, None]
        + (3 * x**2 - 2 * x**3) * v2[:, None]
        - L * x**2 * (1 - x) * p2[:, None]
    )
    return u[..., None] * e[:, None, :] + v[..., None] * en[:, None, :]


def linkage_polyline(mesh: NodeDofMap, node_xy: np.ndarray, disp: np.ndarray | None, xi: np.ndarray) -> np.ndarray:
    """(N, 2) polyline through every element, beam by beam (the elements of a beam are stored
    in order, each starting at the previous one's right node), beams separated by a NaN row;
    ``disp`` (n_el, n_xi, 2) is added if given."""
    n1, n2 = mesh.elem_nodes[:, 0], mesh.elem_nodes[:, 1]
    x = np.asarray(xi, dtype=float)[None, :, None]
    pts = node_xy[n1][:, None, :] + x * (node_xy[n2] - node_xy[n1])[:, None, :]
    if disp is not None:
        pts = pts + disp
    if not n1.size:
        return np.zeros((0, 2))
    starts = np.flatnonzero(np.r_[True, n1[1:] != n2[:-1]])
    pieces = []
    for a, b in zip(starts, np.r_[starts[1:], n1.size]):
        pieces.append(pts[a:b].reshape(-1, 2))
        pieces.append(np.full((1, 2), np.nan))
    return np.concatenate(pieces[:-1])


def draw_guides(ax, node_xy: np.ndarray, mesh: NodeDofMap, lines, extent: float) -> None:
    """Each guide as a hatched line through its slider's travel, the slider as a block on it."""
    slider = np.flatnonzero((mesh.node_dofs[:, 0] >= 0) & (mesh.node_dofs[:, 1] < 0))
    for p, t in lines:
        near = [n for n in slider if abs(np.cross(t, node_xy[n] - p)) <= 1e-9 * max(extent, 1.0)]
        centre = node_xy[near[0]] if near else p
        s = 0.35 * extent
        seg = np.array([centre - s * t, centre + s * t])
        normal = np.array([-t[1], t[0]])
        w, h = 0.12 * extent, 0.06 * extent
        ax.plot(seg[:, 0], seg[:, 1], color="k", lw=1.0, zorder=1, label="_guide")
        ticks = np.linspace(-s, s, 12)
        for u in ticks:  # hatching on the guide's right side
            a = centre + u * t - 0.5 * h * normal
            b = a + 0.25 * h * (t - normal)
            ax.plot([a[0], b[0]], [a[1], b[1]], color="k", lw=0.6, zorder=1, label="_hatch")
        corner = centre - 0.5 * w * t - 0.5 * h * normal
        angle = float(np.degrees(np.arctan2(t[1], t[0])))
        ax.add_patch(Rectangle(tuple(corner), w, h, angle=angle, facecolor="0.85", edgecolor="k",
                               lw=1.0, zorder=2, label="_slider"))


def mode_shape(
    res: SweepResults,
    angle: float | None = None,
    speed: float | None = None,
    cases: Sequence[str | int] | None = None,
    modes: Sequence[int] | None = None,
) -> Figure:
    """Mode shapes on the undeformed linkage at one crank angle and speed, one axes per mode,
    one deformed line per case (Figs 3.22-3.25). Defaults: θ = 10° (else the first angle), the
    highest speed, every case. Shapes of one mode share a peak drawn displacement
    (``AMPLITUDE`` × linkage extent) and are phase-aligned to the first case drawn."""
    if not res.has_mode_shapes:
        raise ArchiveError(
            f"{res.path}: this archive has no mode shapes; produce one with "
            "`fkev run SCENE --mode-shapes` (or `mode_shapes = true` in the scene's [analysis])"
        )
    if res.mesh is None or res.node_xy is None:
        raise ArchiveError(
            f"{res.path}: the archive has mode shapes but no /mesh or /modes/node_xy to draw them on"
        )
    a = pick_angle(res, angle)
    s = pick_speed(res, speed)
    c_idx = pick_cases(res, cases, res.cases)
    mode_idx = pick_modes(res, modes)
    f = res.frequency(order="sorted")
    lines = [(res.cases[c], res.mode_shape(a, s, c), f[a, s, c]) for c in c_idx]
    where = f"θ = {res.crank_angle_deg[a]:g}°, {speed_label(res.speed_rad_s[s], res.speeds_in_rpm)}"
    heading = f"{scene_heading(res)}\nmode shapes at {where}"
    xy = np.asarray(res.node_xy[a], dtype=float)
    if Plane.parse(res.plane).transverse:  # w along the links, the twist marked; the first case asked
        case, shapes, freq = lines[0]
        return out_of_plane_figure(res.mesh, xy, shapes, freq, mode_idx, f"{heading}, case {case}")
    if res.mesh.node_axis is not None:  # the archived axes: exact
        axes, lines_g = res.mesh.node_axis, archived_guides(res.mesh, xy, res.mesh.node_axis)
    else:  # archives written before /mesh/node_axis
        lines_g = guides(res.scene_toml)
        axes = node_axes(res.mesh, xy, lines_g)
    return shapes_figure(res.mesh, xy, lines, mode_idx, heading, [int(m) for m in res.modes], lines_g, axes)


def shapes_figure(mesh: NodeDofMap, xy: np.ndarray, lines, mode_idx: Sequence[int], heading: str,
                  mode_numbers: Sequence[int] | None = None, guide_lines=(), axes_dof=None) -> Figure:
    """Draw mode shapes: one axes per mode (column ``mode_idx`` of the shapes), one deformed
    line per entry of ``lines``, a list of ``(case name, shapes (n_free, n_mode) complex,
    frequencies (n_mode,) Hz)``, on the undeformed linkage ``xy`` (n_node, 2), with the
    prismatic guides ``guide_lines`` (:func:`archived_guides`); ``axes_dof`` (n_node, 2): the
    direction of each node's first translational DOF (default: :func:`node_axes` of the guides)."""
    xi = np.linspace(0.0, 1.0, N_SUB)
    extent = float(np.max(np.ptp(xy, axis=0)))
    base = linkage_polyline(mesh, xy, None, xi)
    if axes_dof is None:
        axes_dof = node_axes(mesh, xy, guide_lines)
    fig, axes = mode_grid(len(mode_idx), width=10.0, height=3.6)
    ground = np.all(mesh.node_dofs[:, :2] < 0, axis=1)
    for ax, m in zip(axes, mode_idx):
        ax.plot(base[:, 0], base[:, 1], color="0.6", lw=2.5, ls="-", label="undeformed", zorder=1)
        ax.plot(xy[ground, 0], xy[ground, 1], "k^", ms=8, label="_ground", zorder=2)
        draw_guides(ax, xy, mesh, guide_lines, extent)
        ref = None
        for c_n, (case, shapes, freq) in enumerate(lines):
            x = shapes[:, m]
            name = case_label(case)
            if not np.all(np.isfinite(x)):
                ax.plot([], [], label=f"{name}: no shape")
                continue
            z = align_phase(x, ref)
            ref = z if ref is None else ref
            disp = element_displacement(mesh, xy, z.real, xi, axes_dof)
            peak = float(np.max(np.linalg.norm(disp, axis=-1)))
            k = AMPLITUDE * extent / peak if peak > 0 else 0.0
            line = linkage_polyline(mesh, xy, k * disp, xi)
            style = case_style(case) or dict(color=f"C{c_n}")
            style["lw"] = min(style.get("lw", 1.3), 1.8)
            ax.plot(line[:, 0], line[:, 1], label=f"{name}: {freq[m]:.1f} Hz", zorder=3, **style)
        ax.set_title(f"mode {mode_numbers[m] if mode_numbers is not None else m + 1}")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    suptitle(fig, f"{heading} (peak drawn displacement {AMPLITUDE:.0%} of the linkage's extent)")
    return fig


__all__ = ["node_displacement", "element_displacement", "guides", "node_axes", "linkage_polyline", "align_phase", "mode_shape",
           "shapes_figure"]
