#!/usr/bin/env python
"""The run-up benchmark of issue 38: Bahgat–Willmert from rest to ``--to`` rad/s in ``--duration`` s of
machine time (a linear ramp), integrated by TSALPHA2 (fkev_slepc/periodic/runup.py) at ``--elements``
per link, full model or ``--reduce``; the wall time of the build (the interpolated coefficients) and of
the integration. ``--fraction F`` integrates only the first F of the ramp's steps and extrapolates the
whole by the steps (the cost of a step does not depend on where it is). docs/runup.md quotes its output.

    .venv/bin/python scripts/bench_runup.py --elements 4
    .venv/bin/python scripts/bench_runup.py --elements 111 --reduce links:2 --fraction 0.1
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one BLAS thread, as the command line (fkev_slepc/_threads.py)

import numpy as np  # noqa: E402

from fkev_slepc.model.operators import Model  # noqa: E402
from fkev_slepc.periodic.motion import CrankHistory, MotionSystem, runup_basis, runup_reduction  # noqa: E402
from fkev_slepc.periodic.runup import Integration  # noqa: E402
from fkev_slepc.scene import load_scene, with_elements  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=str(ROOT / "runs" / "bahgat-willmert-1976.toml"))
    p.add_argument("--elements", type=int, default=4, help="elements per link")
    p.add_argument("--to", type=float, default=1000.0, help="final crank speed, rad/s (from 0)")
    p.add_argument("--duration", type=float, default=2.0, help="ramp duration, s")
    p.add_argument("--steps-per-revolution", type=int, default=256)
    p.add_argument("--reduce", default=None)
    p.add_argument("--case", default="full")
    p.add_argument("--fraction", type=float, default=1.0, help="integrate this share of the steps, extrapolate")
    a = p.parse_args(argv)
    scene = with_elements(load_scene(a.scene), a.elements)
    t0 = time.perf_counter()
    model = Model(scene, (a.case,))
    basis = runup_basis(model, runup_reduction(a.reduce), a.case, a.to)
    system = MotionSystem(model, a.case, basis=basis, gravity=scene.analysis.gravity_m_s2)
    t1 = time.perf_counter()
    history = CrankHistory.ramp(0.0, a.to, a.duration)
    run = Integration(system, history, steps_per_revolution=a.steps_per_revolution)
    steps = max(1, int(round(a.fraction * run.total)))
    run.advance(steps)
    t2 = time.perf_counter()
    per = (t2 - t1) / run.steps
    print(f"{scene.title}: {model.n_free} DOFs, {system.n} coordinates ({a.reduce or 'none'}), case {a.case}")
    print(f"  build {t1 - t0:.2f} s (interpolant: {system.samples} angles, error {system.error:.1e})")
    print(f"  ramp 0 -> {a.to:g} rad/s in {a.duration:g} s: {run.total} steps of {run.dt:.3e} s; ran {run.steps} "
          f"({run.steps / run.total:.0%}) in {t2 - t1:.2f} s, {1e3 * per:.3f} ms/step")
    print(f"  whole ramp: {t1 - t0 + per * run.total:.1f} s (measured{'' if run.steps == run.total else ', extrapolated'})")
    q = system.expand([history.angle(run.t)], [run.state[0]])[0]
    print(f"  at t = {run.t:.4g} s, Ω = {history.speed(run.t):.5g} rad/s: max |q| = {np.max(np.abs(q)):.3e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
