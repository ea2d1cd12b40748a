"""The cycle verdict over speed (``fkev floquet --plot``): the largest Floquet exponent per crank
revolution, log max|μ|, with the unstable runs (bands) shaded and labelled, the frozen-time critical
speeds beside them, and below it the share of crank angles the frozen-time verdict calls unstable.
Band labels stand above the axes, off the data; a label that would touch the previous one is left
to the text report and the JSON."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.plots.common import CHAR_EM, SPEED_LABEL, suptitle

LABEL_SIZE = 8  # points, the band labels
LABEL_GAP_PT = 6  # a band is labelled when its label stands this far (points) from the last one drawn


def speed_map(res) -> Figure:
    """Figure of a :class:`fkev_slepc.sweep.floquet_run.FloquetResults`."""
    w = np.asarray(res.speed_rad_s, dtype=float)
    growth = np.log(np.asarray(res.max_abs, dtype=float))  # per revolution
    fig = Figure(figsize=(8.0, 5.6), layout="constrained")
    ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
    span = np.ptp(w) if w.size > 1 else 1.0
    per_pt = 1.1 * span / (72 * max(fig.get_figwidth() - 1.3, 1.0))  # rad/s per point along the axes (about)
    last, last_half = -np.inf, 0.0  # the centre and half width (rad/s) of the last label drawn
    for i, b in enumerate(res.bands):
        lo, hi = (b.lower if np.isfinite(b.lower) else b.peak_speed), (b.upper if np.isfinite(b.upper) else b.peak_speed)
        ax.axvspan(lo, hi, color="tab:red", alpha=0.2, lw=0, label="unstable runs (outer edges refined;\ninside, sampled at grid speeds only)" if i == 0 else None)
        text = b.resonance or "?"
        half = 0.5 * len(text) * CHAR_EM * LABEL_SIZE * per_pt
        if 0.5 * (lo + hi) - last > last_half + half + LABEL_GAP_PT * per_pt:  # crowded: in the text report and JSON only
            last, last_half = 0.5 * (lo + hi), half
            ax.annotate(text, (last, 1.0), xycoords=("data", "axes fraction"), xytext=(0, 2),  # above the axes, off the data
                        textcoords="offset points", ha="center", va="bottom", fontsize=LABEL_SIZE, color="tab:red")
    ax.plot(w, growth, ".-", color="k", lw=1, ms=4, label="log max|μ| per revolution (Floquet)")
    _gaps(ax, getattr(res, "gaps", ()), getattr(res, "resonance_order", 0))
    ax.axhline(np.log1p(res.tol), color="0.5", lw=0.8, ls=":", label=f"threshold log(1 + {res.tol:g})")
    crit = res.extras.get("frozen_time_critical") or {}
    for key, style, name in (("flutter_speed_rad_s", "--", "frozen-time flutter"),
                             ("divergence_speed_rad_s", "-.", "frozen-time divergence")):
        v = crit.get(key)
        if v is not None:
            for a in (ax, ax2):
                a.axvline(v, color="tab:blue", ls=style, lw=1, label=f"{name} {v:.4g} rad/s" if a is ax else None)
    finite = np.abs(growth[np.isfinite(growth)])
    lin = max(res.tol, 1e-14)
    ax.set_yscale("symlog", linthresh=lin, linscale=1.0)
    ax.set_ylim(-max(finite.max() if finite.size else lin, 10 * lin) * 2, max(finite.max() if finite.size else lin, 10 * lin) * 5)
    ax.set_ylabel("largest Floquet exponent\nlog max|μ| per revolution")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left", framealpha=0.85)
    frac = 100 * np.asarray(res.frozen_unstable_fraction, dtype=float)
    ax2.step(w, frac, where="mid", color="tab:blue")
    ax2.set_ylim(0, 105)
    ax2.set_ylabel("frozen-time\nunstable θ (%)")
    ax2.set_xlabel(SPEED_LABEL)
    ax2.grid(alpha=0.3)
    n = len(res.bands)
    suptitle(fig, f"{res.title}: cycle (Floquet) verdict, case {res.case}; {n} unstable run{'s' if n != 1 else ''}", 10)
    return fig


def _gaps(ax, gaps, order: int) -> None:
    """The grid's blind spots: resonance candidates between stable grid speeds, as ticks at the
    bottom (hollow: not sampled; filled: probed, at the probe's log max|μ| on the curve's axis)."""
    for probed, style in ((False, dict(mfc="none")), (True, {})):
        sel = [g for g in gaps if bool(g.probe_status) == probed]
        if not sel:
            continue
        x = [g.resonance.speed for g in sel]
        name = (f"resonance candidates n <= {order} probed" if probed else
                f"resonance candidates n <= {order} not sampled (between stable speeds)")
        if probed:
            ax.plot(x, np.log([g.probe_max_abs for g in sel]), "D", color="tab:orange", ms=4, ls="none", label=name)
        else:
            ax.plot(x, np.zeros(len(x)), "^", transform=ax.get_xaxis_transform(), color="tab:orange", ms=5, ls="none",
                    clip_on=False, label=name, **style)
