#!/usr/bin/env python
"""Floquet monodromy of one crank speed against the frozen sweep of the same angles.

Thesis size (the scene's mesh): the monodromy of one revolution at ``--speed`` and ``--case``
(periodic.floquet.floquet_multipliers at ``--tol``: coefficient samples, trigonometric
interpolant, 6th-order symplectic Magnus with step doubling) is timed against the frozen sweep
of the same scene at that speed and case over 360 crank angles (sweep.runner.Sweep.solve_angle
for every angle: pieces, QEP, dense engine, selection and classification; no HDF5), the two
timed alternately, medians over ``--repeats``. The multiplier error is measured against a run at
``--tol``/1000 (matched multipliers), beside the run's own step-doubling estimate.

Reduced against full (``--reduce-speeds``, e.g. ``60,30``; empty skips it): on ``--reduce-scene``
(default Turcic–Midha, 27 DOFs) at ``--reduce-elements`` per link (0: the scene's mesh), the full
monodromy and the reduced one (``reduce="auto"``: the convergence sequence of
fkev_slepc/periodic/truncation.py) timed alternately, medians over ``--reduce-repeats``: basis size,
steps, max|μ| of both, the true relative error of the reduced max|μ| beside its truncation
estimate, the frequency measure, and the speed-up.

Large model (``--large-elements`` per link, 111 gives 999 DOFs; 0 skips it): the full monodromy is
out of reach; the reduced one (``reduce="auto"``, at most ``--large-max-basis`` vectors) is timed
and its convergence sequence printed level by level (basis size, max|μ|, max Re s) with the
truncation measures of the last pair and whether they met the tolerance. One BLAS thread.

    .venv/bin/python scripts/bench_floquet.py
    .venv/bin/python scripts/bench_floquet.py --repeats 1 --large-elements 0 --angles 36
    .venv/bin/python scripts/bench_floquet.py --table bw:1:500,bw:4:500,tm:0:60 --repeats 3

Side by side (``--table``): per row SCENE:ELEMENTS:SPEED the frozen 360-angle sweep, the full
monodromy (models up to ``--table-full-max`` DOFs), the frozen-mode reduction (``reduce="auto"``)
and the link-frame component modes (``reduce="links"``, fkev_slepc/periodic/components.py), timed
alternately, medians over ``--repeats``; ratios to the sweep and max|μ| differences from the full
model, as a markdown table. ``--table-structure``: each method by the generic and by the structured
Hamiltonian Magnus steps (fkev_slepc/periodic/hamiltonian.py), timed alternately, with the ratio of
their medians and the relative difference of their monodromies.

    .venv/bin/python scripts/bench_floquet.py --table bw:4:500,sc:0:150 --table-methods full --table-structure

``--table-floor``: per row the least a step-doubling run of the full model at its accepted step
count N can cost (the bare products of N and N/2 step maps, nothing else), beside the sweep and the
whole Floquet: what no step-count rule of this integrator can go below.

    .venv/bin/python scripts/bench_floquet.py --table tm:0:60,tm:0:100,bw:4:500 --table-floor --repeats 3
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
    ap.add_argument("--tol", type=float, default=1e-8, help="monodromy tolerance (multiplier error relative to max(1, max|mu|))")
    ap.add_argument("--large-elements", type=int, default=111)
    ap.add_argument("--large-max-basis", type=int, default=14, help="cap of the large model's basis")
    ap.add_argument("--reduce-speeds", default="", help="speeds of the reduced-vs-full comparison (a,b,...)")
    ap.add_argument("--reduce-scene", default="runs/turcic-midha-1984.toml")
    ap.add_argument("--reduce-elements", type=int, default=0, help="elements per link (0: the scene's)")
    ap.add_argument("--reduce-repeats", type=int, default=1)
    ap.add_argument("--table", default="", help="side-by-side rows SCENE:ELEMENTS:SPEED,... (SCENE bw, tm, sc or "
                    "a path; ELEMENTS 0: the scene's mesh): frozen sweep, full, frozen-mode auto, link components")
    ap.add_argument("--table-methods", default="full,auto,links", help="which monodromies the table times")
    ap.add_argument("--table-full-max", type=int, default=400, help="largest model (DOFs) whose full monodromy is timed")
    ap.add_argument("--table-structure", action="store_true", help="time each table method twice, alternately: "
                    "generic Magnus steps and the structured Hamiltonian ones (fkev_slepc/periodic/hamiltonian.py)")
    ap.add_argument("--table-floor", action="store_true", help="instead: the least any step-doubling run of the "
                    "full model's accepted step count N can cost (the bare products of N and N/2 step maps) beside "
                    "the sweep and the whole Floquet")
    ap.add_argument("--table-steps", action="store_true", help="instead of timing: the least Magnus step count "
                    "2·2π·ρ(A) of the full model and of the link-component levels (1, 2, 4, 8, 16 modes per link)")
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
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.periodic.magnus import match_multipliers
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.settings import PeriodicSettings
    from fkev_slepc.periodic.system import PeriodicSystem

    if args.table:
        (level_steps if args.table_steps else floor if args.table_floor else side_by_side)(args)
        return
    scene = load_scene(benchlib.ROOT / args.scene)
    model = Model(scene, cases=(args.case,))
    sweep = frozen_sweep(scene, model, args.speed, args.case, args.angles, args.modes)
    sweep()  # warm-up
    t_sweep, t_mono, res = [], [], None
    for _ in range(args.repeats):
        t_sweep.append(sweep())
        t0 = time.perf_counter()
        res = floquet_multipliers(PeriodicSystem(model, args.speed, args.case),
                                  PeriodicSettings(reduce="none", monodromy_tol=args.tol))
        t_mono.append(time.perf_counter() - t0)
    ref = floquet_multipliers(PeriodicSystem(model, args.speed, args.case),
                              PeriodicSettings(reduce="none", monodromy_tol=args.tol / 1000))
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
    for w in [float(x) for x in args.reduce_speeds.split(",") if x.strip()]:
        reduced_vs_full(load_scene(benchlib.ROOT / args.reduce_scene), args.reduce_elements, w, args.case,
                        args.tol, args.reduce_repeats)
    if args.large_elements > 0:
        big = with_elements(scene, args.large_elements)
        bm = Model(big, cases=(args.case,))
        t0 = time.perf_counter()
        red = floquet_multipliers(PeriodicSystem(bm, args.speed, args.case),
                                  PeriodicSettings(reduce="auto", monodromy_tol=args.tol, max_basis=args.large_max_basis))
        print(f"large: {bm.n_free} DOFs, reduce=auto (at most {args.large_max_basis} vectors): "
              f"{time.perf_counter() - t0:.1f} s, last level {red.basis} vectors, {red.monodromy.steps} steps")
        print_truncation(red.truncation)


def print_truncation(t) -> None:
    for size, mu, re in t.levels:
        print(f"  level {size:3d} vectors: max|mu| {mu:.9f}, max Re s {re:.6g} 1/s")
    print(f"  truncation (last two pairs of levels): max|mu| {t.max_abs:.1e} relative, growth rate "
          f"{t.growth_rate:.1e} 1/s, Floquet frequencies {t.frequency:.1e} relative; "
          f"{'converged' if t.converged else 'NOT converged'} to {t.tol:g}")


def reduced_vs_full(scene, elements, speed, case, tol, repeats) -> None:
    """The full and the auto-reduced monodromy of one speed, timed alternately (medians)."""
    from fkev_slepc.model.operators import Model
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.settings import PeriodicSettings
    from fkev_slepc.periodic.system import PeriodicSystem

    from fkev_slepc.scene import with_elements

    model = Model(with_elements(scene, elements) if elements > 0 else scene, cases=(case,))
    t_full, t_red = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        full = floquet_multipliers(PeriodicSystem(model, speed, case),
                                   PeriodicSettings(reduce="none", monodromy_tol=tol))
        t_full.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        red = floquet_multipliers(PeriodicSystem(model, speed, case),
                                  PeriodicSettings(reduce="auto", monodromy_tol=tol))
        t_red.append(time.perf_counter() - t0)
    tf, tr = np.median(t_full), np.median(t_red)
    print(f"reduced vs full: {scene.title}, {model.n_free} DOFs, case {case}, {speed:g} rad/s, {repeats} repeat(s)")
    print(f"  full: {tf:.2f} s, {full.monodromy.steps} steps, max|mu| {full.max_abs:.12f}")
    print(f"  reduced: {tr:.2f} s, {red.basis} vectors, {red.monodromy.steps} steps (last level), "
          f"max|mu| {red.max_abs:.12f}")
    print(f"  true error of max|mu|: {abs(red.max_abs - full.max_abs) / full.max_abs:.1e} relative; "
          f"speed-up full / reduced: {tf / tr:.1f}")
    print_truncation(red.truncation)

TABLE_SCENES = {"bw": "runs/bahgat-willmert-1976.toml", "tm": "runs/turcic-midha-1984.toml",
                "sc": "runs/slider-crank-benchmark.toml"}
TABLE_REDUCE = {"full": None, "auto": "auto", "links": "links", "default": "default", "links:2": "links:2",
                "links:4": "links:4"}


def _table_models(args):
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements

    for row in args.table.split(","):
        name, elements, speed = row.split(":")
        scene = load_scene(benchlib.ROOT / TABLE_SCENES.get(name, name))
        scene = with_elements(scene, int(elements)) if int(elements) > 0 else scene
        yield name, elements, float(speed), scene, Model(scene, cases=(args.case,))


def level_steps(args) -> None:
    """Per row: the full model's least step count and each link-component level's (basis size, least
    step count, highest retained fixed-interface frequency), from one eigenvalue problem each."""
    from fkev_slepc.periodic.components import link_components
    from fkev_slepc.periodic.floquet import full_min_steps

    for name, elements, speed, _scene, model in _table_models(args):
        comp = link_components(model)
        full = full_min_steps(model, speed, args.case) if model.n_free <= args.table_full_max else "-"
        cells = []
        for k in (1, 2, 4, 8, 16):
            basis = comp.basis(k)
            steps = full_min_steps(model, speed, args.case, basis=basis)
            cells.append(f"{basis.shape[1]}: {steps:,} ({basis.covered_rad_s:.3g} rad/s)")
        print(f"| {name} | {elements} | {model.n_free} | {speed:g} | {full if isinstance(full, str) else f'{full:,}'} | "
              + " | ".join(cells) + " |", flush=True)


def floor(args) -> None:
    """Per row: the full model's Floquet (``floquet_multipliers``, its accepted step count N), then,
    timed alternately with the frozen sweep and medians over ``--repeats``: the bare ordered product
    of the N step maps of its interpolated generator (periodic/magnus.py ``_product``: the step
    exponentials and their products, nothing else) and of N/2, whose change certifies N. Their sum
    is the least a run of this integrator at N steps costs, whatever its step-count rule."""
    from fkev_slepc.periodic import magnus
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.settings import PeriodicSettings
    from fkev_slepc.periodic.system import PeriodicSystem

    print("| scene | el/link | DOFs | rad/s | steps N | sweep s | Floquet s (×sweep) | product N s (×sweep) "
          "| products N + N/2 s (×sweep) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, elements, speed, scene, model in _table_models(args):
        sweep = frozen_sweep(scene, model, speed, args.case, args.angles, args.modes)
        gen = PeriodicSystem(model, speed, args.case).interpolant().generator
        t = {k: [] for k in ("sweep", "floquet", "N", "N/2")}
        for _ in range(args.repeats):
            t["sweep"].append(sweep())
            t0 = time.perf_counter()
            steps = floquet_multipliers(PeriodicSystem(model, speed, args.case),
                                        PeriodicSettings(reduce="none", monodromy_tol=args.tol)).monodromy.steps
            t["floquet"].append(time.perf_counter() - t0)
            for key, n in (("N", steps), ("N/2", steps // 2)):
                t0 = time.perf_counter()
                magnus._product(gen, 0.0, 2.0 * np.pi, n, None, 6)
                t[key].append(time.perf_counter() - t0)
        ts, tf, tn, th = (float(np.median(t[k])) for k in ("sweep", "floquet", "N", "N/2"))
        print(f"| {name} | {elements} | {model.n_free} | {speed:g} | {steps:,} | {ts:.2f} | {tf:.2f} ({tf / ts:.2f}×) | "
              f"{tn:.2f} ({tn / ts:.2f}×) | {tn + th:.2f} ({(tn + th) / ts:.2f}×) | load {os.getloadavg()[0]:.1f}",
              flush=True)


def side_by_side(args) -> None:
    """One row per SCENE:ELEMENTS:SPEED: the frozen 360-angle sweep and each monodromy of
    ``--table-methods`` timed alternately (medians over ``--repeats``), their ratios to the sweep,
    max|μ| and its difference from the full model (where the full model is timed). With
    ``--table-structure`` each method twice, alternately: the generic steps and the structured
    Hamiltonian ones (PeriodicSystem.hamiltonian_steps), the ratio of their medians and the relative
    difference of their Φ."""
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.settings import PeriodicSettings
    from fkev_slepc.periodic.system import PeriodicSystem

    methods = [m.strip() for m in args.table_methods.split(",") if m.strip()]
    runs = [(f"{m} {k}", m, k == "Hamiltonian") for m in methods for k in ("generic", "Hamiltonian")] \
        if args.table_structure else [(m, m, True) for m in methods]
    print("| scene | el/link | DOFs | rad/s | sweep s | " + " | ".join(
        f"{r} s (×sweep) | {r} max|μ| (basis)" for r, _, _ in runs) + " |"
        + "".join(f" {m} Hamiltonian / generic, Φ rel. diff |" for m in methods if args.table_structure))
    print("|" + "---|" * (5 + 2 * len(runs) + (len(methods) if args.table_structure else 0)))
    for name, elements, speed, scene, model in _table_models(args):
        todo = [r for r in runs if r[1] != "full" or model.n_free <= args.table_full_max]
        sweep = frozen_sweep(scene, model, speed, args.case, args.angles, args.modes)
        times = {r: [] for r in ["sweep"] + [r[0] for r in todo]}
        res = {}
        for _ in range(args.repeats):
            times["sweep"].append(sweep())
            for label, m, structured in todo:
                PeriodicSystem.hamiltonian_steps = structured
                t0 = time.perf_counter()
                res[label] = floquet_multipliers(PeriodicSystem(model, speed, args.case),
                                                 PeriodicSettings(reduce=TABLE_REDUCE[m], monodromy_tol=args.tol))
                times[label].append(time.perf_counter() - t0)
        PeriodicSystem.hamiltonian_steps = True
        ts = float(np.median(times["sweep"]))
        full = next((res[r] for r, m, _ in runs if m == "full" and r in res), None)
        cells = []
        for label, m, _ in runs:
            if label not in res:
                cells += ["not run", "-"]
                continue
            r, tm = res[label], float(np.median(times[label]))
            diff = f", Δ {abs(r.max_abs - full.max_abs):.1e}" if full is not None and m != "full" else ""
            extra = "" if r.basis is None else f" ({r.basis}{'' if r.truncation.converged else ' NOT converged'})"
            cells += [f"{tm:.2f} ({tm / ts:.2f}×)", f"{r.max_abs:.9f}{diff}{extra}, {r.monodromy.steps} steps"]
        for m in methods if args.table_structure else ():
            g, h = f"{m} generic", f"{m} Hamiltonian"
            if g not in res:
                cells.append("-")
                continue
            a, b = res[g].monodromy.phi, res[h].monodromy.phi
            rel = np.linalg.norm(a - b) / np.linalg.norm(a) if a.shape == b.shape else float("nan")
            cells.append(f"{np.median(times[h]) / np.median(times[g]):.3f}, {rel:.1e}")
        print(f"| {name} | {elements} | {model.n_free} | {speed:g} | {ts:.2f} | " + " | ".join(cells)
              + f" | load {os.getloadavg()[0]:.1f}", flush=True)

if __name__ == "__main__":
    main()
