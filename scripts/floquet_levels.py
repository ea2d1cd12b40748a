#!/usr/bin/env python
"""The full model's monodromy at fixed Magnus step counts, level by level, and what changes
between levels: the sorted moduli |μ| and the lowest-frequency multipliers (what the step count is
decided on, fkev_slepc/periodic/floquet.py ``_step_measure``) against every multiplier matched
(the earlier rule). docs/engine.md "Step count".

    .venv/bin/python scripts/floquet_levels.py runs/bahgat-willmert-1976.toml --elements 4 --speed 500 \\
        --steps 1024,2048,4096,8192,16384
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy: one BLAS thread

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
import scipy.linalg as la  # noqa: E402

from fkev_slepc.model.operators import Model  # noqa: E402
from fkev_slepc.periodic.floquet import _unwrapped_exponents  # noqa: E402
from fkev_slepc.periodic.magnus import _product, match_multipliers  # noqa: E402
from fkev_slepc.periodic.system import PeriodicSystem  # noqa: E402
from fkev_slepc.scene import load_scene, with_elements  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--elements", type=int, default=0, help="elements per link (0: the scene's)")
    ap.add_argument("--speed", type=float, default=500.0, help="crank speed, rad/s")
    ap.add_argument("--case", default="full")
    ap.add_argument("--steps", default="2048,4096,8192,16384", help="step counts, increasing")
    args = ap.parse_args()
    scene = load_scene(args.scene)
    scene = with_elements(scene, args.elements) if args.elements > 0 else scene
    model = Model(scene, (args.case,))
    system = PeriodicSystem(model, args.speed, args.case)
    gen = system.interpolant().generator
    c = system.coefficients(np.array([system.start]))
    rho = float(np.max(np.abs(la.eigvals(gen.S[0]))))
    print(f"{model.n_free} DOFs, rho(A) = {rho:.6g}, stiff bound 2*2pi*rho = {2 * 2 * np.pi * rho:,.0f}")
    print("| steps | s | max|μ| | Δ sorted |μ| | Δ low multipliers | Δ every multiplier |")
    before = None
    for steps in (int(x) for x in args.steps.split(",")):
        t0 = time.perf_counter()
        mu, X = la.eig(_product(gen, 0.0, 2.0 * np.pi, steps, None, 6))
        with np.errstate(divide="ignore", invalid="ignore"):
            mu, s = _unwrapped_exponents(mu, X, c, system.dof_scaling, args.speed)
        dt = time.perf_counter() - t0
        cells = ["-"] * 3
        if before is not None:
            i, j = match_multipliers(mu, before)
            low = np.argsort(np.abs(s.imag))[:8]
            cells = [f"{np.max(np.abs(np.sort(np.abs(mu)) - np.sort(np.abs(before)))):.1e}",
                     f"{max(np.min(np.abs(mu[k] - before)) for k in low):.1e}",
                     f"{np.max(np.abs(mu[i] - before[j])):.1e}"]
        print(f"| {steps:,} | {dt:.1f} | {np.max(np.abs(mu)):.12f} | " + " | ".join(cells) + " |", flush=True)
        before = mu


if __name__ == "__main__":
    main()
