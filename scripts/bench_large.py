#!/usr/bin/env python
"""One grid point of a refined model (>= 50,000 DOFs) against a bare SLEPc solve of a beam QEP.

The point is timed as a sweep runs it, split into kinematics (loop closure and rigid-body
loads), element matrices (rotation to global of the element stacks), assembly (scatter into
the cached CSR pattern, combination per speed and case), factorization (PETSc log event
PCSetUp) and the eigen-solve (the rest of ``SlepcEngine.solve``: copying values in,
the scale estimate, TOAR iterations, eigenvector extraction, pair errors). The first point also
creates the PETSc matrices and the symbolic factorization; later points (further crank angles)
reuse both. The bare reference is a straight clamped beam with as many DOFs, C = 2ΩG and
K = K_s - Ω²M, built directly into PETSc matrices and solved by a PEP with TOAR and
shift-and-invert (same tolerance, nev, ncv and scale factor as the engine). Medians of
``--repeats``; the bare solve and the point alternate, so both see the same machine load.

    .venv/bin/python scripts/bench_large.py
    .venv/bin/python scripts/bench_large.py --elements 5600 --repeats 3 -- -fkev_st_pc_factor_mat_solver_type mumps
    .venv/bin/python scripts/bench_large.py --elements 300 --compare st_pc_factor_mat_solver_type=mumps,superlu,umfpack,klu,petsc
    .venv/bin/python scripts/bench_large.py --elements 300 --compare pep_scale=none,scalar
"""

from __future__ import annotations

import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import benchlib


def parse_args(argv=None):
    ap = benchlib.parser(__doc__, modes=6, repeats=3)
    ap.add_argument("--elements", type=int, default=5600, help="elements on every link")
    ap.add_argument("--angle", type=float, default=10.0, help="first crank angle, deg")
    ap.add_argument("--speed", type=float, default=500.0, help="crank speed, rad/s")
    ap.add_argument("--case", default="full")
    ap.add_argument("--compare", metavar="OPTION=v1,v2,...",
                    help="instead: the point with each value of one fkev_ option, e.g. "
                         "st_pc_factor_mat_solver_type=mumps,superlu,umfpack,klu,petsc")
    ap.add_argument("--perturb", action="store_true",
                    help="instead: how far f1 moves when each entry of K changes by one unit in the last place")
    ap.add_argument("--ref-elements", type=int, default=60,
                    help="with --compare: elements per link of the reference solved by dense QZ")
    return benchlib.parse(ap, argv)


class Timers:
    """Wall time spent inside wrapped functions, by category (re-entrant calls counted once)."""

    def __init__(self):
        self.total = defaultdict(float)
        self.depth = 0

    def wrap(self, owner, name, category):
        fn = getattr(owner, name)

        def timed(*a, **k):
            if self.depth:
                return fn(*a, **k)
            self.depth += 1
            t = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                self.total[category] += time.perf_counter() - t
                self.depth -= 1

        setattr(owner, name, timed)


def instrument(timers: Timers) -> None:
    """Attribute the model's per-point work to categories by wrapping the functions it calls."""
    from fkev_slepc.model import assembly
    from fkev_slepc.model import elements
    from fkev_slepc.model import stacks  # the angle state: kinematics, kinetostatics, rotations
    timers.wrap(stacks, "solve_kinematics", "kinematics")
    timers.wrap(stacks, "solve_loads", "kinematics")  # rigid-body kinetostatics
    timers.wrap(stacks, "axial_polynomials", "kinematics")
    for name in ("rotation", "to_global", "axial_force_local"):
        timers.wrap(elements, name, "element matrices")
    for name in ("scatter", "add_diagonal", "matrix"):
        timers.wrap(assembly.Pattern, name, "assembly")


def event_time(PETSc, *names) -> float:
    """Cumulative time of PETSc log events (logging started with PETSc.Log.begin())."""
    return sum(PETSc.Log.Event(n).getPerfInfo()["time"] for n in names)


def factor_time(PETSc) -> float:
    # PCSetUp = the LU factorization (MUMPS logs MatLUFactorSym/Num, the others MatLUFactor)
    return event_time(PETSc, "PCSetUp")


def beam_qep_petsc(n_free: int, scene, omega: float):
    """A straight clamped beam with ``n_free`` DOFs (link properties of the scene's first link,
    total length of its links) as PETSc K, C, M, and |λ₁| of the cantilever (for the scale)."""
    from fkev_slepc.model import elements as el
    from fkev_slepc.model.assembly import Pattern
    from fkev_slepc.solve.petsc_backend import PETSc

    lk = scene.links[0]
    n_el = n_free // 3
    length = sum(link.length for link in scene.links)
    l = np.full(n_el, length / n_el)
    rho_a, ea, ei = (np.full(n_el, v) for v in (lk.density * lk.area, lk.youngs_modulus * lk.area,
                                                  lk.youngs_modulus * lk.second_moment))  # fmt: skip
    dofs = 3 * np.arange(n_el)[:, None] + np.arange(6) - 3  # node 0 clamped: its dofs become -1
    dofs[dofs < 0] = -1
    pat = Pattern(dofs, 3 * n_el)
    M = pat.scatter(el.mass_local(rho_a, l))
    G = pat.scatter(el.skew_mass_local(rho_a, l))
    K = pat.scatter(el.structural_local(ea, ei, l)) - omega**2 * M
    mats = [PETSc.Mat().createAIJ(size=(pat.n, pat.n), csr=(pat.indptr, pat.indices, d), comm=PETSc.COMM_SELF)
            for d in (K, 2 * omega * G, M)]  # fmt: skip
    lam1 = 1.8751**2 * np.sqrt(lk.youngs_modulus * lk.second_moment / (rho_a[0] * length**4))
    return mats, lam1


def bare_solve(mats, lam1, n_modes, package) -> tuple[float, int, float]:
    """Fresh PEP (TOAR, sinvert, LU by ``package``), solve, return (seconds, converged pairs, CPU seconds)."""
    from fkev_slepc.solve.petsc_backend import PETSc
    from fkev_slepc.solve.slepc import SLEPc

    t, c = time.perf_counter(), time.process_time()
    pep = SLEPc.PEP().create(PETSc.COMM_SELF)
    pep.setOperators(mats)
    pep.setType(SLEPc.PEP.Type.TOAR)
    pep.setProblemType(SLEPc.PEP.ProblemType.GYROSCOPIC)
    st = pep.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.getKSP().setType("preonly")
    st.getKSP().getPC().setType("lu")
    st.getKSP().getPC().setFactorSolverType(package)
    benchlib.bare_toar_settings(pep, n_modes, lam1, SLEPc)
    pep.solve()
    n = pep.getConverged()
    pep.destroy()
    return time.perf_counter() - t, n, time.process_time() - c


def main(argv=None) -> int:
    args, petsc = parse_args(argv)
    from fkev_slepc.solve.petsc_backend import PETSc
    from fkev_slepc.solve.slepc import SlepcEngine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements

    PETSc.Log.begin()
    print("command:", " ".join([Path(sys.executable).name, *sys.argv]))
    timers = Timers()
    instrument(timers)
    scene = with_elements(load_scene(args.scene), args.elements)
    t = time.perf_counter()
    model = Model(scene, cases=(args.case,))
    t_model = time.perf_counter() - t
    print(f"{args.scene}, {args.elements} elements per link: {model.n_free} free DOFs, θ from {args.angle:g}°, "
          f"Ω = {args.speed:g} rad/s, case {args.case}, {args.modes} modes; model set-up (once per run) {t_model:.2f} s")
    if args.compare:
        return compare_table(args, model, PETSc, SlepcEngine, postprocess)
    if args.perturb:
        return perturbation(args, model, SlepcEngine, postprocess)

    engine = SlepcEngine()
    package = engine.settings()["factor_solver_type"]
    print(f"LU package {package} (engine and bare solve)")
    mats, lam1 = beam_qep_petsc(model.n_free, scene, args.speed)
    rows, bare, bare_cpu = [], [], []
    for r in range(args.repeats + 1):  # point 0 creates the PETSc matrices; 1.. reuse them
        if r:
            wall, _, cpu = bare_solve(mats, lam1, args.modes, package)
            bare.append(wall)
            bare_cpu.append(cpu)
        timers.total.clear()
        f0, s0 = factor_time(PETSc), event_time(PETSc, "PEPSetUp", "PEPSolve")
        t0, c0 = time.perf_counter(), time.process_time()
        pieces = model.pieces(np.radians(args.angle + r))
        q = model.qep(pieces, args.speed, args.case)
        t1 = time.perf_counter()
        sol = engine.solve(q, args.modes)
        t2, c2 = time.perf_counter(), time.process_time()
        res = postprocess(sol, args.modes)
        fac = factor_time(PETSc) - f0
        slepc = event_time(PETSc, "PEPSetUp", "PEPSolve") - s0 - fac  # iterations, solves with the factors
        row = dict(timers.total)
        row.update({"factorization": fac, "eigen-solve": (t2 - t1) - fac, "  SLEPc setup+solve": slepc,
                    "  engine rest": (t2 - t1) - fac - slepc, "point": t2 - t0, "point CPU": c2 - c0})
        rows.append(row)
        print(f"  point {r} (θ = {args.angle + r:g}°): {t2 - t0:.2f} s, status {res.status.value}, "
              f"f1 = {res.frequency_hz[0]:.4f} Hz, max pair error {np.nanmax(res.residual):.1e}"
              f"{'; ' + res.message if res.message else ''}", flush=True)
    for m in mats:
        m.destroy()
    engine.close()
    print(f"\ntime split, seconds (first point; median of points 1..{args.repeats}, which reuse PETSc objects);"
          "\n'engine rest' = copying values in, eigenvector extraction, pair errors, polish (solve/polish.py)")
    keys = ["kinematics", "element matrices", "assembly", "factorization", "eigen-solve", "  SLEPc setup+solve",
            "  engine rest", "point"]
    for k in keys:
        first, later = rows[0].get(k, 0.0), np.median([row.get(k, 0.0) for row in rows[1:]])
        print(f"  {k:<17} {first:8.3f} {later:8.3f}")
    b = np.median(bare)
    p = np.median([row["point"] for row in rows[1:]])
    print(f"bare TOAR + sinvert solve of a {3 * (model.n_free // 3)}-DOF beam QEP (fresh PEP, median of "
          f"{len(bare)}): {b:.3f} s")
    print(f"whole point / bare solve = {p / b:.2f} (target <= 3)")
    # CPU time of this process: less sensitive to other sessions on a shared machine than wall time
    pc, bc = np.median([row["point CPU"] for row in rows[1:]]), np.median(bare_cpu)
    print(f"CPU time: point {pc:.3f} s, bare solve {bc:.3f} s, ratio {pc / bc:.2f}")
    return 0


def perturbation(args, model, SlepcEngine, postprocess) -> int:
    """Conditioning of the assembled model: f1 of K·(1 + ε·r), r ~ N(0, 1) entrywise, ε = 2.2e-16.

    What no solver can beat: if one rounding of K's entries moves f1 by δ, the double-precision
    model determines f1 only to about δ.
    """
    from fkev_slepc.model.qep import QEP

    q = model.qep(model.pieces(np.radians(args.angle)), args.speed, args.case)
    rng = np.random.default_rng(1)
    with SlepcEngine([("max_pair_error", "1e300")]) as engine:
        f0 = postprocess(engine.solve(q, args.modes), args.modes).frequency_hz[0]
        moves = []
        for _ in range(args.repeats):
            K = q.stiffness.copy()
            K.data = K.data * (1.0 + np.finfo(float).eps * rng.standard_normal(K.nnz))
            f = postprocess(engine.solve(QEP(q.mass, q.damping, K, q.kind), args.modes), args.modes).frequency_hz[0]
            moves.append(abs(f / f0 - 1))
    print(f"f1 = {f0:.6f} Hz; relative change of f1 under one-ulp perturbations of K ({args.repeats} samples): "
          + ", ".join(f"{m:.1e}" for m in moves))
    return 0


def compare_table(args, model, PETSc, SlepcEngine, postprocess) -> int:
    """The same point with each value of one option (first row: the engine's defaults):
    median time, factorization time, TOAR restarts, frequencies, error vs a dense reference."""
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.scene import with_elements

    name, _, values = args.compare.partition("=")
    q = model.qep(model.pieces(np.radians(args.angle)), args.speed, args.case)
    coarse = type(model)(with_elements(model.scene, args.ref_elements), cases=(args.case,))
    ref = postprocess(DenseEngine().solve(coarse.qep(coarse.pieces(np.radians(args.angle)), args.speed, args.case),
                                          args.modes), args.modes).frequency_hz  # fmt: skip
    print(f"reference: dense QZ at {args.ref_elements} elements per link ({coarse.n_free} DOFs): f1 = {ref[0]:.6f} Hz")
    print(f"{name:<12} {'time [s]':>9} {'factor [s]':>10} {'its':>4}  status          f1 [Hz]        "
          f"f{args.modes} [Hz]  f1 rel err  max η")
    for value in [None, *values.split(",")]:
        times, facs = [], []
        opts = [("max_pair_error", "1e300")]  # report every pair, flagged or not
        with SlepcEngine(opts if value is None else [*opts, (name, value)]) as engine:
            for _ in range(args.repeats):
                f0 = factor_time(PETSc)
                t = time.perf_counter()
                sol = engine.solve(q, args.modes)
                times.append(time.perf_counter() - t)
                facs.append(factor_time(PETSc) - f0)
            its = engine.settings().get("last_iterations", -1)
        res = postprocess(sol, args.modes)
        err = abs(res.frequency_hz[0] / ref[0] - 1)
        label = "(default)" if value is None else value
        print(f"{label:<12} {np.median(times):9.3f} {np.median(facs):10.3f} {its:>4}  {res.status.value:<14}"
              f"{res.frequency_hz[0]:11.6f} {res.frequency_hz[-1]:13.6f}  {err:10.1e}  {np.nanmax(res.residual):.1e}"
              f"{'' if sol.converged else '  ' + sol.message[:50]}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
