#!/usr/bin/env python
"""Floquet monodromy of one crank speed against the frozen sweep of the same angles.

Thesis size (the scene's mesh): the monodromy of one revolution at ``--speed`` and ``--case``
(solve.floquet_linkage.floquet_multipliers at ``--tol``: coefficient samples, trigonometric
interpolant, 6th-order symplectic Magnus with step doubling) is timed against the frozen sweep
of the same scene at that speed and case over 360 crank angles (sweep.runner.Sweep.solve_angle
for every angle: pieces, QEP, dense engine, selection and classification; no HDF5), the two
timed alternately, medians over ``--repeats``. The multiplier error is measured against a run at
``--tol``/1000 (matched multipliers), beside the run's own step-doubling estimate.

Large model (``--large-elements`` per link, 111 gives 999 DOFs; 0 skips it): the monodromy
reduced to ``--reduce`` co-rotating frozen modes at ``--basis-angles`` angles
(solve/floquet_reduce.py), its cost, and its truncation error: the largest change of a matched
multiplier of the lowest modes, and of max|μ|, against the basis of twice as many modes.
One BLAS thread.

    .venv/bin/python scripts/bench_floquet.py
    .venv/bin/python scripts/bench_floquet.py --repeats 1 --large-elements 0 --angles 36
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy: one BLAS thread, as one MPI rank has

import time  # noqa: E402

import numpy as np  # noqa: E402

import benchlib  # noqa: E402


def parse_args(argv=None):
    ap = benchlib.parser(__doc__, modes=4, repeats=3)
    ap.add_argument("--speed", type=float, default=500.0, help="crank speed, rad/s")
    ap.add_argument("--case", default="full")
    ap.add_argument("--angles", type=int, default=360, help="frozen sweep angles over a turn")
    ap.add_argument("--tol", type=float, default=1e-10, help="monodromy tolerance (relative error of Φ)")
    ap.add_argument("--large-elements", type=int, default=111)
    ap.add_argument("--reduce", type=int, default=4)
    ap.add_argument("--basis-angles", type=int, default=2)
    return benchlib.parse(ap, argv)[0]


def frozen_sweep(scene, model, speed, case, n_angles, modes):
    from fkev_slepc.archive.store import Grid
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.sweep.runner import Sweep, SweepOptions
    from fkev_slepc.sweep.tracking import tracking_dofs

    angles = np.arange(n_angles) * 360.0 / n_angles
    grid = Grid(angles, np.array([speed]), (case,), modes)
    opts = SweepOptions(modes, scene.analysis.imag_tol, scene.analysis.damping_tol, False,
                        tracking_dofs(model.n_free, len(angles), 1))
    sweep = Sweep(model, grid, DenseEngine(), None, opts, np.full(grid.shape, np.nan))
    todo = np.ones(grid.shape[1:], bool)

    def run():
        t0 = time.perf_counter()
        for ia in range(len(angles)):
            sweep.solve_angle(ia, todo)
        return time.perf_counter() - t0

    return run


def main(argv=None) -> None:
    args = parse_args(argv)
    from dataclasses import replace

    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene
    from fkev_slepc.solve.floquet import match_multipliers
    from fkev_slepc.solve.floquet_linkage import floquet_multipliers

    scene = load_scene(benchlib.ROOT / args.scene)
    model = Model(scene, cases=(args.case,))
    sweep = frozen_sweep(scene, model, args.speed, args.case, args.angles, args.modes)
    sweep()  # warm-up
    t_sweep, t_mono, res = [], [], None
    for _ in range(args.repeats):
        t_sweep.append(sweep())
        t0 = time.perf_counter()
        res = floquet_multipliers(model, args.speed, args.case, tol=args.tol)
        t_mono.append(time.perf_counter() - t0)
    ref = floquet_multipliers(model, args.speed, args.case, tol=args.tol / 1000)
    i, j = match_multipliers(res.multipliers, ref.multipliers)
    err = float(np.max(np.abs(res.multipliers[i] - ref.multipliers[j])))
    ts, tm = np.median(t_sweep), np.median(t_mono)
    print(f"{scene.title}: {model.n_free} DOFs, case {args.case}, {args.speed:g} rad/s, "
          f"{args.repeats} repeats, 1 BLAS thread")
    print(f"frozen sweep of {args.angles} angles: {ts:.3f} s (median)")
    print(f"monodromy: {tm:.3f} s (median), {res.monodromy.steps} Magnus steps, {res.samples} "
          f"coefficient samples (interpolation error {res.interp_error:.1e})")
    print(f"ratio monodromy / frozen sweep: {tm / ts:.2f}")
    print(f"max|mu| {res.max_abs:.12f}, max||mu|-1| {np.max(np.abs(np.abs(res.multipliers) - 1)):.1e}")
    print(f"multiplier error vs tol/1000 run: {err:.1e} (step-doubling estimate {res.error:.1e}; "
          f"reference {ref.monodromy.steps} steps)")
    if args.large_elements <= 0:
        return
    big = replace(scene, links=tuple(replace(lk, elements=args.large_elements) for lk in scene.links))
    bm = Model(big, cases=(args.case,))
    t0 = time.perf_counter()
    red = floquet_multipliers(bm, args.speed, args.case, tol=args.tol, reduce=args.reduce,
                              basis_angles=args.basis_angles, check_truncation=False)
    t_red = time.perf_counter() - t0
    t0 = time.perf_counter()
    ref2 = floquet_multipliers(bm, args.speed, args.case, tol=args.tol, reduce=2 * args.reduce,
                               basis_angles=args.basis_angles, check_truncation=False)
    t_ref2 = time.perf_counter() - t0
    low = np.argsort(np.abs(red.exponents.imag))
    i, j = match_multipliers(red.exponents[low] / abs(args.speed), ref2.exponents / abs(args.speed))
    trunc = float(np.max(np.abs(red.multipliers[low][i] - ref2.multipliers[j])))
    dfreq = np.abs(red.exponents[low][i].imag - ref2.exponents[j].imag) / np.abs(ref2.exponents[j].imag)
    print(f"large: {bm.n_free} DOFs reduced to {red.basis} co-rotating modes "
          f"({args.reduce} per angle at {args.basis_angles} angles): {t_red:.2f} s, "
          f"{red.monodromy.steps} steps, max|mu| {red.max_abs:.12f}")
    print(f"truncation error vs {ref2.basis} modes ({t_ref2:.2f} s): multipliers {trunc:.1e}, "
          f"max|mu| {abs(red.max_abs - ref2.max_abs):.1e}, Floquet frequencies {np.max(dfreq):.1e} relative")


if __name__ == "__main__":
    main()
