"""Figure of the kinetostatic loads over the crank cycle (``fkev loads --plot``,
``LoadsResult.plot``): left, every joint's force in the ground frame as a polar locus
(direction and magnitude of the force over one revolution); right, the driving torque vs crank
angle with the power check dE/dt = τΩ stated."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from fkev_slepc.plots.common import ANGLE_LABEL, fit_width


def draw_loads(loads) -> Figure:
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
    polar = fig.add_subplot(1, 2, 1, projection="polar")
    mag = loads.joint_magnitude
    for jj, name in enumerate(loads.joint_names):
        f = loads.joint_force[:, jj]
        direction = np.unwrap(np.arctan2(f[:, 1], f[:, 0]))
        polar.plot(np.r_[direction, direction[:1]], np.r_[mag[:, jj], mag[:1, jj]], lw=1.4, label=name)
    polar.set_title("joint forces, ground frame: direction and |F| (N)", fontsize=10)
    polar.yaxis.set_major_locator(MaxNLocator(4))  # radial labels climb diagonally: few enough not to touch
    polar.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, title="joint", title_fontsize=8)
    ax = fig.add_subplot(1, 2, 2)
    deg = loads.crank_angle_deg
    ax.plot(deg, loads.torque, "k-", lw=1.8, label="driving torque τ")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel(ANGLE_LABEL)
    ax.set_ylabel("driving torque (N m)")
    ax.set_xlim(deg.min(), deg.max())
    ax.set_title(fit_width(f"Ω = {loads.speed:g} rad/s, α = {loads.accel:g} rad/s², g = ({loads.gravity[0]:g}, "
                 f"{loads.gravity[1]:g}) m/s²\npower check max|τΩ − dE/dt| / max|τΩ| = {loads.power_residual:.1e}",
                           0.42 * fig.get_figwidth(), 9), fontsize=9)
    ax.grid(alpha=0.3)
    return fig
