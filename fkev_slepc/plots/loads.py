"""Figure of the kinetostatic loads over the crank cycle (``fkev loads --plot``,
``LoadsResult.plot``): left, every joint's force in the ground frame as a polar locus
(direction and magnitude of the force over one revolution), or with ``--polar link`` every
moving pin's force on each link it joins relative to that link (what a journal bearing on the
link sees); right, the driving torque vs crank angle with the power check stated."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.plots.common import ANGLE_LABEL


POLAR_FRAMES = ("ground", "link")


def _loci(loads, frame: str):
    """(label, x, y) of every polar locus: each joint's force in the ground frame, or every
    pin's force on each link it joins in that link's frame (x along the link, y its left normal)."""
    if frame == "ground":
        return [(name, loads.joint_force[:, jj, 0], loads.joint_force[:, jj, 1])
                for jj, name in enumerate(loads.joint_names)]
    return [(f"{loads.joint_names[jj]} on {loads.link_names[lk]}", loads.bearing_along[:, lk, k],
             loads.bearing_normal[:, lk, k])
            for jj, here in enumerate(loads.attach) if not loads.joint_ground[jj] for lk, k in here]


def draw_loads(loads, polar_frame: str = "ground") -> Figure:
    if polar_frame not in POLAR_FRAMES:
        raise ValueError(f"polar: must be one of {', '.join(POLAR_FRAMES)} (got {polar_frame!r})")
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
    polar = fig.add_subplot(1, 2, 1, projection="polar")
    for label, x, y in _loci(loads, polar_frame):
        direction, mag = np.unwrap(np.arctan2(y, x)), np.hypot(x, y)
        polar.plot(np.r_[direction, direction[:1]], np.r_[mag, mag[:1]], lw=1.4, label=label)
    polar.set_title("joint forces, ground frame: direction and |F| (N)" if polar_frame == "ground" else
                    "pin forces relative to each link (0°: root to tip), |F| (N)", fontsize=10)
    polar.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, title="joint", title_fontsize=8)
    ax = fig.add_subplot(1, 2, 2)
    deg = loads.crank_angle_deg
    ax.plot(deg, loads.torque, "k-", lw=1.8, label="driving torque τ")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel(ANGLE_LABEL)
    ax.set_ylabel("driving torque (N m)")
    ax.set_xlim(deg.min(), deg.max())
    ax.set_title(f"Ω = {loads.speed:g} rad/s, α = {loads.accel:g} rad/s², g = ({loads.gravity[0]:g}, "
                 f"{loads.gravity[1]:g}) m/s²\npower check max|τΩ − dE/dt| / max|τΩ| = {loads.power_residual:.1e}",
                 fontsize=9)
    ax.grid(alpha=0.3)
    return fig
