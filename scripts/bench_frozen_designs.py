#!/usr/bin/env python
"""Two designs for right pairs on fine meshes, one point side by side (docs/engine.md, "Right pairs at any mesh").

* ``projection`` (the engine's, solve/refine.py): TOAR on the assembled matrices, then Rayleigh-
  Ritz with the accurate operator (K_s from element strains) on TOAR's vectors, enlarged by the
  corrections K⁻¹P(λ)x with the factorization TOAR's shift-and-invert already holds.
* ``accurate ST``: TOAR whose shift-and-invert applies the accurate K itself -- a shell matrix
  (K_s from element strains + K_rest), its KSP GMRES (or Richardson) preconditioned by the LU of
  the assembled K. Its pairs are not judged here (the projection's are, by its corrections).

Printed: CPU seconds of this process (the machine is shared: less noisy than wall time), the
accurate-operator applications or K solves, and f₁…f₄ of each.

    PYTHONPATH=$PWD .venv/bin/python scripts/bench_frozen_designs.py --elements 2000
    PYTHONPATH=$PWD .venv/bin/python scripts/bench_frozen_designs.py --elements 5600 --ksp richardson
"""

from __future__ import annotations

import time

import numpy as np

import benchlib


def parse_args(argv=None):
    ap = benchlib.parser(__doc__, modes=4, repeats=3)
    ap.add_argument("--elements", type=int, default=2000, help="elements on every link")
    ap.add_argument("--angle", type=float, default=0.0, help="crank angle, deg")
    ap.add_argument("--speed", type=float, default=500.0, help="crank speed, rad/s")
    ap.add_argument("--ksp", default="gmres", help="the accurate ST's KSP type (gmres, richardson)")
    ap.add_argument("--rtol", type=float, default=1e-12, help="the accurate ST's KSP relative tolerance")
    return benchlib.parse(ap, argv)


def accurate_st(q, n_modes: int, ksp_type: str, rtol: float, alpha: float):
    """TOAR + sinvert on [K_accurate (shell), C, M] (balanced); returns (f, applies)."""
    from fkev_slepc.solve.dense import balanced
    from fkev_slepc.solve.petsc_backend import PETSc, PetscOperators
    from fkev_slepc.solve.slepc import SLEPc

    qb, d = balanced(q)
    ops = PetscOperators(qb)
    calls = [0]

    class Accurate:
        def mult(self, mat, x, y):
            calls[0] += 1
            v = d * x.getArray(readonly=True)
            y.setArray(d * (q.staged.apply(v)[:, 0] + q.stiffness_rest @ v))

    shell = PETSc.Mat().createPython([q.n, q.n], Accurate(), comm=PETSc.COMM_SELF)
    shell.setUp()
    pep = SLEPc.PEP().create(PETSc.COMM_SELF)
    pep.setOperators([shell, ops.C, ops.M])
    pep.setType(SLEPc.PEP.Type.TOAR)
    pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
    st = pep.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.setPreconditionerMat(ops.K)
    ksp = st.getKSP()
    ksp.setType(ksp_type)
    ksp.setTolerances(rtol=rtol, atol=0.0, max_it=500)
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("umfpack")
    benchlib.bare_toar_settings(pep, n_modes, alpha, SLEPc)
    pep.solve()
    lam = np.array([pep.getEigenpair(i) for i in range(pep.getConverged())])
    for obj in (pep, shell):
        obj.destroy()
    ops.destroy()
    return np.sort(lam[lam.imag > 0].imag)[:n_modes] / (2 * np.pi), calls[0]


def main(argv=None) -> int:
    args, _ = parse_args(argv)
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.slepc import SlepcEngine

    model = Model(with_elements(load_scene(args.scene), args.elements), cases=("full",))
    q = model.qep(model.pieces(np.radians(args.angle)), args.speed, "full")
    print(f"{args.scene}, {args.elements} el/link ({q.n} DOFs), θ = {args.angle:g}°, Ω = {args.speed:g} rad/s, full; "
          f"CPU s, median of {args.repeats}")
    with SlepcEngine() as engine:
        rows = {"projection": [], "accurate ST": []}
        for _ in range(args.repeats):  # alternated: both see the same load
            c = time.process_time()
            res = postprocess(engine.solve(q, args.modes), args.modes)
            rows["projection"].append(time.process_time() - c)
            solves = engine.settings()["last_refine_solves"]
            alpha = abs(res.eigenvalue[0])
            c = time.process_time()
            f_st, applies = accurate_st(q, args.modes, args.ksp, args.rtol, alpha)
            rows["accurate ST"].append(time.process_time() - c)
    print(f"  projection (engine, whole solve):   {np.median(rows['projection']):.3f} s, {solves} K solves, "
          f"status {res.status.value}, f = {np.array2string(res.frequency_hz, precision=9)}")
    print(f"  accurate ST ({args.ksp}, rtol {args.rtol:g}, TOAR only): {np.median(rows['accurate ST']):.3f} s, "
          f"{applies} accurate-K applications, f = {np.array2string(f_st, precision=9)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
