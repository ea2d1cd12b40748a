"""Speed-domain figures: the stability map over (crank angle, speed) and the Campbell diagram."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from matplotlib.colors import SymLogNorm
from matplotlib.figure import Figure

from fkev_slepc.status import Status
from fkev_slepc.plots.common import (
    ANGLE_LABEL,
    FREQ_LABEL,
    SPEED_LABEL,
    default_case,
    edges,
    pick_angle,
    pick_cases,
    pick_modes,
    set_title,
)
from fkev_slepc.archive.reader import SweepResults

MAX_DEFAULT_ORDERS = 8
STATUS_MARKS = (  # status, marker, colour, legend text
    (Status.UNSTABLE, "^", "k", "unstable (Re λ > 0)"),
    (Status.DIVERGENT, "x", "k", "divergent (real λ > 0)"),
    (Status.NOT_CONVERGED, "s", "0.4", "not converged"),
    (Status.FAILED, "D", "m", "failed"),
)


def stability(res: SweepResults, case: str | int | None = None) -> Figure:
    """Map of max Re λ (1/s) over (crank angle, speed) for one case, with unstable, divergent
    and unconverged points marked (default case ``full``).

    Colour: a symmetric log scale, red for growth; blue (decay) appears only if some point has
    every Re λ < 0, which an undamped model never has. Values within 1e-6 of the largest
    |max Re λ| are white.
    """
    c = res.case_index(case) if case is not None else res.case_index(default_case(res))
    mr = res.max_real[:, :, c]
    st = res.status[:, :, c]
    fig = Figure(figsize=(8.0, 4.6), layout="constrained")
    ax = fig.subplots()
    finite = np.abs(mr[np.isfinite(mr)])
    vmax = float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    # Growth rates span decades (flutter ~0.1/s, divergence ~1e3/s) above round-off (~1e-12/s);
    # a log scale shows both.
    two_sided = bool(np.any(mr < -1e-6 * vmax))
    norm = SymLogNorm(linthresh=1e-6 * vmax, vmin=-vmax if two_sided else 0.0, vmax=vmax, base=10)
    speed_edges = edges(res.speed_rad_s)
    if res.speed_rad_s.min() >= 0 and res.speed_rad_s.size > 1:  # no negative speeds on the axis
        speed_edges = np.maximum(speed_edges, 0.0)
    mesh = ax.pcolormesh(
        edges(res.crank_angle_deg), speed_edges, mr.T, norm=norm, shading="flat",
        cmap="RdBu_r" if two_sided else "Reds",
    )
    fig.colorbar(mesh, ax=ax, label="max Re λ (1/s)")
    for status, marker, color, label in STATUS_MARKS:
        ia, i_s = np.nonzero(st == status.code)
        if ia.size:
            ax.scatter(
                res.crank_angle_deg[ia], res.speed_rad_s[i_s], marker=marker, c=color,
                s=16 if st.size <= 300 else 7, linewidths=0.8, label=f"{label}: {ia.size}",
            )
    n_ok = int(np.sum(st == Status.OK.code))
    ax.set_xlabel(ANGLE_LABEL)
    ax.set_ylabel(SPEED_LABEL)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8, loc="upper right", framealpha=0.85)
    set_title(fig, res, f"stability map, case {res.cases[c]} ({n_ok} of {st.size} points ok)")
    return fig


def crossings(speed: np.ndarray, freq: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the curve ``freq(speed)`` (Hz) meets the crank-order line k·Ω/2π, by linear
    interpolation between neighbouring speeds. Returns (Ω, f) of each crossing."""
    g = np.asarray(freq, dtype=float) - k * np.asarray(speed) / (2 * np.pi)
    if g.size < 2:
        return np.zeros(0), np.zeros(0)
    ok = np.isfinite(g[:-1]) & np.isfinite(g[1:])
    hit = np.flatnonzero(ok & (np.sign(g[:-1]) != np.sign(g[1:])) & (g[:-1] != 0))
    t = g[hit] / (g[hit] - g[hit + 1])
    om = speed[hit] + t * (speed[hit + 1] - speed[hit])
    return om, k * om / (2 * np.pi)


def campbell(
    res: SweepResults,
    angle: float | None = None,
    cases: Sequence[str | int] | None = None,
    modes: Sequence[int] | None = None,
    orders: int | None = None,
    order: str = "sorted",
) -> Figure:
    """Campbell diagram at one crank angle: frequency vs crank speed per mode, with the
    crank-order excitation lines k·Ω/2π (k = 1..``orders``) and their crossings marked.

    Defaults: θ = 10° if on the grid (else the first angle), case ``full``, every mode, and
    enough orders to reach the highest plotted frequency (at most 8).
    """
    a = pick_angle(res, angle)
    c_idx = pick_cases(res, cases, [default_case(res)])
    mode_idx = pick_modes(res, modes)
    om = res.speed_rad_s
    f = res.frequency(order=order)[a]
    shown = f[:, c_idx][:, :, mode_idx]
    fmax = float(np.nanmax(shown)) if np.any(np.isfinite(shown)) else 1.0
    if orders is None:
        top = om.max() / (2 * np.pi)
        orders = int(min(MAX_DEFAULT_ORDERS, max(1, math.ceil(fmax / top)))) if top > 0 else 1
    fig = Figure(figsize=(8.0, 5.2), layout="constrained")
    ax = fig.subplots()
    styles = ["-", "--", ":", "-."]
    cross_om, cross_f = [], []
    for c_n, c in enumerate(c_idx):
        for m in mode_idx:
            label = f"mode {res.modes[m]}" + (f", {res.cases[c]}" if len(c_idx) > 1 else "")
            ax.plot(om, f[:, c, m], styles[c_n % len(styles)], color=f"C{m}",
                    marker="." if om.size < 15 else None, label=label)
            for k in range(1, orders + 1):
                xo, yo = crossings(om, f[:, c, m], k)
                cross_om.extend(xo)
                cross_f.extend(yo)
    span = np.array([0.0, om.max()])
    for k in range(1, orders + 1):
        ax.plot(span, k * span / (2 * np.pi), color="0.55", lw=0.8, ls="--", gid=f"order-{k}",
                label=f"crank orders k·Ω/2π, k = 1..{orders}" if k == 1 else "_order")
        ax.annotate(f"{k}×", (span[1], k * span[1] / (2 * np.pi)), fontsize=7, color="0.4",
                    xytext=(2, 0), textcoords="offset points")
    if cross_om:
        ax.scatter(cross_om, cross_f, s=40, facecolors="none", edgecolors="r", zorder=5,
                   label=f"crossings: {len(cross_om)}")
    ax.set_xlabel(SPEED_LABEL)
    ax.set_ylabel(FREQ_LABEL)
    ax.set_ylim(0, 1.08 * fmax)
    ax.set_xlim(0, om.max() * 1.04 if om.max() > 0 else 1)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    names = ", ".join(res.cases[c] for c in c_idx)
    set_title(fig, res, f"Campbell diagram at θ = {res.crank_angle_deg[a]:g}° ({names})")
    return fig
