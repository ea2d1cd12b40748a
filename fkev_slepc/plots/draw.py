"""Figures drawn from :class:`~fkev_slepc.archive.reader.SweepResults` (matplotlib, no pyplot state).

Every function returns a :class:`matplotlib.figure.Figure` and never recomputes physics: it
draws archive arrays, or the §12 ratios :mod:`fkev_slepc.archive.reader` derives from them. Lines
carry labels naming the speed / case / mode they draw, so tests (and users) can read the
plotted data back from the figure. One axes per mode; the figure title names the scene.

Kinds (thesis Chapter 3 figure numbers in brackets):

``freq-angle``  natural frequency vs crank angle, one curve per speed  [3.2-3.4, 3.6-3.9]
``param-speed`` ω_i(case)/ω_i(structure) vs α = Ω/ω_1(structure) at one angle  [3.10-3.13]
``error-angle`` % error of the simplified cases vs ``full`` over the cycle, MAC-matched modes  [3.14-3.21]
``mode-shape``  mode shapes on the undeformed linkage  [3.22-3.25]  (:mod:`.plots_shapes`)
``stability``   max Re λ over (crank angle, speed), unstable/divergent marked  (:mod:`.plots_maps`)
``campbell``    frequency vs speed at one angle with crank-order lines k·Ω/2π  (:mod:`.plots_maps`)
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.scene.cases import CASE_NAMES
from fkev_slepc.plots.common import (
    FREQ_LABEL,
    SIMPLIFIED,
    angle_axis,
    case_label,
    case_style,
    default_case,
    elements_tag,
    mode_grid,
    only_one,
    pick_angle,
    pick_cases,
    pick_modes,
    pick_speed,
    set_title,
    speed_label,
    suptitle,
)
from fkev_slepc.plots.maps import campbell, stability
from fkev_slepc.plots.shapes import mode_shape
from fkev_slepc.archive.reader import ArchiveError, SweepResults
from fkev_slepc.archive.tracks import read_refined, read_signature, read_tracking
from fkev_slepc.solve.modes import percent_error
from fkev_slepc.status import converged_codes
from fkev_slepc.sweep.tracking import match_cases

KINDS = ("freq-angle", "param-speed", "error-angle", "mode-shape", "stability", "campbell", "bands")
__all__ = ["KINDS", "draw", "freq_angle", "param_speed", "error_angle", "mode_shape", "stability",
           "campbell", "case_label"]


def freq_angle(
    results: SweepResults | Sequence[SweepResults],
    cases: Sequence[str | int] | None = None,
    speeds: Sequence[float] | None = None,
    modes: Sequence[int] | None = None,
    order: str = "tracked",
) -> Figure:
    """Natural frequency vs crank angle, one axes per mode, one curve per speed (Figs 3.6-3.9).

    Several archives of one scene at different meshes (``--elements``) are overlaid and
    labelled by their element counts (Figs 3.2-3.4: convergence). Points that did not converge
    are gaps. Defaults: case ``full`` (else the first case), every speed and mode, modes
    tracked along the crank angle (``order="sorted"``: the i-th lowest at each angle).
    Tracked curves also pass through the extra angles the sweep solved where neighbouring grid
    angles could not be matched (``/tracking/refined``, docs/tracking.md), drawn as dots: a
    sharp veering is drawn as solved, not as a straight line between two grid angles.
    """
    runs = [results] if isinstance(results, SweepResults) else list(results)
    first = runs[0]
    mode_idx = pick_modes(first, modes)
    fig, axes = mode_grid(len(mode_idx))
    dashes = ["-", "--", ":", "-."]
    sorted_lines = []  # tracked order asked for, but the archive left these lines sorted
    extra_angles: set[float] = set()  # refined angles drawn
    for r_i, res in enumerate(runs):
        c_idx = pick_cases(res, cases, [default_case(res)])
        s_idx = [res.speed_index(s) for s in speeds] if speeds else list(range(res.speed_rad_s.size))
        f = res.frequency(order=order)
        fallback = read_tracking(res.path, res.table_plane)["fallback"] if order == "tracked" else None
        refined = read_refined(res.path, res.table_plane) if order == "tracked" else None
        for ax, m in zip(axes, mode_idx):
            for c_n, c in enumerate(c_idx):
                for s_n, s in enumerate(s_idx):
                    parts = [speed_label(res.speed_rad_s[s], res.speeds_in_rpm)]
                    if len(c_idx) > 1 or cases:
                        parts.append(res.cases[c])
                    if len(runs) > 1:
                        parts.append(elements_tag(res))
                    x, y, extra = res.crank_angle_deg, f[:, s, c, m], []
                    if fallback is not None and fallback[s, c]:
                        parts.append("sorted")
                        if ax is axes[0]:
                            sorted_lines.append(f"{res.speed_rad_s[s]:g} rad/s {res.cases[c]}")
                    elif refined is not None:
                        x, y, extra = _with_refined(x, y, refined, s, c, m)
                        extra_angles.update(x[extra].tolist())
                    dots = dict(marker=".", markevery=extra) if refined is not None else {}
                    ax.plot(x, y, dashes[(r_i if len(runs) > 1 else c_n) % 4], color=f"C{r_i * len(s_idx) + s_n}",
                            label=", ".join(parts), **dots)
    for ax, m in zip(axes, mode_idx):
        ax.set_title(f"mode {first.modes[m]}")
        angle_axis(ax)
        ax.set_ylabel(FREQ_LABEL)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    names = sorted({first.cases[c] for c in pick_cases(first, cases, [default_case(first)])})
    n_lines = sum(len(pick_cases(r, cases, [default_case(r)])) * (len(speeds) if speeds else r.speed_rad_s.size)
                  for r in runs)
    if sorted_lines and len(set(sorted_lines)) >= n_lines:  # the archive could not tell any apart (docs/tracking.md)
        what = f"natural frequency vs crank angle ({', '.join(names)}; sorted modes: tracking ambiguous, MAC)"
    else:
        what = f"natural frequency vs crank angle ({', '.join(names)}; {order} modes"
        what += f", sorted for {', '.join(sorted(set(sorted_lines)))}: MAC ambiguous)" if sorted_lines else ")"
    if extra_angles:
        what += f"; dots: {len(extra_angles)} extra angles solved where the MAC was ambiguous"
    if len(runs) > 1:  # the meshes differ by design: name the scene, list the meshes
        meshes = ", ".join(elements_tag(r) for r in runs)
        suptitle(fig, f"{first.title}\n{what}; meshes: {meshes}")
    else:
        set_title(fig, first, what)
    return fig


def _with_refined(angles, values, refined: dict, s: int, c: int, m: int):
    """One tracked line (speed ``s``, case ``c``, mode ``m``) with its converged extra angles of
    ``/tracking/refined`` inserted in angle order: (angles, values, indices of the extra ones)."""
    ok = np.isin(refined.status[:, s, c], converged_codes())
    x = np.concatenate([angles, refined.angles_deg[ok]])
    y = np.concatenate([values, refined.tracked[ok, s, c, m]])
    order = np.argsort(x, kind="stable")
    extra = np.concatenate([np.zeros(len(angles), bool), np.ones(int(ok.sum()), bool)])[order]
    return x[order], y[order], np.flatnonzero(extra).tolist()


def param_speed(
    res: SweepResults,
    angle: float | None = None,
    cases: Sequence[str | int] | None = None,
    modes: Sequence[int] | None = None,
    order: str = "sorted",
) -> Figure:
    """Frequency parameter ω_i(case)/ω_i(structure) vs speed parameter α = Ω/ω_1(structure)
    at one crank angle, one curve per case (Figs 3.10-3.13; docs/theory.md §12).

    Needs case ``structure`` in the archive and, to be useful, many speeds. Defaults: θ = 10°
    if on the grid (else the first angle), every case, every mode, sorted modes.
    """
    if "structure" not in res.cases:
        raise ArchiveError("param-speed: the archive has no 'structure' case (the reference ω_i(structure))")
    a = pick_angle(res, angle)
    c_idx = pick_cases(res, cases, CASE_NAMES)
    mode_idx = pick_modes(res, modes)
    alpha = res.speed_parameter()[a]
    p = res.frequency_parameter(order)[a]
    fig, axes = mode_grid(len(mode_idx))
    for ax, m in zip(axes, mode_idx):
        for c in c_idx:
            ax.plot(alpha, p[:, c, m], marker="." if alpha.size < 15 else None,
                    label=case_label(res.cases[c]), **case_style(res.cases[c]))
        ax.set_title(f"mode {res.modes[m]}")
        ax.set_xlabel("speed parameter α = Ω / ω₁(structure) (–)")
        ax.set_ylabel("frequency parameter ω_i / ω_i(structure) (–)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    w1 = 2 * np.pi * res.structure_frequency("sorted")[a, 0]
    theta = res.crank_angle_deg[a]
    what = f"frequency parameter vs speed parameter, θ = {theta:g}° (ω₁(structure) = {w1:.1f} rad/s)"
    set_title(fig, res, what)
    return fig


def error_angle(
    res: SweepResults,
    speed: float | None = None,
    cases: Sequence[str | int] | None = None,
    modes: Sequence[int] | None = None,
    order: str = "matched",
) -> Figure:
    """Signed % error (ω_i(case) − ω_i(full))/ω_i(full) × 100 of the simplified cases over the
    crank cycle at one speed, one axes per mode (Figs 3.14-3.21; docs/theory.md §12).

    ``order="matched"`` (default): mode i of ``full`` is compared with the mode of each case
    whose shape it matches at the same point (MAC, :func:`tracking.match_cases`); where no clear
    match exists the curve has a gap and the sorted-order error is marked ×. ``"sorted"``
    compares the i-th lowest frequencies. Defaults: the highest speed, cases ``no_coriolis`` …
    ``no_pseudo_normal``, every mode.
    """
    if "full" not in res.cases:
        raise ArchiveError("error-angle: the archive has no 'full' case (the reference of the percentage error)")
    s = pick_speed(res, speed)
    c_idx = pick_cases(res, cases, SIMPLIFIED)
    mode_idx = pick_modes(res, modes)
    fig, axes = mode_grid(len(mode_idx))
    sorted_err = {c: res.percent_error(res.cases[c], "sorted" if order == "matched" else order)[:, s, :]
                  for c in c_idx}
    sig = read_signature(res.path, s, res.table_plane) if order == "matched" else None
    if order == "matched" and sig is None:
        order = "sorted (no eigenvectors archived for MAC matching)"
    err, unmatched = dict(sorted_err), {}
    if sig is not None:
        jf = res.case_index("full")
        f = res.frequency(order="sorted")[:, s]
        for c in c_idx:
            perm, clear = match_cases(sig[:, jf], sig[:, c])
            fc = np.take_along_axis(f[:, c], perm, axis=1)
            err[c] = np.where(clear, percent_error(fc, f[:, jf]), np.nan)
            unmatched[c] = ~clear & np.isfinite(sorted_err[c])
    n_flag = 0
    for ax, m in zip(axes, mode_idx):
        ax.axhline(0.0, color="0.5", lw=0.8, label="_zero")
        for c in c_idx:
            name = res.cases[c]
            ax.plot(res.crank_angle_deg, err[c][:, m], label=case_label(name), **case_style(name))
            if c in unmatched and unmatched[c][:, m].any():
                miss = unmatched[c][:, m]
                n_flag += int(miss.sum())
                ax.plot(res.crank_angle_deg[miss], sorted_err[c][miss, m], "x", ms=6, ls="none",
                        color=case_style(name).get("color", "k"), label=f"_nomatch {name}")
        ax.set_title(f"mode {res.modes[m]}")
        angle_axis(ax)
        ax.set_ylabel("error vs full (%)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    what = (f"percentage error in natural frequency vs crank angle, "
            f"{speed_label(res.speed_rad_s[s], res.speeds_in_rpm)}; {order} modes")
    if n_flag:
        what += f"\n× {n_flag} points with no MAC match to a full mode (sorted-order error shown there)"
    set_title(fig, res, what)
    return fig


def draw(results: SweepResults | Sequence[SweepResults], kind: str, *, cases=None, speeds=None,
         angles=None, modes=None, order=None, orders=None) -> Figure:
    """Draw ``kind`` with options as the CLI gives them (lists; a kind that takes one angle or
    speed rejects several). Only ``freq-angle`` accepts several archives."""
    runs = [results] if isinstance(results, SweepResults) else list(results)
    if kind != "freq-angle" and len(runs) > 1:
        raise ArchiveError(
            f"kind {kind}: takes one archive (got {len(runs)}); only freq-angle overlays several"
        )
    res = runs[0]
    if kind == "freq-angle":
        return freq_angle(runs if len(runs) > 1 else res, cases, speeds, modes, order or "tracked")
    if kind == "param-speed":
        return param_speed(res, only_one(angles, "angles"), cases, modes, order or "sorted")
    if kind == "error-angle":
        return error_angle(res, only_one(speeds, "speeds"), cases, modes, order or "matched")
    if kind == "stability":
        return stability(res, only_one(cases, "cases"))
    if kind == "campbell":
        return campbell(res, only_one(angles, "angles"), cases, modes, orders, order or "tracked")
    if kind == "bands":  # plots/bands.py (fkev margins --plot)
        from fkev_slepc.plots.bands import band_campbell

        along = order if order in ("tracked", "sorted") else None
        return band_campbell(res, only_one(cases, "cases"), modes, orders, along, only_one(speeds, "speeds"))
    if kind == "mode-shape":
        return mode_shape(res, only_one(angles, "angles"), only_one(speeds, "speeds"), cases, modes)
    raise ArchiveError(f"kind: unknown kind {kind!r} (known: {', '.join(KINDS)})")
