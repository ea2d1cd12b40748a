#!/usr/bin/env bash
# `make figures`: regenerate the committed figures (runs/figures/*.png) from archives this script
# produces with `fkev run` on the scenes in runs/, then print the numbers of the Chapter-3
# claims table of runs/README.md (docs/theory.md §16, C1-C12) from the same archives.
#
#   usage: scripts/figures.sh [VENV] [NP]      (defaults: .venv, 1 rank; NP=2 runs under mpiexec)
#
# Archives go to runs/out/figures/ (git-ignored); a few minutes on one core.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${1:-.venv}
NP=${2:-1}
FKEV="$VENV/bin/fkev"
PY="$VENV/bin/python"
OUT=runs/out/figures
FIG=runs/figures
DPI=${FKEV_FIGURE_DPI:-100}
mkdir -p "$OUT" "$FIG"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1

sweep() {  # sweep OUT SCENE [fkev run options]: exit 3 (some points not converged) is reported, not fatal
    local out=$1 scene=$2
    shift 2
    local cmd=("$FKEV" run "$scene" -o "$out" --quiet "$@")
    [ "$NP" -gt 1 ] && cmd=(mpiexec -n "$NP" "${cmd[@]}")
    echo "+ ${cmd[*]}"
    local rc=0
    "${cmd[@]}" || rc=$?
    if [ "$rc" -eq 3 ]; then
        echo "  (some points did not converge; see: $FKEV info $out)"
    elif [ "$rc" -ne 0 ]; then
        echo "fkev run failed with exit code $rc" >&2
        exit "$rc"
    fi
}

plot() {  # plot FILE ARCHIVE... [fkev plot options]
    local file=$1
    shift
    echo "+ fkev plot $* -o $FIG/$file"
    "$FKEV" plot "$@" --dpi "$DPI" -o "$FIG/$file" >/dev/null
}

speeds() { seq -s, "$1" "$2" "$3"; }  # speeds START STEP STOP -> a,b,c

BW=runs/bahgat-willmert-1976.toml
TM=runs/turcic-midha-1984.toml

# --- archives -------------------------------------------------------------------------------
sweep "$OUT/bw.h5" "$BW"                                   # 73 angles x 0/500/1000 rad/s x 6 cases
sweep "$OUT/bw-refined.h5" "$BW" --elements 8              # C1: 24 elements instead of 5
sweep "$OUT/bw-speed.h5" runs/bahgat-willmert-speed-sweep.toml --mode-shapes   # θ = 10°, 41 speeds
sweep "$OUT/bw-stability.h5" "$BW" --angles 0:360:10 --speeds "$(speeds 0 50 1000)" --cases full
for n in 1 2 3 12; do                                      # Turcic-Midha 3, 6, 9 and 36 elements
    sweep "$OUT/tm-$((3 * n)).h5" "$TM" --elements "$n"
done
sweep "$OUT/tm-stability.h5" "$TM" --angles 0:360:10 --speeds "$(speeds 0 10 200)" --cases full

# --- figures (thesis figure numbers in runs/README.md) --------------------------------------
plot bw-freq-angle.png "$OUT/bw.h5" --kind freq-angle --order sorted      # mode i = i-th lowest, as the thesis
plot bw-freq-angle-tracked.png "$OUT/bw.h5" --kind freq-angle --order tracked
plot bw-error-angle-500.png "$OUT/bw.h5" --kind error-angle --speed 500
plot bw-error-angle-1000.png "$OUT/bw.h5" --kind error-angle --speed 1000
plot bw-param-speed-10deg.png "$OUT/bw-speed.h5" --kind param-speed --angle 10
plot bw-mode-shapes-10deg-1000.png "$OUT/bw-speed.h5" --kind mode-shape --angle 10 --speed 1000
plot bw-campbell-10deg.png "$OUT/bw-speed.h5" --kind campbell --angle 10
plot bw-stability-full.png "$OUT/bw-stability.h5" --kind stability --case full
plot tm-freq-angle-3-6-9.png "$OUT/tm-3.h5" "$OUT/tm-6.h5" "$OUT/tm-9.h5" --kind freq-angle --order sorted
plot tm-stability-full.png "$OUT/tm-stability.h5" --kind stability --case full

# --- the numbers of the claims table -------------------------------------------------------
"$PY" - "$OUT" <<'EOF'
"""Chapter-3 claims (docs/theory.md §16) measured on the archives above. Errors are docs/theory.md
§12's e = (ω_case − ω_full)/ω_full × 100 on sorted modes; α = Ω/ω₁(structure)."""
import sys
from pathlib import Path

import numpy as np

from fkev_slepc.solve.modes import mac
from fkev_slepc.archive.reader import load

out = Path(sys.argv[1])
bw, ref, spd = load(out / "bw.h5"), load(out / "bw-refined.h5"), load(out / "bw-speed.h5")
tm = {n: load(out / f"tm-{n}.h5") for n in (3, 6, 9, 36)}
f, fr = bw.frequency(), ref.frequency()
modes = bw.modes


def pct(x):
    return " / ".join(f"{v:.2f}" for v in np.atleast_1d(x))


def row(claim, text):
    print(f"| {claim} | {text} |")


print("\n| claim | our number (modes 1 / 2 / 3 / 4 unless stated) |\n|---|---|")
full = bw.case_index("full")
d = np.abs(f - fr) / fr * 100
row("C1", f"5 vs 24 elements, case full, whole cycle, 0-1000 rad/s: max Δf = {pct(np.nanmax(d[:, :, full], axis=(0, 1)))} %; "
    f"all six cases: max {np.nanmax(d):.2f} %")
e5 = np.stack([bw.percent_error(c)[:, -1] for c in ("no_normal", "no_pseudo_normal")])
e24 = np.stack([ref.percent_error(c)[:, -1] for c in ("no_normal", "no_pseudo_normal")])
row("C1", f"errors e of no_normal / no_pseudo_normal at 1000 rad/s differ by at most "
    f"{np.nanmax(np.abs(e5[0] - e24[0])):.2f} / {np.nanmax(np.abs(e5[1] - e24[1])):.2f} percentage points (5 vs 24 el)")
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
        e = np.abs(bw.percent_error(c)[:, s])
        at = bw.crank_angle_deg[np.nanargmax(e, axis=0)]
        row("C8", f"Ω = {om:g} rad/s, {c}: max |e| {pct(np.nanmax(e, axis=0))} % at θ = {' / '.join(f'{a:g}' for a in at)}°")
s1000 = bw.speed_index(1000)
e5 = bw.percent_error("no_pseudo_normal")[:, s1000]
a, m = np.unravel_index(np.nanargmax(np.abs(e5)), e5.shape)
row("C9", f"no_pseudo_normal at 1000 rad/s, whole cycle: max |e| = {abs(e5[a, m]):.1f} % (mode {modes[m]}, θ = {bw.crank_angle_deg[a]:g}°, e = {e5[a, m]:+.1f} %); thesis 38 %")
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
    at = bw.crank_angle_deg[np.nanargmin(f[:, s, full], axis=0)]
    row("C12", f"full, Ω = {om:g} rad/s: minimum of each mode at θ = {' / '.join(f'{a:g}' for a in at)}°")
st = load(out / "bw-stability.h5")
counts = {n: int(np.sum(st.status == v)) for n, v in (("ok", 1), ("unstable", 3), ("divergent", 4), ("not converged", 2), ("failed", 5))}
row("stability", f"Bahgat-Willmert full, 37 angles × 21 speeds: {counts}; max Re λ = {np.nanmax(st.max_real):.3g} 1/s")
st = load(out / "tm-stability.h5")
counts = {n: int(np.sum(st.status == v)) for n, v in (("ok", 1), ("unstable", 3), ("divergent", 4), ("not converged", 2), ("failed", 5))}
div = st.speed_rad_s[np.argmax(np.any(st.status == 4, axis=0))] if np.any(st.status == 4) else None
row("stability", f"Turcic-Midha full, 37 angles × 21 speeds: {counts}; first divergent speed {div} rad/s")
EOF
ls -la "$FIG"
