"""Out-of-plane mode shapes (docs/theory.md §19), drawn so that they read: for each mode, the
out-of-plane displacement w along every link (a line per link, against the station from its root)
and the twist ψ = θ·e of its nodes (markers on a second axis), each scaled to its largest value.

The DOFs of an out-of-plane model are (θ_X, θ_Y, w) per node (model/out_of_plane.py); a node's
twist is its rotation about its link's axis e, its bending rotation the one about e⊥.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.archive.reader import NodeDofMap
from fkev_slepc.plots.common import align_phase, mode_grid, node_displacement


def link_axes(mesh: NodeDofMap, node_xy: np.ndarray) -> np.ndarray:
    """Unit direction (n_node, 2) of the element each node belongs to (the last one listed), in
    the plane: the axis about which the node's rotation is a twist."""
    a, b = mesh.elem_nodes[:, 0], mesh.elem_nodes[:, 1]
    d = node_xy[b] - node_xy[a]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    out = np.tile([1.0, 0.0], (node_xy.shape[0], 1))
    out[a], out[b] = d, d
    return out


def out_of_plane_shape(mesh: NodeDofMap, node_xy: np.ndarray, q: np.ndarray, xi: np.ndarray = np.linspace(0, 1, 9)):
    """The shape of the free-DOF vector ``q`` (phase-aligned, real part): twist ψ = θ·e per node
    (n_node,), and w inside every element by its Hermite interpolation (slope w' = -θ·e⊥, §19.2)
    at ``xi``: stations and values, (n_el, n_xi) each."""
    z = align_phase(np.asarray(q), None).real
    th_x, th_y, w = node_displacement(mesh, z).T
    e = link_axes(mesh, node_xy)
    psi, slope = th_x * e[:, 0] + th_y * e[:, 1], -(th_y * e[:, 0] - th_x * e[:, 1])
    a, b = mesh.elem_nodes[:, 0], mesh.elem_nodes[:, 1]
    l = np.linalg.norm(node_xy[b] - node_xy[a], axis=1)[:, None]
    h = (1 - 3 * xi**2 + 2 * xi**3, xi * (1 - xi) ** 2, 3 * xi**2 - 2 * xi**3, -(xi**2) * (1 - xi))
    w_in = w[a, None] * h[0] + l * slope[a, None] * h[1] + w[b, None] * h[2] + l * slope[b, None] * h[3]
    return psi, mesh.node_s[a, None] + l * xi, w_in


def out_of_plane_figure(mesh: NodeDofMap, node_xy: np.ndarray, shapes: np.ndarray, freqs: np.ndarray,
                        mode_idx: Sequence[int], heading: str) -> Figure:
    """One axes per mode (column ``mode_idx`` of ``shapes`` (n_free, n_mode)): w / max|w| along each
    link (lines) and ψ / max|ψ| at its nodes (markers, right axis)."""
    fig, axes = mode_grid(len(mode_idx), width=10.0, height=3.6)
    for ax, m in zip(axes, mode_idx):
        psi, station, w = out_of_plane_shape(mesh, node_xy, shapes[:, m])
        w_max, psi_max = float(np.max(np.abs(w))) or 1.0, float(np.max(np.abs(psi))) or 1.0
        twin = ax.twinx()
        elem_link = mesh.node_link[mesh.elem_nodes[:, 0]]
        for k, name in enumerate(mesh.link_names):
            for j, e in enumerate(np.flatnonzero(elem_link == k)):
                ax.plot(station[e], w[e] / w_max, "-", color=f"C{k}", lw=1.6, label=f"{name}: w" if j == 0 else "_")
            on = np.flatnonzero(mesh.node_link == k)
            twin.plot(mesh.node_s[on], psi[on] / psi_max, "o", color=f"C{k}", ms=4, mfc="none",
                      label=f"{name}: twist ψ")
        ax.set_title(f"mode {m + 1}: {freqs[m]:.1f} Hz")
        ax.set_xlabel("station along the link from its root (m)")
        ax.set_ylabel("w / max|w| (lines)")
        twin.set_ylabel("ψ / max|ψ| (markers)")
        ax.set_ylim(-1.15, 1.15)
        twin.set_ylim(-1.15, 1.15)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
        twin.legend(fontsize=7, loc="lower right")
    fig.suptitle(f"{heading}\nout of the plane: displacement w along each link and the twist ψ of its nodes", fontsize=11)
    return fig


__all__ = ["link_axes", "out_of_plane_shape", "out_of_plane_figure"]
