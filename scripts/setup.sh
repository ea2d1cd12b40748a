#!/usr/bin/env bash
# Idempotent set-up: Debian packages (PETSc/SLEPc/MPI/HDF5 stack) and a venv that sees them.
# Usage: scripts/setup.sh [VENV_DIR]   (default .venv). Re-running does only what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${1:-.venv}
PY=/usr/bin/python3   # Debian's interpreter: the only one that can load Debian's petsc4py

DEB_PACKAGES=(
  python3-venv python3-pip python3-setuptools python3-numpy python3-scipy
  python3-petsc4py python3-slepc4py petsc-dev slepc-dev
  python3-mpi4py python3-h5py-mpi openmpi-bin
  python3-matplotlib python3-xarray python3-h5netcdf python3-tqdm python3-pytest
  python3-mpmath
)

missing=()
for p in "${DEB_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
fi

if [ ! -x "$VENV/bin/python" ]; then
  echo "setup: creating $VENV (system site packages visible)"
  "$PY" -m venv --system-site-packages "$VENV"
fi
stamp="$VENV/.fkev-installed"
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  # --no-deps --no-build-isolation: dependencies come from Debian; never let pip pull numpy 2.
  "$VENV/bin/python" -m pip install -q --no-deps --no-build-isolation -e .
  touch "$stamp"
fi
"$VENV/bin/python" - <<'PY'
import numpy, petsc4py, slepc4py, mpi4py, h5py, scipy
from petsc4py import PETSc
from slepc4py import SLEPc
assert numpy.__version__.startswith("1."), f"numpy {numpy.__version__}: petsc4py needs Debian's numpy 1.x"
print(f"setup: ok (numpy {numpy.__version__}, PETSc {'.'.join(map(str, PETSc.Sys.getVersion()))}, "
      f"SLEPc {'.'.join(map(str, SLEPc.Sys.getVersion()))}, h5py {h5py.__version__} mpi={h5py.get_config().mpi})")
PY
