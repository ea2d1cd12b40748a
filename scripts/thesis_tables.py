#!/usr/bin/env python
"""Print the thesis verification tables (markdown) recorded in runs/README.md.

    .venv/bin/python scripts/thesis_tables.py

1. Turcic & Midha (Table 3.2), case `structure`, Ω = 0: first three frequencies over a full
   cycle for the 3-, 6- and 9-element models (thesis Figs 3.2-3.4; claim C2).
2. Bahgat & Willmert (Table 3.3), θ = 10°: first four frequencies for Ω = 0, 500, 1000 rad/s in
   all six cases, and the percentage errors of cases 2-5 against the full solution (§12, §16).
3. Convergence of the 5-element Bahgat-Willmert model against a refined one (claim C1).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

from fkev_slepc.scene.cases import CASE_NAMES  # noqa: E402
from fkev_slepc.solve.dense import DenseEngine  # noqa: E402
from fkev_slepc.solve.modes import percent_error, postprocess  # noqa: E402
from fkev_slepc.model.operators import Model  # noqa: E402
from fkev_slepc.scene import load_scene, with_elements  # noqa: E402


def solve(model, theta_deg, omega, case, n):
    q = model.qep(model.pieces(np.radians(theta_deg)), omega, case)
    return postprocess(DenseEngine().solve(q, n), n)


def turcic_midha() -> None:
    scene = load_scene(ROOT / "runs/turcic-midha-1984.toml")
    models = {n: Model(with_elements(scene, n), cases=("structure",)) for n in (1, 2, 3)}
    print("### Turcic–Midha, case `structure`, Ω = 0: f₁, f₂, f₃ [Hz]\n")
    print("| θ [deg] | " + " | ".join(f"{3*n} el. f{k}" for n in models for k in (1, 2, 3)) + " |")
    print("|---:|" + "---:|" * 9)
    allf = {n: [] for n in models}
    for theta in range(0, 361, 30):
        row = []
        for n, m in models.items():
            f = solve(m, theta, 0.0, "structure", 3).frequency_hz
            allf[n].append(f)
            row += [f"{v:.1f}" for v in f]
        print(f"| {theta} | " + " | ".join(row) + " |")
    full = {n: np.array([solve(m, t, 0.0, "structure", 3).frequency_hz for t in range(0, 360, 5)]) for n, m in models.items()}
    print("\nOver the full cycle (5° steps): min–max [Hz] and largest change vs the 9-element model\n")
    print("| model | f₁ | f₂ | f₃ | max |f−f₉|/f₉ (f₁, f₂, f₃) |")
    print("|---|---|---|---|---|")
    for n, f in full.items():
        d = np.abs(f / full[3] - 1).max(axis=0)
        rng = " | ".join(f"{f[:, k].min():.1f}–{f[:, k].max():.1f}" for k in range(3))
        print(f"| {3*n} elements | {rng} | {', '.join(f'{v:.2%}' for v in d)} |")


def bahgat_willmert() -> None:
    scene = load_scene(ROOT / "runs/bahgat-willmert-1976.toml")
    model = Model(scene, cases=CASE_NAMES)
    print("\n### Bahgat–Willmert, θ = 10°, 5 elements: f₁…f₄ [Hz] and error vs `full` [%]\n")
    print("| Ω [rad/s] | case | f₁ | f₂ | f₃ | f₄ | e₁ | e₂ | e₃ | e₄ | max Re λ [1/s] | status |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    p = model.pieces(np.radians(10.0))
    w10 = None
    for omega in (0.0, 500.0, 1000.0):
        res = {c: postprocess(DenseEngine().solve(model.qep(p, omega, c), 4), 4) for c in CASE_NAMES}
        w10 = w10 or 2 * np.pi * res["structure"].frequency_hz[0]
        for c, r in res.items():
            e = percent_error(r.frequency_hz, res["full"].frequency_hz)
            es = ["" if c in ("structure", "full") else f"{v:+.2f}" for v in e]
            print(f"| {omega:g} | {c} | " + " | ".join(f"{v:.2f}" for v in r.frequency_hz)
                  + " | " + " | ".join(es) + f" | {r.max_real:.3g} | {r.status.value} |")
    print(f"\nω₁⁰ = {w10:.1f} rad/s, so α = Ω/ω₁⁰ = {1000 / w10:.3f} at 1000 rad/s and {500 / w10:.3f} at 500 rad/s.")
    r1 = postprocess(DenseEngine().solve(model.qep(p, 1000.0, "full"), 4), 4).frequency_hz[0]
    r4 = postprocess(DenseEngine().solve(model.qep(p, 1000.0, "no_normal"), 4), 4).frequency_hz[0]
    print(f"C6 (normal neglected, θ = 10°, Ω = 1000): e₁ = {(r4 - r1) / r1:+.2%}; "
          f"gap in frequency parameter (ω₁⁴ − ω₁¹)/ω₁⁰ = {(r4 - r1) * 2 * np.pi / w10:+.2%} (thesis: ≈ 8.5 %)")


def convergence() -> None:
    scene = load_scene(ROOT / "runs/bahgat-willmert-1976.toml")
    print("\n### Claim C1: 5-element model vs refined models (θ = 10°, Ω = 1000 rad/s, `full`)\n")
    print("| elements (crank, coupler, follower) | f₁ | f₂ | f₃ | f₄ |")
    print("|---|---:|---:|---:|---:|")
    ref = None
    for n in ((1, 2, 2), (2, 4, 4), (4, 8, 8), (8, 16, 16)):
        m = Model(with_elements(scene, n), cases=("full",))
        f = solve(m, 10.0, 1000.0, "full", 4).frequency_hz
        ref = f if n == (8, 16, 16) else ref
        print(f"| {n} | " + " | ".join(f"{v:.2f}" for v in f) + " |")
    f5 = solve(Model(scene, cases=("full",)), 10.0, 1000.0, "full", 4).frequency_hz
    print(f"\n5-element error vs (8, 16, 16): {', '.join(f'{v:+.3%}' for v in f5 / ref - 1)}")


if __name__ == "__main__":
    what = sys.argv[1:] or ["turcic-midha", "bahgat-willmert", "convergence"]
    for w in what:
        {"turcic-midha": turcic_midha, "bahgat-willmert": bahgat_willmert, "convergence": convergence}[w]()
