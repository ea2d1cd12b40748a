#!/usr/bin/env python
"""Mesh convergence of the Floquet verdict with the link-component reduction (docs/stability.md).

For one scene and crank speed, at each mesh of ``--elements`` (elements per link, e.g. 4,8,16,32
and 111 for Bahgat–Willmert = 999 DOFs): the Floquet multipliers of one revolution projected on
the link-frame component modes (fkev_slepc/periodic/components.py, docs/theory.md §18.8) with a FIXED
number ``--modes`` of fixed-interface modes per link, so that every mesh retains the same
physics (the boundary DOFs and the same lowest modes of each link); ``--double`` repeats each
mesh with twice the modes per link and prints the change (the truncation, measured by doubling).

Printed per mesh: DOFs, basis size, the covered frequency range (highest retained
fixed-interface frequency), max|μ|, the lowest ``--retained`` Floquet frequencies (|Im s|
unwrapped by the engine, rad/s), wall times (model and components; monodromy, median over
``--repeats``, one BLAS thread). Then the convergence table: the lowest Floquet frequencies as
**folded** frequencies f = |arg μ|·Ω/2π ∈ [0, Ω/2] (Im s is defined modulo Ω; the engine's
unwrapping picks a branch by a Rayleigh quotient at the start angle, which can change from one
mesh to the next where Floquet modes mix frozen modes; the folded value is the multiplier's
phase, which the mesh determines), their change Δ against the next finer mesh, and the observed
rate log(Δᵢ₋₁/Δᵢ)/log(nᵢ/nᵢ₋₁) where the mesh ratios of the two changes are equal (doubling:
log2 of the ratio of successive changes; Euler–Bernoulli cubic elements converge frequencies as
h⁴). A mesh after an unequal ratio (e.g. 32 -> 111) is checked against the order-4 Richardson
prediction from the two meshes before it: "pred" is f∞ + (f₂ - f∞)(n₂/n₃)⁴ with
f∞ = f₂ + (f₂ - f₁)/((n₂/n₁)⁴ - 1).

``--edge LO:HI`` also locates, at each mesh of ``--edge-elements``, the band edge in [LO, HI]
(one stable and one unstable end) by the engine's edge search (fkev_slepc/periodic/edges.py,
``refine_edges``, to ``--edge-rtol``) with the same fixed modes per link.

    PYTHONPATH=$PWD .venv/bin/python scripts/mesh_convergence.py --scene bw --speed 500 \\
        --elements 4,8,16,32,111 --modes 2 --double
    PYTHONPATH=$PWD .venv/bin/python scripts/mesh_convergence.py --scene tm --speed 60 \\
        --elements 4,8,16,32 --modes 2 --double --edge 54.5:56 --edge-elements 4,8,16
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy: one BLAS thread, as one MPI rank has

import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402

import numpy as np  # noqa: E402

import benchlib  # noqa: E402
from fkev_slepc.periodic.truncation import folded  # noqa: E402  (the one folding, also the truncation's)

SCENES = {"bw": "runs/bahgat-willmert-1976.toml", "tm": "runs/turcic-midha-1984.toml",
          "sc": "runs/slider-crank-benchmark.toml"}
ORDER = 4.0  # the h-order of the frequencies of cubic (Euler–Bernoulli) elements, for the Richardson check


def _counts(ap, text: str, name: str) -> list[int]:
    """Whole numbers >= 1 from "a,b,c"; otherwise one error naming ``name`` (exit 2)."""
    try:
        out = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        out = []
    if not out or min(out) < 1:
        ap.error(f"{name}: needs elements per link a,b,c, each >= 1 (got {text!r})")
    return out


def parse_args(argv=None):
    ap = benchlib.parser(__doc__, modes=2, repeats=1)
    ap.set_defaults(scene="bw")
    ap.add_argument("--speed", type=float, default=500.0, help="crank speed, rad/s (> 0)")
    ap.add_argument("--case", default="full")
    ap.add_argument("--elements", default="4,8,16,32", help="elements per link of each mesh, a,b,c")
    ap.add_argument("--double", action="store_true", help="repeat each mesh with 2x --modes per link")
    ap.add_argument("--retained", type=int, default=4, help="lowest Floquet frequencies compared")
    ap.add_argument("--tol", type=float, default=1e-10, help="monodromy tolerance")
    ap.add_argument("--edge", default="", help="LO:HI bracket of a band edge, rad/s (empty: none)")
    ap.add_argument("--edge-elements", default="4,8,16", help="meshes of the band-edge search")
    ap.add_argument("--edge-rtol", type=float, default=1e-4, help="band edge to this relative accuracy")
    args = benchlib.parse(ap, argv)[0]
    if not np.isfinite(args.speed) or args.speed <= 0:
        ap.error(f"--speed: needs a crank speed > 0 rad/s (got {args.speed!r})")
    if args.modes < 1:
        ap.error(f"--modes: needs >= 1 fixed-interface mode per link (got {args.modes!r})")
    if args.retained < 1:
        ap.error(f"--retained: needs >= 1 (got {args.retained!r})")
    args.meshes = _counts(ap, args.elements, "--elements")
    args.edge_meshes = _counts(ap, args.edge_elements, "--edge-elements")
    args.bracket = None
    if args.edge:
        try:
            lo, hi = (float(x) for x in args.edge.split(":"))
        except ValueError:
            ap.error(f"--edge: needs LO:HI in rad/s (got {args.edge!r})")
        if not 0 < lo < hi:
            ap.error(f"--edge: needs 0 < LO < HI (got {args.edge!r})")
        args.bracket = (lo, hi)
    return args


@dataclass(frozen=True)
class MeshPoint:
    """The reduced Floquet result of one mesh at a fixed number of modes per link."""

    elements: int
    dofs: int
    basis: int
    covered_rad_s: float
    max_abs: float
    growth_rate: float  # max Re s, 1/s
    frequencies: np.ndarray  # the lowest retained |Im s|, unwrapped by the engine, rad/s
    build_s: float  # model and link components
    solve_s: float  # median monodromy wall time
    doubled: tuple | None = None  # (basis, max|μ|, largest folded frequency change) at 2x the modes


def model_of(scene, elements: int, case: str):
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import with_elements

    return Model(with_elements(scene, elements), (case,))


def mesh_point(scene, elements: int, speed: float, modes: int, *, case: str = "full", retained: int = 4,
               tol: float = 1e-10, repeats: int = 1, double: bool = False) -> MeshPoint:
    """Floquet result of ``scene`` re-meshed to ``elements`` per link on the link-component
    basis of ``modes`` fixed-interface modes per link (and of 2·modes if ``double``)."""
    from fkev_slepc.periodic.components import link_components
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.settings import PeriodicSettings
    from fkev_slepc.periodic.system import PeriodicSystem
    from fkev_slepc.periodic.truncation import retained_frequencies

    t0 = time.perf_counter()
    model = model_of(scene, elements, case)
    comp = link_components(model)
    basis = comp.basis(modes)
    build = time.perf_counter() - t0
    times = []
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        res = floquet_multipliers(PeriodicSystem(model, speed, case, basis=basis),
                                  PeriodicSettings(reduce="none", monodromy_tol=tol))
        times.append(time.perf_counter() - t0)
    freq = retained_frequencies(res.exponents, retained)
    doubled = None
    if double:
        ref = floquet_multipliers(PeriodicSystem(model, speed, case, basis=comp.basis(2 * modes)),
                                  PeriodicSettings(reduce="none", monodromy_tol=tol))
        f2 = retained_frequencies(ref.exponents, retained)
        n = min(freq.size, f2.size)
        doubled = (ref.basis, ref.max_abs, float(np.max(np.abs(folded(freq[:n], speed) - folded(f2[:n], speed)))))
    return MeshPoint(elements, int(model.n_free), res.basis, basis.covered_rad_s, res.max_abs,
                     float(np.max(res.exponents.real)), freq, build, float(np.median(times)), doubled)


def convergence(points, speed: float):
    """(folded, changes, rates, predicted), each (n_mesh, r): the convergence table of the module
    docstring. folded: the folded frequencies of each mesh (``periodic.truncation.folded``);
    changes (n_mesh, r): |f_i - f_{i+1}| of the folded frequencies (NaN on the finest mesh);
    rates (n_mesh, r): log(Δ_{i-1}/Δ_i)/log(n_i/n_{i-1}) where n_i/n_{i-1} = n_{i+1}/n_i, else NaN;
    predicted (n_mesh, r): the order-4 Richardson prediction of f_i from the two meshes before it
    where the mesh ratio changes, else NaN."""
    r = min(p.frequencies.size for p in points)
    f = np.array([folded(p.frequencies[:r], speed) for p in points])
    n = np.array([p.elements for p in points], dtype=float)
    k = len(points)
    changes, rates, pred = (np.full((k, r), np.nan) for _ in range(3))
    changes[:-1] = np.abs(f[:-1] - f[1:])
    for i in range(1, k - 1):
        if np.isclose(n[i] / n[i - 1], n[i + 1] / n[i]):
            with np.errstate(divide="ignore", invalid="ignore"):
                rates[i] = np.log(changes[i - 1] / changes[i]) / np.log(n[i] / n[i - 1])
    for i in range(2, k):
        if not np.isclose(n[i] / n[i - 1], n[i - 1] / n[i - 2]):
            inf = f[i - 1] + (f[i - 1] - f[i - 2]) / ((n[i - 1] / n[i - 2]) ** ORDER - 1.0)
            pred[i] = inf + (f[i - 1] - inf) * (n[i - 1] / n[i]) ** ORDER
    return f, changes, rates, pred


def band_edge(scene, elements: int, modes: int, bracket, *, case: str = "full", tol: float = 1e-10,
              rtol: float = 1e-4):
    """(edge rad/s, evaluations, max|μ| at the bracket's ends) of the band edge in ``bracket``
    at ``elements`` per link and ``modes`` per link (NaN edge when the ends agree in verdict)."""
    from fkev_slepc.periodic.bands import SpeedPoint, brackets
    from fkev_slepc.periodic.edges import refine_edges
    from fkev_slepc.periodic.components import link_components
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.settings import PeriodicSettings
    from fkev_slepc.periodic.system import PeriodicSystem

    model = model_of(scene, elements, case)
    basis = link_components(model).basis(modes)
    count = [0]

    def evaluate(w):
        count[0] += 1
        return SpeedPoint.of(w, floquet_multipliers(PeriodicSystem(model, w, case, basis=basis),
                                                    PeriodicSettings(reduce="none", monodromy_tol=tol)))

    ends = [evaluate(w) for w in bracket]
    pairs = brackets(ends)
    if not pairs:
        return float("nan"), count[0], tuple(p.max_abs for p in ends)
    edges = refine_edges(ends, pairs, lambda ws: [evaluate(w) for w in ws], {}, rtol=rtol)
    return edges[pairs[0]], count[0], tuple(p.max_abs for p in ends)


def _row(cells) -> str:
    return "| " + " | ".join(cells) + " |"


def print_meshes(points, speed: float) -> None:
    head = ["el/link", "DOFs", "basis", "covered rad/s", "max abs(μ) - 1", "max Re s 1/s",
            "lowest Floquet frequencies (unwrapped) rad/s", "model+comp s", "monodromy s"]
    if points[0].doubled is not None:
        head[6:6] = ["2x modes: basis, max abs(μ) - 1, max Δf rad/s"]
    print(_row(head))
    print("|" + "---|" * len(head))
    for p in points:
        cells = [str(p.elements), str(p.dofs), str(p.basis), f"{p.covered_rad_s:.0f}", f"{p.max_abs - 1.0:.2e}",
                 f"{p.growth_rate:.3g}", ", ".join(f"{x:.4f}" for x in p.frequencies),
                 f"{p.build_s:.1f}", f"{p.solve_s:.1f}"]
        if p.doubled is not None:
            b, mu, df = p.doubled
            cells[6:6] = [f"{b}, {mu - 1.0:.2e}, {df:.1e}"]
        print(_row(cells))


def print_convergence(points, speed: float) -> None:
    f, changes, rates, pred = convergence(points, speed)
    r = f.shape[1]
    print(f"\nfolded Floquet frequencies f = |arg mu|·Omega/2pi (rad/s, Omega = {speed:g}), change to the next "
          "finer mesh, observed rate\n")
    head = ["el/link"] + [f"f{j + 1}" for j in range(r)] + [f"Δf{j + 1}" for j in range(r)] + [
        f"rate{j + 1}" for j in range(r)]
    print(_row(head))
    print("|" + "---|" * len(head))
    num = lambda v, fmt: "" if not np.isfinite(v) else format(v, fmt)  # noqa: E731
    for i, p in enumerate(points):
        print(_row([str(p.elements)] + [f"{x:.6f}" for x in f[i]] + [num(x, ".2e") for x in changes[i]]
                   + [num(x, ".2f") for x in rates[i]]))
    for i in np.flatnonzero(np.isfinite(pred[:, 0])):
        n = [points[j].elements for j in (i - 2, i - 1, i)]
        print(f"\n{n[2]} el/link against the order-4 Richardson prediction from {n[0]} and {n[1]}: measured - "
              "predicted " + ", ".join(f"{x:.1e}" for x in f[i] - pred[i]) + " rad/s; |f - f(" + str(n[1])
              + ")| measured " + ", ".join(f"{x:.2e}" for x in np.abs(f[i] - f[i - 1])) + ", predicted "
              + ", ".join(f"{x:.2e}" for x in np.abs(pred[i] - f[i - 1])))


def main(argv=None) -> None:
    args = parse_args(argv)
    from fkev_slepc.scene import load_scene

    scene = load_scene(benchlib.ROOT / SCENES.get(args.scene, args.scene))
    print(f"{scene.title}: {args.speed:g} rad/s, case {args.case}, link components with {args.modes} "
          f"fixed-interface mode(s) per link{' (and ' + str(2 * args.modes) + ')' if args.double else ''}, "
          f"tol {args.tol:g}, 1 BLAS thread, {args.repeats} repeat(s)")
    points = []
    for ne in args.meshes:
        points.append(mesh_point(scene, ne, args.speed, args.modes, case=args.case, retained=args.retained,
                                 tol=args.tol, repeats=args.repeats, double=args.double))
    print_meshes(points, args.speed)
    if len(points) > 1:
        print_convergence(points, args.speed)
    if args.bracket:
        lo, hi = args.bracket
        print(f"\nband edge in [{lo:g}, {hi:g}] rad/s to {args.edge_rtol:g} relative, {args.modes} mode(s) per link\n")
        print(_row(["el/link", "edge rad/s", "max abs(μ) at ends", "monodromies", "s"]))
        print("|---|---|---|---|---|")
        for ne in args.edge_meshes:
            t0 = time.perf_counter()
            w, count, ends = band_edge(scene, ne, args.modes, args.bracket, case=args.case, tol=args.tol,
                                       rtol=args.edge_rtol)
            print(_row([str(ne), f"{w:.6f}", ", ".join(f"{x:.6f}" for x in ends), str(count),
                        f"{time.perf_counter() - t0:.0f}"]), flush=True)


if __name__ == "__main__":
    main()
