"""Time per point against error of f₁…f₄: meshes × elements × engines × tolerances, Pareto front.

For each scene (one representative operating point) the reference is the cubic-axial element's
Richardson extrapolation with the measured rate over 32/64/128(/256) elements per link; its own
error estimate is the change between the last two extrapolations. Every configuration (element
thesis|cubic, elements per link 1 … 4096, engine dense QZ | SLEPc TOAR | SLEPc linearization,
PEP tolerance) is timed per point in CPU time of this process (assembly of the angle's pieces + QEP + solve + polish, the
median of --repeats after a warm-up; above 3,000 DOFs one solve, set-up included) and its error is the largest relative
difference of f₁…f₄ from the reference. Writes JSON (--json), the figure
runs/figures/pareto-time-vs-error.png and prints each scene's Pareto front.

    PYTHONPATH=$PWD .venv/bin/python scripts/bench_time_vs_error.py
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

import benchlib

SCENES = {  # scene -> (angle deg, speed rad/s, case)
    "runs/bahgat-willmert-1976.toml": (10.0, 1000.0, "full"),
    "runs/turcic-midha-1984.toml": (90.0, 0.0, "structure"),
    "runs/rotating-cantilever.toml": (0.0, 35.7828502, "full"),
}
MESHES = [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096]
DENSE_MAX_DOFS = 300  # QZ of the 2n companion pencil is O(n³) (3 s at 288 DOFs): off the front beyond
LINEAR_MAX_DOFS = 10000
LOOSE_TOL_MAX_DOFS = 10000
ONE_REPEAT_DOFS = 3000  # and dense above 100 DOFs
N_MODES = 4


def configurations(element: str, n_free: int):
    """(label, engine method, petsc options) tried at a mesh of ``n_free`` DOFs."""
    out = [("slepc-toar", "slepc", ())]
    if n_free <= LOOSE_TOL_MAX_DOFS:
        out.append(("slepc-toar-tol1e-8", "slepc", (("pep_tol", "1e-8"),)))
    if n_free <= LINEAR_MAX_DOFS:
        out.append(("slepc-linear", "slepc", (("pep_type", "linear"),)))
    if n_free <= DENSE_MAX_DOFS:
        out.append(("dense", "dense", ()))
    return out


def solve_point(model, engine, point):
    from fkev_slepc.solve.modes import postprocess

    angle, speed, case = point
    qep = model.qep(model.pieces(np.radians(angle)), speed, case)
    return postprocess(engine.solve(qep, N_MODES), N_MODES)


def timed(model, engine, point, repeats):
    times, res = [], None
    for _ in range(repeats):
        t0 = time.process_time()  # CPU time: the machine is shared, wall time measures the neighbours
        res = solve_point(model, engine, point)
        times.append(time.process_time() - t0)
    return float(np.median(times)), res


def reference(scene, point):
    """Richardson extrapolation (measured rate) of the cubic element; (f_ref, error estimate, detail)."""
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import with_elements
    from fkev_slepc.solve.accuracy import with_element
    from fkev_slepc.solve.engines import make_engine

    from fkev_slepc.solve.thresholds import SolveSettings

    meshes = (32, 64, 128, 256)
    # Every pair polished, not only those above polish_above (1e-8): an unpolished pair error of
    # 9.6e-9 (cubic, 64 per link) leaves f₁ 1.8e-10 off, which showed as a Richardson ratio of
    # 15.1 instead of 16 and a reference error estimate of 2.7e-11 instead of ~1e-12.
    engine = make_engine("slepc", 10**6, scene.solver.petsc, settings=SolveSettings(polish_above=0.0))
    f = []
    try:
        for n in meshes:
            model = Model(with_elements(with_element(scene, "cubic"), n), cases=(point[2],))
            f.append(solve_point(model, engine, point).frequency_hz)
    finally:
        engine.close()
    f = np.array(f)
    extrap, rates = [], []
    for k in range(2, len(meshes)):
        p = np.log2(np.abs(f[k - 2] - f[k - 1]) / np.abs(f[k - 1] - f[k]))
        p = np.clip(np.where(np.isfinite(p), p, 4.0), 1.0, 8.0)
        rates.append(p)
        extrap.append(f[k] + (f[k] - f[k - 1]) / (2.0**p - 1.0))
    err = np.abs(extrap[-1] - extrap[-2]) / np.abs(extrap[-1])
    detail = {"meshes": list(meshes), "frequencies": f.tolist(), "rates": [r.tolist() for r in rates]}
    return extrap[-1], err, detail


def floor_table(path, point, f_ref, meshes=(256, 1024, 2048, 4096)):
    """Round-off floor: the largest relative error of f₁…f₄ on fine meshes, the engine's pairs
    as the assembled K gives them (no factored K_s, so no polish) against the polished ones."""
    import dataclasses

    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.solve.accuracy import with_element
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.slepc import SlepcEngine

    scene, out = load_scene(path), []
    with SlepcEngine(max_pair_error=1.0) as engine:  # report the unpolished pairs whatever their error
        for element in ("thesis", "cubic"):
            for n in meshes:
                model = Model(with_elements(with_element(scene, element), n), cases=(point[2],))
                qep = model.qep(model.pieces(np.radians(point[0])), point[1], point[2])
                row = {"element": element, "elements_per_link": n, "n_free": model.n_free}
                for label, q in (("assembled", dataclasses.replace(qep, staged=None)), ("polished", qep)):
                    res = postprocess(engine.solve(q, N_MODES), N_MODES)
                    row[label] = float(np.max(np.abs(res.frequency_hz - f_ref) / f_ref))
                    row[label + "_pair_error"] = float(np.nanmax(res.residual))
                out.append(row)
                print(f"  floor {element:6} {n:5} el/link: assembled K {row['assembled']:.1e} (pair error "
                      f"{row['assembled_pair_error']:.0e}), polished {row['polished']:.1e} (pair error "
                      f"{row['polished_pair_error']:.0e})", flush=True)
    return out


def pareto(rows):
    """Rows not dominated in (time, error), sorted by time (answers off by more than 50 %, e.g. a
    mode missing on a one-element mesh, are not candidates)."""
    rows = sorted((r for r in rows if r["error"] < 0.5), key=lambda r: (r["time_s"], r["error"]))
    front, best = [], math.inf
    for r in rows:
        if r["error"] < best:
            front.append(r)
            best = r["error"]
    return front


def run_scene(path, point, repeats, max_mesh):
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.solve.accuracy import with_element
    from fkev_slepc.solve.engines import make_engine

    scene = load_scene(path)
    f_ref, ref_err, detail = reference(scene, point)
    print(f"{path}: reference f = {np.array2string(f_ref, precision=10)} Hz, estimated error "
          f"{ref_err.max():.1e} (cubic, Richardson over {detail['meshes']} elements per link)", flush=True)
    rows = []
    for element in ("thesis", "cubic"):
        for n in [m for m in MESHES if m <= max_mesh]:
            model = Model(with_elements(with_element(scene, element), n), cases=(point[2],))
            for label, method, opts in configurations(element, model.n_free):
                engine = make_engine(method, model.n_free, opts)
                big = model.n_free > ONE_REPEAT_DOFS or (method == "dense" and model.n_free > 100)
                reps = 1 if big else repeats
                if reps > 1:
                    solve_point(model, engine, point)  # warm-up (symbolic factorization, caches)
                t, res = timed(model, engine, point, reps)
                engine.close()
                err = float(np.max(np.abs(res.frequency_hz - f_ref) / f_ref))
                rows.append({"element": element, "elements_per_link": n, "n_free": model.n_free, "engine": label,
                             "time_s": t, "error": err if np.isfinite(err) else math.inf,
                             "error_per_mode": (np.abs(res.frequency_hz - f_ref) / f_ref).tolist(),
                             "status": str(res.status.name.lower())})
            last = [r for r in rows if r["element"] == element and r["elements_per_link"] == n]
            print(f"  {element:6} {n:5} el/link {model.n_free:6} DOFs: " + ", ".join(
                f"{r['engine']} {r['time_s'] * 1e3:.1f} ms err {r['error']:.1e}" for r in last), flush=True)
    as_given = Model(scene, cases=(point[2],))  # the scene's own mesh and element (the thesis model)
    engine = make_engine("auto", as_given.n_free, scene.solver.petsc)
    f_given = solve_point(as_given, engine, point).frequency_hz
    engine.close()
    given = {"elements": [lk.elements for lk in scene.links], "element": scene.analysis.element,
             "frequency_hz": f_given.tolist(), "rel_error_per_mode": ((f_given - f_ref) / f_ref).tolist()}
    print(f"  as given ({given['element']}, elements {given['elements']}): relative error per mode "
          + " ".join(f"{e:+.2e}" for e in given["rel_error_per_mode"]), flush=True)
    return {"scene": path, "point": {"angle_deg": point[0], "speed_rad_s": point[1], "case": point[2]},
            "as_given": given,
            "reference_hz": f_ref.tolist(), "reference_error_estimate": ref_err.tolist(), "reference": detail,
            "rows": rows, "pareto": pareto(rows)}


def figure(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.8), sharey=True)
    markers = {"slepc-toar": "o", "slepc-toar-tol1e-8": "v", "slepc-linear": "s", "dense": "^"}
    colors = {"thesis": "tab:blue", "cubic": "tab:red"}
    for ax, res in zip(np.atleast_1d(axes), results):
        for r in res["rows"]:
            if np.isfinite(r["error"]):
                ax.loglog(r["time_s"] * 1e3, max(r["error"], 1e-16), markers[r["engine"]], ms=3.5,
                          color=colors[r["element"]], alpha=0.55, mec="none")
        front = res["pareto"]
        ax.loglog([r["time_s"] * 1e3 for r in front], [max(r["error"], 1e-16) for r in front], "k-", lw=1)
        ax.axhline(max(res["reference_error_estimate"]), color="0.5", ls=":", lw=1)
        ax.set_title(res["scene"].split("/")[-1].removesuffix(".toml"), fontsize=9)
        ax.set_xlabel("time per point [ms]")
        ax.grid(True, which="major", alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("max relative error of f₁…f₄")
    handles = [plt.Line2D([], [], color=c, marker="o", ls="", label=f"element {e}") for e, c in colors.items()]
    handles += [plt.Line2D([], [], color="0.3", marker=m, ls="", label=k) for k, m in markers.items()]
    handles += [plt.Line2D([], [], color="k", label="Pareto front"),
                plt.Line2D([], [], color="0.5", ls=":", label="reference error estimate")]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def table(results) -> str:
    lines = []
    for res in results:
        lines.append(f"\n{res['scene']} ({res['point']['case']}, θ = {res['point']['angle_deg']:g}°, "
                     f"Ω = {res['point']['speed_rad_s']:g} rad/s); reference error "
                     f"{max(res['reference_error_estimate']):.0e}")
        g = res["as_given"]
        lines.append(f"scene as given ({g['element']} element, elements {g['elements']}): relative error per mode "
                     + ", ".join(f"{e:+.1e}" for e in g["rel_error_per_mode"]))
        lines.append("| element | el/link | DOFs | engine | time/point [ms] | max rel. error f1-f4 |")
        lines.append("|---|---|---|---|---|---|")
        for r in res["pareto"]:
            lines.append(f"| {r['element']} | {r['elements_per_link']} | {r['n_free']} | {r['engine']} | "
                         f"{r['time_s'] * 1e3:.2f} | {r['error']:.1e} |")
        if "floor" in res:
            lines += ["\nround-off floor (SLEPc TOAR):", "| element | el/link | DOFs | assembled K: error (pair error) "
                      "| polished: error (pair error) |", "|---|---|---|---|---|"]
            lines += [f"| {r['element']} | {r['elements_per_link']} | {r['n_free']} | {r['assembled']:.1e} "
                      f"({r['assembled_pair_error']:.0e}) | {r['polished']:.1e} ({r['polished_pair_error']:.0e}) |"
                      for r in res["floor"]]
    return "\n".join(lines)


TARGETS = (1e-2, 1e-4, 1e-6, 1e-8)


def targets_table(results) -> str:
    """Cheapest configuration (time per point) reaching each error target, per scene."""
    head = "| scene | " + " | ".join(f"error ≤ {t:.0e}" for t in TARGETS) + " |"
    lines = [head, "|---" * (len(TARGETS) + 1) + "|"]
    for res in results:
        cells = []
        for t in TARGETS:
            ok = [r for r in res["pareto"] if r["error"] <= t]
            r = min(ok, key=lambda r: r["time_s"]) if ok else None
            cells.append("—" if r is None else f"{r['element']} {r['elements_per_link']}/link, {r['engine']}, "
                         f"{r['time_s'] * 1e3:.0f} ms")
        name = res["scene"].split("/")[-1].removesuffix(".toml")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = benchlib.parser(__doc__, modes=N_MODES, repeats=3)
    ap.add_argument("--max-mesh", type=int, default=4096, help="finest elements per link")
    ap.add_argument("--floor-meshes", default="256,1024,2048,4096", help="meshes of the round-off floor table")
    ap.add_argument("--replot", action="store_true", help="only redraw the figure and tables from --json")
    ap.add_argument("--json", default="runs/bench/time-vs-error.json")
    ap.add_argument("--figure", default="runs/figures/pareto-time-vs-error.png")
    args, _ = benchlib.parse(ap, argv)
    t0 = time.perf_counter()
    if args.replot:
        results = json.loads((benchlib.ROOT / args.json).read_text())["results"]
        for res in results:
            res["pareto"] = pareto(res["rows"])
        figure(results, benchlib.ROOT / args.figure)
        print(table(results) + "\n\n" + targets_table(results))
        return 0
    results = [run_scene(path, point, args.repeats, args.max_mesh) for path, point in SCENES.items()]
    first = results[0]
    point = tuple(first["point"].values())
    first["floor"] = floor_table(first["scene"], point, np.array(first["reference_hz"]),
                                 tuple(int(v) for v in args.floor_meshes.split(",")))
    out = benchlib.ROOT / args.json
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"command": "scripts/bench_time_vs_error.py", "results": results}, indent=0))
    figure(results, benchlib.ROOT / args.figure)
    print(table(results) + "\n\n" + targets_table(results))
    print(f"\nwrote {args.json} and {args.figure} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
