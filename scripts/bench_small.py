#!/usr/bin/env python
"""Small models: per-point cost of a sweep against a bare LAPACK QZ of the same pencils.

The sweep side is the per-point loop of ``fkev run`` (``sweep.runner.Sweep.solve_angle`` for
every crank angle: operator pieces, the QEP of every (speed, case), the dense engine with the
eigenvectors tracking needs, selection and classification), without HDF5 writing. The bare
side is ``scipy.linalg.eig(A, B, right=False)`` (LAPACK ggev, eigenvalues only) of the
companion pencil A = [[0, I], [-M, -C]], B = [[I, 0], [0, K]] of every grid point, built
beforehand (not timed); the same with right eigenvectors is shown for reference. They are
timed alternately angle by angle (same machine load); medians over the repeats, per grid
point (angle x speed x case). One BLAS thread.

    .venv/bin/python scripts/bench_small.py
    .venv/bin/python scripts/bench_small.py --elements 3 --repeats 9
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy: one BLAS thread, as one MPI rank has

import time  # noqa: E402

import numpy as np  # noqa: E402
import scipy.linalg as la  # noqa: E402

import benchlib  # noqa: E402

MODES, REPEATS = 4, 7


def parse_args(argv=None):
    ap = benchlib.parser(__doc__, modes=MODES, repeats=REPEATS)
    ap.add_argument("--elements", type=int, help="elements per link (default: the scene's mesh)")
    ap.add_argument("--angles", default="0:350:10", help="crank angles START:STOP:STEP, deg")
    return benchlib.parse(ap, argv)[0]


def setup(args):
    from fkev_slepc.archive.store import Grid
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.sweep.runner import Sweep, SweepOptions
    from fkev_slepc.sweep.tracking import tracking_dofs

    scene = load_scene(benchlib.ROOT / args.scene)
    if args.elements:
        scene = with_elements(scene, args.elements)
    start, stop, step = (float(v) for v in args.angles.split(":"))
    angles = np.arange(start, stop + step / 2, step)
    grid = Grid(angles, np.asarray(scene.driver.speeds, float), tuple(scene.analysis.cases), args.modes)
    model = Model(scene, cases=grid.cases)
    opts = SweepOptions(args.modes, scene.analysis.imag_tol, scene.analysis.damping_tol, False,
                        tracking_dofs(model.n_free, len(angles), len(grid.speeds)))
    sweep = Sweep(model, grid, DenseEngine(), None, opts, np.full(grid.shape, np.nan))
    return scene, grid, model, sweep


def pencils(grid, model):
    """Companion pencils (A, B) of every grid point, per angle (the structure once per speed too)."""
    out = []
    for a in grid.angles_deg:
        p = model.pieces(np.radians(a))
        here = []
        for speed in grid.speeds:
            for case in grid.cases:
                q = model.qep(p, float(speed), case)
                n = q.n
                M, K = q.mass.toarray(), q.stiffness.toarray()
                C = q.damping.toarray() if q.damping is not None else np.zeros((n, n))
                Z, I = np.zeros((n, n)), np.eye(n)
                here.append((np.block([[Z, I], [-M, -C]]), np.block([[I, Z], [Z, K]])))
        out.append(here)
    return out


def one_pass(sweep, grid, pairs) -> np.ndarray:
    """Seconds per grid point of (sweep, bare QZ, QZ with eigenvectors), timed angle by angle
    alternately, so that both see the same machine load."""
    todo = np.ones(grid.shape[1:], bool)
    t = np.zeros(3)
    clock = time.perf_counter
    for ia, here in enumerate(pairs):
        t0 = clock()
        sweep.solve_angle(ia, todo)
        t1 = clock()
        for A, B in here:
            la.eig(A, B, right=False)
        t2 = clock()
        for A, B in here:
            la.eig(A, B)
        t += (t1 - t0, t2 - t1, clock() - t2)
    return t / grid.n_points


def main(argv=None) -> None:
    args = parse_args(argv)
    scene, grid, model, sweep = setup(args)
    pairs = pencils(grid, model)
    one_pass(sweep, grid, pairs)  # warm-up
    t = np.array([one_pass(sweep, grid, pairs) for _ in range(args.repeats)]) * 1e3
    med = np.median(t, axis=0)
    ratio = med[0] / med[1]
    print(f"{scene.title}: {model.n_free} DOFs, {grid.n_points} points "
          f"({len(grid.angles_deg)} angles x {len(grid.speeds)} speeds x {len(grid.cases)} cases), "
          f"{args.modes} modes, {args.repeats} repeats, 1 BLAS thread")
    print(f"per point (median): sweep {med[0]:.3f} ms, bare QZ {med[1]:.3f} ms "
          f"(with eigenvectors {med[2]:.3f} ms)")
    print(f"ratio sweep / bare QZ: {ratio:.2f} (median of per-repeat ratios {np.median(t[:, 0] / t[:, 1]):.2f}); "
          f"vs QZ with eigenvectors: {med[0] / med[2]:.2f}")


if __name__ == "__main__":
    main()
