#!/usr/bin/env python3
"""Throughput of `fkev run` on 2 ranks against 1 rank, measured side by side.

    .venv/bin/python scripts/bench_mpi_scaling.py [--repeats 5] [--elements 6] [--solver dense]

The sweep is the Bahgat-Willmert grid (73 angles x 3 speeds x 6 cases = 1314 points) of
runs/bahgat-willmert-1976.toml, meshed with ``--elements`` per link. Runs alternate 1 rank,
2 ranks, 1 rank, ... (so slow phases of a shared machine hit both), each under
``mpiexec -n N`` with one BLAS thread per rank. Throughput is points / ``wall_time_s`` of the
archive (from the checked scene to the finished archive: model set-up, file creation,
solves, writes, tracking); the end-to-end command time (with interpreter start-up) is shown
too. The result is the ratio of the medians, with the median of the per-pair ratios and the
load average before and after. Exit 0 if the ratio reaches ``--target`` (1.8), else 1.
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

import h5py

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "runs" / "bahgat-willmert-1976.toml"


def one_run(n_ranks: int, out: Path, elements: int, solver: str) -> tuple[float, float, int]:
    """(archive wall_time_s, command wall time, points) of one sweep on ``n_ranks``."""
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    cmd = ["mpiexec", "-n", str(n_ranks), sys.executable, "-m", "fkev_slepc", "run", str(SCENE), "-o", str(out),
           "--elements", str(elements), "--solver", solver, "--quiet"]
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True, timeout=1800)
    wall = time.perf_counter() - t
    if r.returncode not in (0, 3):
        sys.exit(f"bench: {' '.join(cmd)} failed ({r.returncode}):\n{r.stderr}")
    with h5py.File(out, "r") as f:
        return float(f.attrs["wall_time_s"]), wall, int(f["status"].size)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5, help="pairs of runs (default 5)")
    ap.add_argument("--elements", type=int, default=6, help="elements per link (default 6)")
    ap.add_argument("--solver", default="dense", choices=("auto", "slepc", "dense"))
    ap.add_argument("--target", type=float, default=1.8)
    args = ap.parse_args()

    load0 = os.getloadavg()
    rows = {1: [], 2: []}
    with tempfile.TemporaryDirectory(prefix="fkev-bench-") as tmp:
        for rep in range(args.repeats):
            for n in (1, 2):
                sweep, cmd, points = one_run(n, Path(tmp) / f"r{n}.h5", args.elements, args.solver)
                rows[n].append((sweep, cmd))
                print(f"  repeat {rep + 1}: {n} rank(s): {points} points, sweep {sweep:6.2f} s "
                      f"({points / sweep:7.1f} points/s), command {cmd:6.2f} s", flush=True)
    load1 = os.getloadavg()
    med = {n: statistics.median(s for s, _ in rows[n]) for n in rows}
    med_cmd = {n: statistics.median(c for _, c in rows[n]) for n in rows}
    ratio = med[1] / med[2]
    pairs = statistics.median(a[0] / b[0] for a, b in zip(rows[1], rows[2]))
    print(f"sweep: {points} points, {args.elements} elements per link, solver {args.solver}, "
          f"{args.repeats} pairs, one BLAS thread per rank")
    print(f"median sweep time: 1 rank {med[1]:.2f} s ({points / med[1]:.1f} points/s), "
          f"2 ranks {med[2]:.2f} s ({points / med[2]:.1f} points/s)")
    print(f"throughput ratio 2 ranks / 1 rank: {ratio:.2f} (median of pair ratios {pairs:.2f}); "
          f"end-to-end command: {med_cmd[1] / med_cmd[2]:.2f}")
    print(f"load average before {load0[0]:.2f} {load0[1]:.2f}, after {load1[0]:.2f} {load1[1]:.2f} "
          f"on {os.cpu_count()} cores")
    ok = ratio >= args.target
    print(f"{'PASS' if ok else 'FAIL'}: target {args.target}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
