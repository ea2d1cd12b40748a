"""BLAS threads per rank: a ``fkev run`` with the default pin (one thread) against the BLAS
library's own default (``FKEV_BLAS_THREADS=default``), alternated, median of repeats.

    python scripts/bench_blas_threads.py [--repeats 3] [--np 1]

The sweep: Bahgat-Willmert, 37 angles x 7 speeds x 3 cases = 777 points (docs/engine.md,
"BLAS threads"). Wall time of the whole command (the machine is shared: run it when quiet).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SWEEP = ["run", str(ROOT / "runs/bahgat-willmert-1976.toml"), "--angles", "0:360:10",
         "--speeds", "0,250,500,750,1000,1250,1500", "--cases", "structure,full,no_pseudo_normal", "-q", "--force"]


def timed(threads: str, out: Path, np_: int) -> float:
    env = {**os.environ, "FKEV_BLAS_THREADS": threads, "PYTHONPATH": str(ROOT),
           "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS"):
        env.pop(v, None)
    cmd = [sys.executable, "-m", "fkev_slepc", *SWEEP, "-o", str(out)] + (["--np", str(np_)] if np_ > 1 else [])
    t0 = time.perf_counter()
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if r.returncode not in (0, 3):
        raise SystemExit(f"fkev run failed ({r.returncode}): {r.stderr[-2000:]}")
    return dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--np", type=int, default=1, help="MPI ranks (fkev run --np)")
    args = ap.parse_args()
    times = {"1": [], "default": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeats):
            for threads in times:  # alternated: both see the same machine load
                times[threads].append(timed(threads, Path(tmp) / "bench.h5", args.np))
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"777-point fkev run, {args.np} rank(s), {os.cpu_count()} CPUs, median of {args.repeats}:")
    for k, v in times.items():
        print(f"  FKEV_BLAS_THREADS={k:<8} {med[k]:6.2f} s   (runs: {', '.join(f'{t:.2f}' for t in v)})")
    print(f"  ratio default/pinned: {med['default'] / med['1']:.2f}")


if __name__ == "__main__":
    main()
