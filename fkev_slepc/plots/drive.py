"""Figure of the drive's steady cycle (``fkev drive --plot``, ``DriveResult.plot``): left, the
crank speed over the revolution with its mean and δ; right, the motor's torque at the crank
(n T_m), the torque the drive puts into the crank and the load torque of gravity and the process
loads (docs/theory.md §20)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.plots.common import ANGLE_LABEL, fit_width


def draw_drive(result) -> Figure:
    c = result.cycle
    deg = np.r_[np.degrees(c.theta), 360.0]
    loop = lambda x: np.r_[x, x[:1]]  # noqa: E731 - close the revolution
    fig = Figure(figsize=(11.0, 4.4), layout="constrained")
    ax = fig.add_subplot(1, 2, 1)
    ax.plot(deg, loop(c.speed), "k-", lw=1.8, label="crank speed ω")
    ax.axhline(c.mean_speed, color="C0", lw=1.0, ls="--", label=f"mean {c.mean_speed:.5g} rad/s")
    ax.set_xlabel(ANGLE_LABEL)
    ax.set_ylabel("crank speed (rad/s)")
    ax.set_title(fit_width(f"{result.title}\nδ = (ω_max − ω_min)/ω_mean = {c.fluctuation:.4g}, flywheel "
                           f"{c.drive.flywheel_inertia:g} kg m²", 0.45 * fig.get_figwidth(), 9), fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    tx = fig.add_subplot(1, 2, 2)
    tx.plot(deg, loop(c.drive.gear_ratio * c.motor_torque), "C1-", lw=1.6, label="motor at the crank n·T_m")
    tx.plot(deg, loop(c.crank_torque), "k-", lw=1.6, label="into the crank n·T_m − J_d·θ̈")
    tx.plot(deg, loop(c.load_torque), "C2--", lw=1.2, label="load (gravity, process)")
    tx.axhline(0.0, color="0.6", lw=0.8)
    tx.set_xlabel(ANGLE_LABEL)
    tx.set_ylabel("torque (N m)")
    tx.legend(fontsize=8)
    tx.grid(alpha=0.3)
    for a in (ax, tx):
        a.set_xlim(0.0, 360.0)
    return fig
