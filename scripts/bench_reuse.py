#!/usr/bin/env python
"""Reusing the PETSc/SLEPc objects across 100 consecutive crank angles vs re-creating them.

*reuse*: one ``SlepcEngine`` for all angles, as the sweep does: the PETSc matrices are created
once and their values overwritten, the PEP/ST/KSP/PC and the symbolic factorization are kept,
``setFromOptions`` ran once. *re-create*: a new engine (matrices, PEP, options, symbolic and
numeric factorization) at every angle. Both solve the same QEPs (assembled beforehand, so only
the solver side is timed) with the same hints (|λ₁| of the previous angle); the two modes
alternate within every repeat and the table gives medians over repeats of the total time.

    .venv/bin/python scripts/bench_reuse.py
    .venv/bin/python scripts/bench_reuse.py --elements 5,50,500 --repeats 3
    .venv/bin/python scripts/bench_reuse.py -- -fkev_st_pc_factor_mat_solver_type mumps
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import benchlib


MODES, REPEATS = 4, 3


def parse_args(argv=None):
    ap = benchlib.parser(__doc__, modes=MODES, repeats=REPEATS)
    ap.add_argument("--elements", default="5,50,500", help="elements per link, comma-separated")
    ap.add_argument("--angles", type=int, default=100, help="number of consecutive crank angles (1° apart)")
    ap.add_argument("--speed", type=float, default=500.0)
    ap.add_argument("--case", default="full")
    return benchlib.parse(ap, argv)[0]


def symbolic_count() -> int:
    """Symbolic LU factorizations so far (PETSc log: MUMPS/UMFPACK log MatLUFactorSym, others MatLUFactor)."""
    from fkev_slepc.solve.petsc_backend import PETSc

    return sum(PETSc.Log.Event(n).getPerfInfo()["count"] for n in ("MatLUFactorSym", "MatLUFactor"))


def run(qeps, hints, n_modes, reuse: bool):
    """Solve every QEP; returns (seconds, frequencies of the last point)."""
    from fkev_slepc.solve.slepc import SlepcEngine
    from fkev_slepc.solve.modes import postprocess

    t = time.perf_counter()
    engine = SlepcEngine() if reuse else None
    for q, h in zip(qeps, hints):
        e = engine or SlepcEngine()
        sol = e.solve(q, n_modes, hint=h)
        if not reuse:
            e.close()
    if engine is not None:
        engine.close()
    return time.perf_counter() - t, postprocess(sol, n_modes).frequency_hz


def main(argv=None) -> int:
    args = parse_args(argv)
    from fkev_slepc.solve.slepc import SlepcEngine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements

    from fkev_slepc.solve.petsc_backend import PETSc

    PETSc.Log.begin()
    base = load_scene(args.scene)
    print("command:", " ".join([Path(sys.executable).name, *sys.argv]))
    print(f"{args.scene}: {args.angles} consecutive crank angles, Ω = {args.speed:g} rad/s, case {args.case}, "
          f"{args.modes} modes; median of {args.repeats} repeats")
    with SlepcEngine() as e:
        st = e.settings()
    print(f"SLEPc engine: pep_type {st['pep_type']}, st {st['st_type']}, LU {st['factor_solver_type']}, "
          f"pep_tol {st['pep_tol']:g}")
    print(f"{'el/link':>7} {'n_free':>7} {'re-create [s]':>14} {'reuse [s]':>10} {'ms/pt reuse':>12} {'speed-up':>9}"
          f" {'symbolic LU (re-create/reuse)':>30}")
    for n in (int(v) for v in args.elements.split(",")):
        model = Model(with_elements(base, n), cases=(args.case,))
        qeps = [model.qep(model.pieces(np.radians(10.0 + k)), args.speed, args.case) for k in range(args.angles)]
        with SlepcEngine() as e:  # hints as the sweep would pass them: |λ₁| of the previous angle
            lam1 = [abs(postprocess(e.solve(q, args.modes), args.modes).eigenvalue[0]) for q in qeps]
        hints = [None, *lam1[:-1]]
        t_new, t_reuse = [], []
        for _ in range(args.repeats):
            s0 = symbolic_count()
            a, fa = run(qeps, hints, args.modes, reuse=False)
            s1 = symbolic_count()
            b, fb = run(qeps, hints, args.modes, reuse=True)
            sym = (s1 - s0, symbolic_count() - s1)
            assert np.allclose(fa, fb, rtol=1e-9), (fa, fb)  # same answers both ways
            t_new.append(a)
            t_reuse.append(b)
        a, b = np.median(t_new), np.median(t_reuse)
        print(f"{n:>7} {model.n_free:>7} {a:>14.3f} {b:>10.3f} {1e3 * b / args.angles:>12.2f} {a / b:>9.2f}"
              f" {f'{sym[0]} / {sym[1]}':>30}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
