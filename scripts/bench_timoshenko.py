#!/usr/bin/env python
"""A frozen point on the Timoshenko element against the thesis element (issue 42, docs/engine.md).

The Bahgat-Willmert four-bar (runs/bahgat-willmert-1976.toml) re-meshed to about N elements
(N/3 per link), with G = E/2(1 + 0.3) and κ = 5/6 on every link; one frozen point (θ = 30°, the
scene's highest speed, case full, 4 modes, the SLEPc engine): model build, operator pieces, QEP
and solve, timed alternately thesis/timoshenko (same machine load), medians over the repeats.

    .venv/bin/python scripts/bench_timoshenko.py
    .venv/bin/python scripts/bench_timoshenko.py --sizes 500 5000 --repeats 5
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.solve.slepc import SlepcEngine

SCENE = Path(__file__).resolve().parent.parent / "runs" / "bahgat-willmert-1976.toml"


def scene_for(n_total: int, element: str):
    sc = with_elements(load_scene(SCENE), max(1, n_total // 3))
    links = tuple(dataclasses.replace(lk, shear_modulus=lk.youngs_modulus / 2.6, shear_coefficient=5 / 6,
                                      segments=()) for lk in sc.links)
    return dataclasses.replace(sc, links=links, analysis=dataclasses.replace(sc.analysis, element=element))


def one_point(scene) -> tuple[float, np.ndarray]:
    t0 = time.perf_counter()
    model = Model(scene)
    speed = max(scene.driver.speeds, key=abs)
    q = model.qep(model.pieces(np.radians(30.0)), speed, "full", None)
    res = SlepcEngine().solve(q, 4)
    return time.perf_counter() - t0, res


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[500, 5000])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    print(f"{'elements':>9} {'thesis [s]':>11} {'timoshenko [s]':>15} {'ratio':>7}")
    for n in args.sizes:
        scenes = {e: scene_for(n, e) for e in ("thesis", "timoshenko")}
        times = {e: [] for e in scenes}
        for _ in range(args.repeats):
            for e, sc in scenes.items():
                times[e].append(one_point(sc)[0])
        t, s = np.median(times["thesis"]), np.median(times["timoshenko"])
        print(f"{n:>9} {t:>11.4f} {s:>15.4f} {s / t:>7.3f}")


if __name__ == "__main__":
    main()
