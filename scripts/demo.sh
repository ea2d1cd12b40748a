#!/usr/bin/env bash
# `make demo`: the Bahgat-Willmert sweep (73 crank angles x 3 speeds x 6 cases = 1314 points)
# on NP ranks into an HDF5 archive, then `fkev info` on it.
#
#   usage: scripts/demo.sh [VENV] [NP]        (defaults: .venv, 2 ranks)
#
# The archive is runs/out/bahgat-willmert-1976.h5 (fkev run's default: <scene dir>/out/<stem>.h5;
# git-ignored). Each call starts a new run (--force replaces the previous archive; fkev run refuses
# to without it); `fkev run ... --resume` would continue a killed one.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${1:-.venv}
NP=${2:-2}
FKEV="$VENV/bin/fkev"
SCENE=runs/bahgat-willmert-1976.toml
ARCHIVE=runs/out/bahgat-willmert-1976.h5
# OpenMPI refuses to run as root and to place more ranks than cores unless told; only for this script.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1

mkdir -p "$(dirname "$ARCHIVE")"  # fkev run -o never creates directories itself
echo "+ mpiexec -n $NP $FKEV run $SCENE -o $ARCHIVE --force"
rc=0
mpiexec -n "$NP" "$FKEV" run "$SCENE" -o "$ARCHIVE" --force || rc=$?
if [ "$rc" -eq 3 ]; then
    echo "demo: some points failed or did not converge (listed by fkev info below)"
elif [ "$rc" -ne 0 ]; then
    echo "demo: fkev run failed (exit $rc)" >&2
    exit "$rc"
fi

echo "+ $FKEV info $ARCHIVE"
"$FKEV" info "$ARCHIVE"

# --- figures: the plots helper appends figure generation from "$ARCHIVE" here ---
# The standard figure set, next to the archive as <archive stem>_<figure>.png (no mode shapes:
# those need `fkev run SCENE --mode-shapes`; `make figures` draws them from the speed-sweep scene).
STEM=${ARCHIVE%.h5}
demo_plot() { # demo_plot NAME fkev-plot-options...
    local name=$1
    shift
    "$FKEV" plot "$ARCHIVE" "$@" -o "${STEM}_$name.png" >/dev/null
    echo "  ${STEM}_$name.png"
}
echo "+ $FKEV plot $ARCHIVE --kind ... (standard figure set)"
demo_plot freq-angle --kind freq-angle
demo_plot error-angle-500 --kind error-angle --speed 500
demo_plot error-angle-1000 --kind error-angle --speed 1000
demo_plot param-speed-10deg --kind param-speed --angle 10
demo_plot campbell-10deg --kind campbell --angle 10
demo_plot stability --kind stability
# --- end of figures ---

echo
echo "demo: archive written to $(pwd)/$ARCHIVE"
echo "      open it with: $FKEV info $ARCHIVE | xarray.open_dataset('$ARCHIVE', engine='h5netcdf')"
