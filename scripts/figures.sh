#!/usr/bin/env bash
# `make figures`: regenerate the committed figures (runs/figures/*.png) from archives this script
# produces with `fkev run` on the scenes in runs/, then print the numbers of the Chapter-3
# claims table of runs/README.md (docs/theory.md §16, C1-C12) from the same archives
# (scripts/figures_claims.py).
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
    local cmd=("$FKEV" run "$scene" -o "$out" --force --quiet "$@")  # --force: each call starts afresh
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
# the same with Rayleigh structural damping, ζ ≈ 1 % at modes 1 and 4 (docs/stability.md)
{ cat "$BW"; printf '\n[damping]\nmass_proportional_1_s = 40.0\nstiffness_proportional_s = 1.0e-6\n'; } > "$OUT/bw-damped.toml"
sweep "$OUT/bw-damped-stability.h5" "$OUT/bw-damped.toml" --angles 0:360:10 --speeds "$(speeds 0 50 1000)" --cases full
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
plot bw-stability-full-damped.png "$OUT/bw-damped-stability.h5" --kind stability --case full
plot tm-freq-angle-3-6-9.png "$OUT/tm-3.h5" "$OUT/tm-6.h5" "$OUT/tm-9.h5" --kind freq-angle --order sorted
plot tm-stability-full.png "$OUT/tm-stability.h5" --kind stability --case full

# --- the numbers of the claims table -------------------------------------------------------
"$PY" scripts/figures_claims.py "$OUT"
ls -la "$FIG"
