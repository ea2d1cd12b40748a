#!/usr/bin/env python
"""The periodic response of one crank speed against the Floquet multipliers of the same speed.

Per row SCENE:ELEMENTS:SPEED (SCENE bw, tm, sc or a path; ELEMENTS 0: the scene's mesh) the
response as ``fkev response`` computes it (fkev_slepc/periodic/steady.steady_solve: harmonic
balance doubled to ``--tol``, no shooting, ``reduce`` default: the full model up to
periodic.component_response.FULL_MAX_DOFS free DOFs, link components above) and
``floquet_multipliers`` as ``fkev floquet`` does (``reduce="default"``), timed alternately on the
same model, medians over ``--repeats``; the ratio response / Floquet, the method that gave the
response (harmonic balance, or shooting where the balance was abandoned:
fkev_slepc/periodic/response.py), the harmonics reached (with shooting: where the balance was
abandoned, and the Magnus steps) and the response's error estimate, as a markdown table. One BLAS
thread.

    .venv/bin/python scripts/bench_response.py
    .venv/bin/python scripts/bench_response.py --rows bw:1:500,sc:0:150 --repeats 1

``--floor``: where the response shot, also the least its shooting could cost at the step count N it
needed (the bare products of N and N/2 homogeneous step maps, timed beside), over the Floquet.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy: one BLAS thread, as one MPI rank has

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SCENES = {"bw": "runs/bahgat-willmert-1976.toml", "tm": "runs/turcic-midha-1984.toml",
          "sc": "runs/slider-crank-benchmark.toml"}
ROWS = "bw:1:500,bw:4:500,tm:0:60,sc:0:150"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", default=ROWS, help=f"SCENE:ELEMENTS:SPEED,... (default {ROWS})")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tol", type=float, default=1e-8, help="harmonic-balance tolerance (fkev response's default)")
    ap.add_argument("--floor", action="store_true", help="also the least the response's shooting could cost at its "
                    "step count N: the bare products of N and N/2 step maps of the homogeneous generator, over the Floquet")
    ap.add_argument("--reduce", default=None, help="the response's --reduce (default: its default)")
    args = ap.parse_args(argv)

    from fkev_slepc.model.operators import Model
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.settings import PeriodicSettings
    from fkev_slepc.periodic.system import PeriodicSystem
    from fkev_slepc.periodic.steady import steady_solve
    from fkev_slepc.scene import load_scene, with_elements

    print("| scene | DOFs | Ω (rad/s) | response (s) | method | harmonics | error | reduction | Floquet (s) | ratio |"
          + (" Floquet steps | shooting floor (s) | floor / Floquet |" if args.floor else ""))
    print("|---|---|---|---|---|---|---|---|---|---|" + ("---|---|---|" if args.floor else ""))
    for row in args.rows.split(","):
        name, elements, speed = row.split(":")
        scene = load_scene(ROOT / SCENES.get(name, name))
        if int(elements):
            scene = with_elements(scene, int(elements))
        model, w = Model(scene, cases=("full",)), float(speed)
        gravity = scene.analysis.gravity_m_s2
        t_resp, t_floq, t_floor = [], [], []
        for _ in range(args.repeats):
            t = time.perf_counter()
            r = steady_solve(model, w, "full", gravity, tol=args.tol, shoot=False, reduce=args.reduce)
            t_resp.append(time.perf_counter() - t)
            t = time.perf_counter()
            f = floquet_multipliers(PeriodicSystem(model, w, "full"), PeriodicSettings(reduce="default"))
            t_floq.append(time.perf_counter() - t)
            if args.floor and r.periodic is not None:
                t_floor.append(shooting_floor(model, w, r.periodic.steps))
        tr, tf = statistics.median(t_resp), statistics.median(t_floq)
        red = "none" if r.truncation is None else f"links:{r.truncation.modes_per_link}"
        method = "HB" if r.periodic is None else f"shooting, {r.periodic.steps} steps"
        print(f"| {name} {elements or 'scene'} | {model.n_free} | {w:g} | {tr:.2f} | {method} | "
              f"{r.hb.harmonics.shape[0] - 1} | {r.error:.1e} | {red} | {tf:.2f} | {tr / tf:.2f} |"
              + ("" if not args.floor else f" {f.monodromy.steps:,} | " + (
                  "- | - |" if not t_floor else f"{statistics.median(t_floor):.2f} | {statistics.median(t_floor) / tf:.2f} |")),
              flush=True)


def shooting_floor(model, w: float, steps: int) -> float:
    """Seconds of the bare ordered products of ``steps`` and ``steps``/2 Magnus step maps of the full
    model's interpolated homogeneous generator (periodic/magnus.py ``_product``): less than any shooting
    at that step count costs (it also carries the load's columns and solves for the periodic state)."""
    from fkev_slepc.periodic import magnus
    from fkev_slepc.periodic.system import PeriodicSystem

    gen = PeriodicSystem(model, w, "full").interpolant().generator
    t = time.perf_counter()
    for n in (steps, steps // 2):
        magnus._product(gen, 0.0, 2.0 * np.pi, n, None, 6)
    return time.perf_counter() - t


if __name__ == "__main__":
    main()
