"""Figures of the steady periodic response (docs/response.md §5): the deflected linkage at
several crank angles (magnified, the factor stated), an animation over one revolution (GIF),
stress (or bending moment) vs crank angle per station, and peak response vs speed with the
forced-resonance speeds and Floquet bands."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.plots.common import ANGLE_LABEL, SPEED_LABEL, fit_width, suptitle

AXES_SHARE = 0.85  # of a one-axes figure's width: the axes (beside the y label)
RESONANCE_GAP_PT = 11  # resonance labels (7 pt, rotated) closer than this share one label


def magnification(res, scale=None) -> float:
    """The given factor, or one that draws the largest deflection at 8 % of the linkage's
    size, rounded to 1, 2 or 5 times a power of ten."""
    if scale is not None:
        return float(scale)
    size = np.ptp(res.node_positions.reshape(-1, 2), axis=0).max()
    peak = np.nanmax(np.hypot(res.node_displacement[..., 0], res.node_displacement[..., 1]))
    if not peak > 0:
        return 1.0
    raw = 0.08 * size / peak
    e = np.floor(np.log10(raw))
    m = raw / 10**e
    return float((1 if m < 2 else 2 if m < 5 else 5) * 10**e)


def _draw(ax, res, a, scale):
    xy, d = res.node_positions[a], res.node_displacement[a]
    for i, j in res.elem_nodes:
        ax.plot(xy[[i, j], 0], xy[[i, j], 1], color="0.7", lw=1.0)
        ax.plot(xy[[i, j], 0] + scale * d[[i, j], 0], xy[[i, j], 1] + scale * d[[i, j], 1], color="tab:blue", lw=2.0)
    ax.set_aspect("equal")


def draw_deflected(res, angles=None, scale=None) -> Figure:
    """The rigid linkage (grey) and the deflected one (blue, deflections x scale) at 4 angles."""
    n = len(res.angle_deg)
    idx = [int(np.argmin(np.abs(res.angle_deg - a))) for a in angles] if angles is not None else \
        [int(k) for k in np.linspace(0, n, 4, endpoint=False)]
    scale = magnification(res, scale)
    fig = Figure(figsize=(3.2 * len(idx), 3.4), layout="constrained")
    axes = fig.subplots(1, len(idx), sharex=True, sharey=True)
    for ax, a in zip(np.atleast_1d(axes), idx):
        _draw(ax, res, a, scale)
        ax.set_title(f"θ = {res.angle_deg[a]:g}°", fontsize=9)
    suptitle(fig, f"{res.title}: Ω = {res.speed:g} rad/s, case {res.case}; elastic deflections × {scale:g} "
                  "(grey: rigid-body position)", 9)
    return fig


def animate(res, path, scale=None, fps: int = 12):
    """GIF of the deflected linkage over the output angles (PillowWriter)."""
    import matplotlib.animation as animation

    scale = magnification(res, scale)
    fig = Figure(figsize=(5.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    allxy = res.node_positions.reshape(-1, 2)
    pad = 0.1 * np.ptp(allxy, axis=0).max()
    writer = animation.PillowWriter(fps=fps)
    with writer.saving(fig, str(path), dpi=80):
        for a in range(len(res.angle_deg)):
            ax.clear()
            _draw(ax, res, a, scale)
            ax.set_xlim(allxy[:, 0].min() - pad, allxy[:, 0].max() + pad)
            ax.set_ylim(allxy[:, 1].min() - pad, allxy[:, 1].max() + pad)
            ax.set_title(f"Ω = {res.speed:g} rad/s, θ = {res.angle_deg[a]:g}°, deflections × {scale:g}", fontsize=9)
            writer.grab_frame()
    return path


def draw_stations(res) -> Figure:
    """Stress vs crank angle per station (bending moment where the section has no fibre distance)."""
    sr = res.stations
    stress = np.isfinite(sr.stress).any()
    y, label = (sr.stress / 1e6, "extreme-fibre stress max |σ| (MPa)") if stress else \
        (sr.moment, "bending moment M (N m)")
    fig = Figure(figsize=(8.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    for k, st in enumerate(sr.stations):
        ax.plot(res.angle_deg, y[:, k], lw=1.4, label=f"{res.link_names[st.link]} @ {st.s:g} m")
    ax.set_xlabel(ANGLE_LABEL)
    ax.set_ylabel(label)
    ax.set_title(fit_width(f"{res.title}: Ω = {res.speed:g} rad/s, case {res.case}", AXES_SHARE * fig.get_figwidth(), 9), fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return fig


def draw_speed_response(sp, bands=()) -> Figure:
    """Peak stress (or peak chord deflection) of each station vs speed; dashed: n·Ω = ω̄ₖ; shaded:
    Floquet-unstable bands (``bands``: (lower, upper) rad/s)."""
    stress = np.isfinite(sp.peak_stress).any()
    y, label = (sp.peak_stress / 1e6, "peak extreme-fibre stress (MPa)") if stress else \
        (sp.peak_chord * 1e3, "peak transverse deflection from the chord (mm)")
    fig = Figure(figsize=(8.5, 4.4), layout="constrained")
    ax = fig.add_subplot()
    for k, lab in enumerate(sp.station_labels):
        ax.semilogy(sp.speeds, np.maximum(y[:, k], 1e-300), lw=1.4, marker=".", label=lab)
    for r in sp.resonances:
        ax.axvline(r["speed_rad_s"], color="0.5", ls="--", lw=0.8)
    per_pt = 1.1 * np.ptp(sp.speeds) / (72 * max(fig.get_figwidth() - 1.3, 1.0))  # rad/s per point (about)
    for x, text in resonance_labels(sp.resonances, RESONANCE_GAP_PT * per_pt):
        ax.text(x, 1.0, f" {text}", transform=ax.get_xaxis_transform(), rotation=90, va="top", fontsize=7, color="0.4")
    for lo, hi in bands:
        ax.axvspan(lo, hi, color="tab:red", alpha=0.15, lw=0)
    ax.set_xlabel(SPEED_LABEL)
    ax.set_ylabel(label)
    ax.set_title(fit_width(f"{sp.title}: peak response over the cycle vs speed, case {sp.case}\n(dashed: forced "
                           "resonances n·Ω = cycle-mean frozen ω̄ₖ; shaded: Floquet-unstable)", AXES_SHARE * fig.get_figwidth(), 8),
                 fontsize=8)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3, which="both")
    return fig


def resonance_labels(resonances, gap: float) -> list[tuple[float, str]]:
    """(speed, text) of the forced-resonance labels: ``nΩ=ω̄k`` at each resonance speed, those
    less than ``gap`` (rad/s) after the previous label joined to it ("5Ω=ω̄3, 1Ω=ω̄1").

    Examples
    --------
    >>> resonance_labels([{"speed_rad_s": 100.0, "order": 2, "mode": 1}, {"speed_rad_s": 103.0, "order": 5, "mode": 2},
    ...                   {"speed_rad_s": 150.0, "order": 1, "mode": 1}], gap=10.0)
    [(100.0, '2Ω=ω̄1, 5Ω=ω̄2'), (150.0, '1Ω=ω̄1')]
    """
    out: list[tuple[float, str]] = []
    for r in sorted(resonances, key=lambda r: r["speed_rad_s"]):
        text = f"{r['order']}Ω=ω̄{r['mode']}"
        if out and r["speed_rad_s"] - out[-1][0] < gap:
            out[-1] = (out[-1][0], f"{out[-1][1]}, {text}")
        else:
            out.append((float(r["speed_rad_s"]), text))
    return out


def draw_link_stress(res) -> Figure:
    """Left: the signed stress range [σ_min, σ_max] over the cycle along each link, both faces
    (σ₊ at +c, σ₋ at −c along the left normal; fkev_slepc/periodic/link_stress.py). Right: σ₊ and σ₋ over the
    crank angle at the point of the peak |σ|."""
    ls = res.link_stress
    hi, lo, _, _ = ls.parts()
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    along, cycle = fig.subplots(1, 2)
    peaks = [(lk, ls.peak(lk)) for lk in range(len(ls.link_names))]
    peaks = [(lk, p) for lk, p in peaks if p is not None]
    for lk, _ in peaks:
        sel = np.flatnonzero(ls.point_link == lk)
        for f, (face, style) in enumerate(zip(("σ₊", "σ₋"), ("-", "--"))):
            line, = along.plot(ls.point_s[sel], hi[sel, f] / 1e6, style, lw=1.2,
                               label=f"{ls.link_names[lk]} {face} max/min")
            along.plot(ls.point_s[sel], lo[sel, f] / 1e6, style, lw=1.2, color=line.get_color())
            along.fill_between(ls.point_s[sel], lo[sel, f] / 1e6, hi[sel, f] / 1e6, color=line.get_color(), alpha=0.08)
    along.set_xlabel("s from the link's root (m)")
    along.set_ylabel("signed extreme-fibre stress (MPa)")
    along.set_title("stress range over the cycle along each link", fontsize=9)
    along.grid(alpha=0.3)
    if peaks:
        along.legend(fontsize=7)
        lk, p = max(peaks, key=lambda item: item[1]["stress_pa"])
        for f, face in enumerate(("σ₊ (+c)", "σ₋ (−c)")):
            cycle.plot(ls.angle_deg, ls.sigma[:, p["point"], f] / 1e6, lw=1.4, label=face)
        cycle.set_title(fit_width(f"critical point: {ls.link_names[lk]} at s = {p['s_m']:g} m (peak |σ| "
                        f"{p['stress_pa'] / 1e6:.4g} MPa at θ = {p['crank_angle_deg']:g}°)", 0.45 * fig.get_figwidth(), 9),
                        fontsize=9)
        cycle.legend(fontsize=7)
    cycle.set_xlabel(ANGLE_LABEL)
    cycle.set_ylabel("signed extreme-fibre stress (MPa)")
    cycle.grid(alpha=0.3)
    suptitle(fig, f"{res.title}: Ω = {res.speed:g} rad/s, case {res.case}", fontsize=9)
    return fig
