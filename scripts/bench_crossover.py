#!/usr/bin/env python
"""Dense QZ vs SLEPc: time per grid point against model size, side by side.

For each mesh (every link re-meshed with N elements) the points of one crank angle (all six
cases of Table 3.1 at one speed) are solved by both engines, alternating within every repeat
so that both see the same machine load; the table gives medians over the repeats of the mean
time per point. The SLEPc engine is created once per model and warmed up on the same points
(the sweep creates it once per run), and each point gets the |λ₁| hint a sweep would pass.
The crossover is the smallest model size from which SLEPc is faster at every larger size.

    .venv/bin/python scripts/bench_crossover.py
    .venv/bin/python scripts/bench_crossover.py --elements 1,2,4,8 --repeats 3
    .venv/bin/python scripts/bench_crossover.py -- -fkev_st_pc_factor_mat_solver_type mumps
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import benchlib


MODES, REPEATS = 4, 5


def parse_args(argv=None):
    ap = benchlib.parser(__doc__, modes=MODES, repeats=REPEATS)
    ap.add_argument("--elements", default="1,2,3,4,5,6,8,12,16,24", help="elements per link, comma-separated")
    ap.add_argument("--angle", type=float, default=100.0, help="crank angle, deg")
    ap.add_argument("--speed", type=float, default=500.0, help="crank speed, rad/s")
    return benchlib.parse(ap, argv)[0]


def time_points(engine, qeps, n_modes, hints) -> float:
    """Mean wall time per point of solving every QEP once (hints as a sweep would pass)."""
    t = time.perf_counter()
    for q, h in zip(qeps, hints):
        engine.solve(q, n_modes, hint=h)
    return (time.perf_counter() - t) / len(qeps)


def main(argv=None) -> int:
    args = parse_args(argv)
    from fkev_slepc.scene.cases import CASE_NAMES
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.solve.slepc import SlepcEngine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements

    base = load_scene(args.scene)
    print("command:", " ".join([Path(sys.executable).name, *sys.argv]))
    print(f"scene {args.scene}: θ = {args.angle:g}°, Ω = {args.speed:g} rad/s, six cases, {args.modes} modes, "
          f"median of {args.repeats} repeats (ms per point)")
    with SlepcEngine() as e:
        st = e.settings()
    print(f"SLEPc engine: pep_type {st['pep_type']}, st {st['st_type']}, LU {st['factor_solver_type']}, "
          f"pep_tol {st['pep_tol']:g}")
    print(f"{'el/link':>7} {'n_free':>7} {'dense':>10} {'slepc':>10} {'dense/slepc':>12} {'max rel diff':>13}")
    rows = []
    for n in (int(v) for v in args.elements.split(",")):
        model = Model(with_elements(base, n), cases=CASE_NAMES)
        pieces = model.pieces(np.radians(args.angle))
        qeps = [model.qep(pieces, args.speed, c) for c in CASE_NAMES]
        dense, slepc = DenseEngine(), SlepcEngine()
        ref = [postprocess(dense.solve(q, args.modes), args.modes) for q in qeps]
        hints = [float(np.abs(r.eigenvalue[0])) if np.isfinite(r.eigenvalue[0]) else None for r in ref]
        got = [postprocess(slepc.solve(q, args.modes, hint=h), args.modes) for q, h in zip(qeps, hints)]
        diff = max(np.nanmax(np.abs(g.frequency_hz / r.frequency_hz - 1)) for g, r in zip(got, ref))
        td, ts = [], []
        for _ in range(args.repeats):  # alternate: both engines see the same load
            td.append(time_points(dense, qeps, args.modes, hints))
            ts.append(time_points(slepc, qeps, args.modes, hints))
        slepc.close()
        d, s = np.median(td) * 1e3, np.median(ts) * 1e3
        rows.append((model.n_free, d, s))
        print(f"{n:>7} {model.n_free:>7} {d:>10.2f} {s:>10.2f} {d / s:>12.2f} {diff:>13.1e}", flush=True)
    n_free = np.array([r[0] for r in rows])
    faster = np.array([r[2] < r[1] for r in rows])
    later = [i for i in range(len(rows)) if faster[i:].all()]
    if later:
        i = later[0]
        lo = n_free[i - 1] if i > 0 else 0
        print(f"crossover: SLEPc is faster from n_free = {n_free[i]} on (dense faster at {lo})")
    else:
        print("crossover: not reached in this range")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
