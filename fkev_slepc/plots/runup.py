"""The run-up figure (``fkev runup --plot``, ``RunupResult.plot``): per link the peak |stress| (or,
without fibre distances, the peak deflection) of every crank revolution against the crank speed at
its end, and, beside it, against time; ``bands`` (Ω intervals, rad/s) are shaded, ``critical``
speeds (rad/s) drawn as vertical lines (docs/runup.md)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.plots.common import SPEED_LABEL


def draw_runup(result, path=None, bands=(), critical=()):
    """The figure (saved to ``path`` when given)."""
    S = np.array(result.peak_stress_pa, float).reshape(-1, len(result.link_names))
    D = np.array(result.peak_deflection_m, float).reshape(-1, len(result.link_names))
    stress = np.isfinite(S).any()
    Y, label = (S / 1e6, "peak |σ| per revolution (MPa)") if stress else (D * 1e3, "peak deflection per revolution (mm)")
    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    ax_w, ax_t = fig.subplots(1, 2)
    w, t = np.asarray(result.speed_rad_s, float), np.asarray(result.time_s, float)
    for j, name in enumerate(result.link_names):
        ax_w.plot(w, Y[:, j], marker=".", ms=3, lw=1.2, label=name)
        ax_t.plot(t, Y[:, j], marker=".", ms=3, lw=1.2, label=name)
    for lo, hi in bands:
        ax_w.axvspan(lo, hi, color="tab:red", alpha=0.12, lw=0)
    for c in critical:
        ax_w.axvline(c, color="0.4", ls=":", lw=1.0)
    ax_w.set_xlabel(SPEED_LABEL)
    ax_t.set_xlabel("time t (s)")
    for ax in (ax_w, ax_t):
        ax.set_ylabel(label)
        ax.set_yscale("log" if np.nanmax(Y) > 100 * max(np.nanmin(Y[Y > 0]) if (Y > 0).any() else 1, 1e-300) else "linear")
        ax.grid(alpha=0.3)
    ax_w.legend(fontsize=8)
    fig.suptitle(f"{result.title}: run-up, {result.case}", fontsize=10)
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig
