"""Band Campbell diagram: each mode's frequency band over the whole crank cycle (min-max over θ)
against crank speed, with the crank-order lines n·Ω/2π (fkev_slepc/design/margins.py).

A single-angle Campbell diagram shows one curve per mode; at constant speed the frequencies
sweep a band as the crank turns, and an order line inside a band is a resonance passage every
revolution. Bands are drawn only at the computed speeds: a bar per speed, and the shaded band
between speeds only when at least three were computed (two give no shape to shade).
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.archive.reader import SweepResults
from fkev_slepc.design.margins import bands
from fkev_slepc.plots.common import (FREQ_LABEL, SPEED_LABEL, default_case, label_orders, legend_outside, pick_modes,
                                     rpm_axis, set_title)

MIN_SPEEDS_TO_SHADE = 3
MAX_ORDERS = 48  # default orders reach the highest band, up to this many lines


def band_campbell(res: SweepResults, case: str | None = None, modes=None, orders: int | None = None,
                  order: str | None = None, speed: float | None = None) -> Figure:
    """Bands of ``modes`` (default all) over speed for ``case`` (default ``full``), with ``orders``
    crank orders (default: enough to pass the highest band, at most MAX_ORDERS) and the operating
    ``speed`` (rad/s) marked if given."""
    case = default_case(res) if case is None else case
    res.case_index(case)
    if order is None:
        order = "tracked" if np.isfinite(res.tracked_frequency_hz).any() else "sorted"
    lo, hi = bands(res, case, order)
    picked = pick_modes(res, modes)
    om = np.asarray(res.speed_rad_s, float)
    top = float(np.nanmax(hi[:, picked])) if np.isfinite(hi[:, picked]).any() else 1.0
    w_max = float(om.max()) if om.max() > 0 else 1.0
    if orders is None:
        orders = int(min(MAX_ORDERS, max(1, math.ceil(top / (w_max / (2 * math.pi))))))
    fig = Figure(figsize=(9.5, 5.2), layout="constrained")
    ax = fig.subplots()
    width = 0.012 * w_max
    for m in picked:
        color = f"C{m % 10}"
        ok = np.isfinite(lo[:, m])
        ax.bar(om[ok], hi[ok, m] - lo[ok, m], bottom=lo[ok, m], width=width, color=color, alpha=0.85,
               label=f"mode {res.modes[m]}: min-max over θ")
        if ok.sum() >= MIN_SPEEDS_TO_SHADE:
            ax.fill_between(om[ok], lo[ok, m], hi[ok, m], color=color, alpha=0.18, lw=0)
    span = np.array([0.0, w_max * 1.04])
    for k in range(1, orders + 1):
        ax.plot(span, k * span / (2 * math.pi), color="0.5", lw=0.8, ls="--",
                label=f"crank orders n·Ω/2π, n = 1..{orders}" if k == 1 else "_order")
    if speed is not None:
        ax.axvline(speed, color="k", lw=1.0, ls=":", label=f"operating speed {speed:g} rad/s")
    ax.set_xlabel(SPEED_LABEL)
    if res.speeds_in_rpm:
        rpm_axis(ax, "x")
    ax.set_ylabel(FREQ_LABEL)
    ax.set_ylim(0, 1.08 * top)
    ax.set_xlim(0, span[1])
    label_orders(ax, span[1], orders, 1.08 * top, color="0.35")  # just right of the axes
    ax.grid(alpha=0.3)
    legend_outside(ax, "below", fontsize=7, ncol=2)  # never over data, nor over the order labels on the right
    shade = "" if om.size >= MIN_SPEEDS_TO_SHADE else f"; {om.size} speed{'s' if om.size > 1 else ''} computed: bars only"
    set_title(fig, res, f"frequency bands over the crank cycle vs speed ({case}, {order} modes{shade})")
    return fig
