"""Speed-domain figures: the stability map over (crank angle, speed) and the Campbell diagram."""

from __future__ import annotations

import math
import warnings
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
    label_orders,
    legend_outside,
    pick_angle,
    pick_cases,
    pick_modes,
    rpm_axis,
    set_title,
)
from fkev_slepc.archive.reader import SweepResults
from fkev_slepc.archive.tracks import read_tracking
from fkev_slepc.scene import SceneError, parse_scene

MAX_DEFAULT_ORDERS = 8
MIN_CAMPBELL_SPEEDS = 3  # fewer: no crossings marked, and a warning
STATUS_MARKS = (  # status, marker, colour, legend text
    (Status.DIVERGENT, "x", "k", "divergent (real λ > 0 in the spectrum)"),
    (Status.NOT_CONVERGED, "s", "0.4", "not converged"),
    (Status.FAILED, "D", "m", "failed"),
)


def stability(res: SweepResults, case: str | int | None = None) -> Figure:
    """Map of the smallest frozen-time damping ratio ζ = -Re λ/|λ| of the reported modes over
    (crank angle, speed) for one case (default ``full``), divergent and unconverged points marked.
    Frozen-time: each point holds the matrices at its crank angle; the verdict over a crank
    revolution is the Floquet one (``fkev floquet``, :mod:`fkev_slepc.plots.floquet`).

    Colour: a diverging, symmetric-log scale centred on ζ = 0: red is growth (unstable), blue
    decay; ±damping_tol (the ``unstable`` threshold) is the linear core, so round-off is
    white. Divergent points (a real eigenvalue anywhere in the spectrum) are grey with a cross:
    their ζ says nothing about the real eigenvalue.
    """
    c = res.case_index(case) if case is not None else res.case_index(default_case(res))
    st = res.status[:, :, c]
    conv = np.isin(st, [Status.OK.code, Status.UNSTABLE.code])
    z = res.damping_ratio[:, :, c, :]
    zmin = np.full(st.shape, np.nan)
    have = conv & np.any(np.isfinite(z), axis=-1)
    zmin[have] = np.nanmin(z[have], axis=-1)
    tol = float(res.attrs.get("damping_tol", 1e-6)) or 1e-6
    finite = np.abs(zmin[np.isfinite(zmin)])
    vmax = max(float(finite.max()) if finite.size else 0.0, 10 * tol)
    norm = SymLogNorm(linthresh=tol, vmin=-vmax, vmax=vmax, base=10)
    fig = Figure(figsize=(8.0, 5.4), layout="constrained")
    ax = fig.subplots()
    speed_edges = edges(res.speed_rad_s)  # the computed range only (half cells at the ends)
    a_edges = edges(res.crank_angle_deg)
    div = (st == Status.DIVERGENT.code).astype(float)
    if div.any():  # grey under the divergent points
        ax.pcolormesh(a_edges, speed_edges, np.where(div > 0, 1.0, np.nan).T, cmap="Greys", vmin=0, vmax=2.5,
                      shading="flat")
    mesh = ax.pcolormesh(a_edges, speed_edges, zmin.T, norm=norm, shading="flat", cmap="RdBu")
    cb = fig.colorbar(mesh, ax=ax, label="min frozen-time damping ratio ζ\nof the reported modes")
    cb.ax.axhline(-tol, color="k", lw=0.8)
    for status, marker, color, label in STATUS_MARKS:
        ia, i_s = np.nonzero(st == status.code)
        if ia.size:
            ax.scatter(
                res.crank_angle_deg[ia], res.speed_rad_s[i_s], marker=marker, c=color,
                s=16 if st.size <= 300 else 7, linewidths=0.8, label=f"{label}: {ia.size}",
            )
    n_unst = int(np.sum(st == Status.UNSTABLE.code))
    ax.set_xlabel(ANGLE_LABEL)
    ax.set_ylabel(SPEED_LABEL)
    if res.speeds_in_rpm:
        rpm_axis(ax, "y")
    if ax.get_legend_handles_labels()[0]:
        legend_outside(ax, "below", fontsize=8, ncol=3)
    set_title(fig, res, f"frozen-time stability map, case {res.cases[c]}{_damping_label(res)}\n{n_unst} unstable "
                        f"(ζ < -{tol:g}), {int(div.sum())} divergent of {st.size} points "
                        "(matrices held at each angle; over a revolution: fkev floquet)")
    return fig


def _damping_label(res: SweepResults) -> str:
    """``, Rayleigh damping α = 40 1/s, β = 1e-06 s`` when the run had any (the archived
    ``damping_alpha``/``damping_beta``; archives written before them: the archived scene text)."""
    if "damping_alpha" in res.attrs:
        a, b = float(res.attrs["damping_alpha"]), float(res.attrs.get("damping_beta", 0.0))
        return f", Rayleigh damping α = {a:g} 1/s, β = {b:g} s" if a > 0 or b > 0 else ""
    if not res.scene_toml:
        return ""
    try:
        damping = parse_scene(res.scene_toml, "archive").damping
    except SceneError:
        return ""
    a, b = damping.mass_proportional, damping.stiffness_proportional
    return f", Rayleigh damping α = {a:g} 1/s, β = {b:g} s" if damping.active else ""


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
    order: str = "tracked",
) -> Figure:
    """Campbell diagram at one crank angle: frequency vs crank speed per mode, with the
    crank-order excitation lines k·Ω/2π (k = 1..``orders``) and their crossings marked.

    ``order="tracked"``: modes followed along speed by MAC (``speed_tracked_frequency_hz``;
    lines whose links are ambiguous are in sorted order, and the title says so); ``"sorted"``:
    the i-th lowest at each speed. Defaults: θ = 10° if on the grid (else the first angle),
    case ``full``, every mode, and enough orders to reach the highest plotted frequency (at most 8).
    """
    a = pick_angle(res, angle)
    c_idx = pick_cases(res, cases, [default_case(res)])
    mode_idx = pick_modes(res, modes)
    om = res.speed_rad_s
    note = ""
    if order == "tracked":
        trk = read_tracking(res.path, res.table_plane)
        if trk["speed_tracked"] is None:
            order, note = "sorted", "; sorted modes (the archive has no tracking along speed)"
        else:
            f = np.where(res.converged[..., None], trk["speed_tracked"], np.nan)[a]
            fb = trk["speed_fallback"][a] if trk["speed_fallback"] is not None else np.zeros(len(res.cases), bool)
            note = _order_note([res.cases[c] for c in c_idx if not fb[c]], [res.cases[c] for c in c_idx if fb[c]])
    if order != "tracked":
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
    if om.size < MIN_CAMPBELL_SPEEDS:  # straight lines between 2 speeds: their crossings would be guesses
        cross_om = []
        note += f"; only {om.size} speed(s): lines join the computed speeds, crossings not marked"
        warnings.warn(f"Campbell diagram from {om.size} crank speed(s): the lines join computed points and say "
                      f"nothing between them; crossings need at least {MIN_CAMPBELL_SPEEDS} speeds", stacklevel=2)
    if cross_om:
        ax.scatter(cross_om, cross_f, s=40, facecolors="none", edgecolors="r", zorder=5,
                   label=f"crossings: {len(cross_om)}")
    ax.set_xlabel(SPEED_LABEL)
    if res.speeds_in_rpm:
        rpm_axis(ax, "x")
    ax.set_ylabel(FREQ_LABEL)
    ax.set_ylim(0, 1.08 * fmax)
    ax.set_xlim(0, om.max() * 1.04 if om.max() > 0 else 1)
    label_orders(ax, span[1], orders, 1.08 * fmax)
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=7)
    names = ", ".join(res.cases[c] for c in c_idx)
    set_title(fig, res, f"Campbell diagram at θ = {res.crank_angle_deg[a]:g}° ({names}){note}")
    return fig


def _order_note(tracked: list[str], left_sorted: list[str]) -> str:
    """The title's words on mode order: tracked, sorted, or which cases are which; never
    "tracked" and "SORTED" of the same lines.

    Examples
    --------
    >>> _order_note(["full"], []), _order_note([], ["full"])
    ('; modes tracked along speed', '; sorted modes (tracking along speed ambiguous: MAC)')
    >>> _order_note(["structure"], ["full"])
    '; modes tracked along speed for structure, sorted for full (MAC ambiguous)'
    """
    if not left_sorted:
        return "; modes tracked along speed"
    if not tracked:
        return "; sorted modes (tracking along speed ambiguous: MAC)"
    return f"; modes tracked along speed for {', '.join(tracked)}, sorted for {', '.join(left_sorted)} (MAC ambiguous)"
