"""The numbers of the Chapter-3 claims table of runs/README.md (docs/theory.md §16, C1-C12),
measured on the archives scripts/figures.sh writes (``runs/out/figures/``).

Errors are docs/theory.md §12's e = (ω_case − ω_full)/ω_full × 100 on sorted modes;
α = Ω/ω₁(structure).

    usage: python scripts/figures_claims.py ARCHIVE_DIR

The archives it reads: bw.h5, bw-refined.h5 (Bahgat-Willmert, 5 and 24 elements), bw-speed.h5
(θ = 10°, speeds from 0 to 1000 rad/s, mode shapes), bw-stability.h5 and tm-stability.h5
(case full), tm-3.h5, tm-6.h5, tm-9.h5, tm-36.h5 (Turcic-Midha structure, by element count).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from fkev_slepc import Status, open as open_archive
from fkev_slepc.archive.store import status_counts
from fkev_slepc.solve.modes import mac

HEADER = "| claim | our number (modes 1 / 2 / 3 / 4 unless stated) |\n|---|---|"


def pct(x) -> str:
    return " / ".join(f"{v:.2f}" for v in np.atleast_1d(x))


def outcome_counts(res) -> dict[str, int]:
    """Points of each outcome (``pending`` left out), by status name, in the table's order."""
    counts = status_counts(res.status)
    return {s.value: counts[s.value] for s in (Status.OK, Status.UNSTABLE, Status.DIVERGENT,
                                               Status.NOT_CONVERGED, Status.FAILED)}


def one_turn(angles_deg) -> np.ndarray:
    """Mask of the crank angles that are distinct positions: 360° is left out when 0° is also on
    the grid (the same position, the same frequencies up to round-off), so that where a cycle's
    maximum or minimum lies does not flip between 0° and 360° on round-off."""
    a = np.asarray(angles_deg, dtype=float)
    return ~(np.isclose(a, 360.0) & np.any(np.isclose(a, 0.0)))


def claims(out: Path) -> list[tuple[str, str]]:
    """(claim, text) rows of the claims table, from the archives in ``out``."""
    rows: list[tuple[str, str]] = []

    def row(claim, text):
        rows.append((claim, text))

    bw, ref, spd = (open_archive(out / n) for n in ("bw.h5", "bw-refined.h5", "bw-speed.h5"))
    tm = {n: open_archive(out / f"tm-{n}.h5") for n in (3, 6, 9, 36)}
    f, fr = bw.frequency(), ref.frequency()
    modes = bw.modes
    turn = one_turn(bw.crank_angle_deg)  # where-is-the-peak questions: each position once


    n5, n24 = sum(bw.elements_per_link()), sum(ref.elements_per_link())  # 5 and 24 in make figures
    full = bw.case_index("full")
    d = np.abs(f - fr) / fr * 100
    row("C1", f"{n5} vs {n24} elements, case full, whole cycle, 0-1000 rad/s: max Δf = {pct(np.nanmax(d[:, :, full], axis=(0, 1)))} %; "
        f"all six cases: max {np.nanmax(d):.2f} %")
    e5 = np.stack([bw.percent_error(c)[:, -1] for c in ("no_normal", "no_pseudo_normal")])
    e24 = np.stack([ref.percent_error(c)[:, -1] for c in ("no_normal", "no_pseudo_normal")])
    row("C1", f"errors e of no_normal / no_pseudo_normal at 1000 rad/s differ by at most "
        f"{np.nanmax(np.abs(e5[0] - e24[0])):.2f} / {np.nanmax(np.abs(e5[1] - e24[1])):.2f} percentage points ({n5} vs {n24} el)")
    f36 = tm[36].frequency()[:, 0, 0]
    for n in (3, 6, 9):
        dn = np.nanmax(np.abs(tm[n].frequency()[:, 0, 0] - f36) / f36 * 100, axis=0)
        row("C2", f"Turcic-Midha structure, {n} vs 36 elements, whole cycle: max Δf = {pct(dn)} % (modes 1 / 2 / 3)")
    p = spd.frequency_parameter()[0]
    alpha = spd.speed_parameter()[0]
    s_idx = spd.case_index("structure")
    row("C3", f"structure: max |ω_i/ω_i(structure) − 1| over {alpha.size} speeds = {np.nanmax(np.abs(p[:, s_idx] - 1)):.1e}")
    low = alpha < 0.1
    e_low = {c: np.nanmax(np.abs(spd.percent_error(c)[0][low]), axis=0) for c in ("no_coriolis", "no_tangential", "no_normal", "no_pseudo_normal")}
    row("C4", f"θ = 10°, α < 0.1 (Ω ≤ {spd.speed_rad_s[low].max():g} rad/s), max |e|: "
        + "; ".join(f"{c} {pct(v)} %" for c, v in e_low.items()))
    top = int(np.argmax(spd.speed_rad_s))
    for c in ("no_coriolis", "no_tangential"):
        row("C5", f"{c}, θ = 10°, α = {alpha[top]:.3f}: e = {pct(spd.percent_error(c)[0, top])} %")
    en = spd.percent_error("no_normal")[0, top, 0]
    f1 = spd.frequency()[0, top, :, 0]
    w0 = spd.structure_frequency()[0, 0]
    gap = (f1[spd.case_index("no_normal")] - f1[spd.case_index("full")]) / w0 * 100
    row("C6", f"no_normal, mode 1, θ = 10°, α = {alpha[top]:.3f}: e₁ = {en:.2f} % (§12); gap of the frequency-parameter "
        f"curves (ω₁(no_normal) − ω₁(full))/ω₁(structure) = {gap:.2f} % (§14 item 14); thesis ≈ 8.5 %")
    mid = int(np.argmin(np.abs(spd.speed_rad_s - 500)))
    row("C7", "θ = 10°, ω₁/ω₁(structure) at α = "
        f"{alpha[mid]:.2f} / {alpha[top]:.2f}: full {p[mid, spd.case_index('full'), 0]:.3f} / {p[top, spd.case_index('full'), 0]:.3f}; "
        f"no_pseudo_normal {p[mid, spd.case_index('no_pseudo_normal'), 0]:.3f} / {p[top, spd.case_index('no_pseudo_normal'), 0]:.3f}")
    for s, om in enumerate(bw.speed_rad_s):
        if om == 0:
            continue
        e2 = np.nanmax(np.abs(bw.percent_error("no_coriolis")[:, s]), axis=0)
        e3 = np.nanmax(np.abs(bw.percent_error("no_tangential")[:, s]), axis=0)
        row("C8", f"Ω = {om:g} rad/s, whole cycle: max |e| no_coriolis {pct(e2)} %; no_tangential {pct(e3)} %")
        for c in ("no_normal", "no_pseudo_normal"):
            e = np.abs(bw.percent_error(c)[turn, s])
            at = bw.crank_angle_deg[turn][np.nanargmax(e, axis=0)]
            row("C8", f"Ω = {om:g} rad/s, {c}: max |e| {pct(np.nanmax(e, axis=0))} % at θ = {' / '.join(f'{a:g}' for a in at)}°")
    s1000 = bw.speed_index(1000)
    e5 = bw.percent_error("no_pseudo_normal")[turn, s1000]
    a, m = np.unravel_index(np.nanargmax(np.abs(e5)), e5.shape)
    row("C9", f"no_pseudo_normal at 1000 rad/s, whole cycle: max |e| = {abs(e5[a, m]):.1f} % (mode {modes[m]}, θ = {bw.crank_angle_deg[turn][a]:g}°, e = {e5[a, m]:+.1f} %); thesis 38 %")
    for s, om in enumerate(bw.speed_rad_s):
        if om == 0:
            continue
        en, ep = np.abs(bw.percent_error("no_normal")[:, s]), np.abs(bw.percent_error("no_pseudo_normal")[:, s])
        ok = np.isfinite(en) & np.isfinite(ep)
        row("C10", f"Ω = {om:g} rad/s: |e(no_normal)| < |e(no_pseudo_normal)| at {np.mean(en[ok] < ep[ok]) * 100:.0f} % of (angle, mode) points")
    a10, s1 = spd.angle_index(10), spd.speed_index(1000)
    shape = {c: spd.mode_shape(a10, s1, spd.case_index(c)) for c in spd.cases}
    for against in ("full", "structure"):
        macs = {c: np.diag(mac(shape[against], shape[c])) for c in spd.cases if c != against}
        row("C11", f"θ = 10°, 1000 rad/s, MAC (all free DOFs) with the {against} mode shapes: "
            + "; ".join(f"{c} {' / '.join(f'{v:.3f}' for v in macs[c])}" for c in macs))
    for s, om in enumerate(bw.speed_rad_s):
        at = bw.crank_angle_deg[turn][np.nanargmin(f[turn, s, full], axis=0)]
        row("C12", f"full, Ω = {om:g} rad/s: minimum of each mode at θ = {' / '.join(f'{a:g}' for a in at)}°")
    st = open_archive(out / "bw-stability.h5")
    counts = outcome_counts(st)
    row("stability", f"Bahgat-Willmert full, {st.crank_angle_deg.size} angles × {st.speed_rad_s.size} speeds: {counts}; max Re λ = {np.nanmax(st.max_real):.3g} 1/s")
    st = open_archive(out / "tm-stability.h5")
    counts = outcome_counts(st)
    divergent = st.status_names == Status.DIVERGENT
    div = st.speed_rad_s[np.argmax(np.any(divergent, axis=(0, 2)))] if divergent.any() else None
    row("stability", f"Turcic-Midha full, {st.crank_angle_deg.size} angles × {st.speed_rad_s.size} speeds: {counts}; first divergent speed {div} rad/s")
    return rows


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    print("\n" + HEADER)
    for claim, text in claims(Path(argv[0])):
        print(f"| {claim} | {text} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
