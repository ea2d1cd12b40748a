#!/usr/bin/env python
"""The moving modal basis (``reduce="moving"``, docs/theory.md §18.10) against the mesh.

For each ``--elements`` N (per link) of ``--scene`` at ``--speed`` and ``--case``: the Floquet
multipliers on the moving basis, the cutoff doubled until converged (fkev_slepc/periodic/moving.py),
timed; its levels (r, max|μ| − 1), the last change and, for models up to ``--full-max`` DOFs, the
full model timed beside it (medians over ``--repeats``, the two alternated). docs/engine.md, "The
moving modal basis", quotes its output.

    .venv/bin/python scripts/bench_moving.py --elements 4,8,16 --full-max 36
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from fkev_slepc.model.operators import Model
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.scene import load_scene, with_elements

ROOT = Path(__file__).resolve().parents[1]


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=str(ROOT / "runs" / "bahgat-willmert-1976.toml"))
    p.add_argument("--elements", default="4,8,16", help="elements per link, comma-separated")
    p.add_argument("--speed", type=float, default=500.0, help="crank speed, rad/s")
    p.add_argument("--case", default="full")
    p.add_argument("--full-max", type=int, default=36, help="also time the full model up to this many DOFs")
    p.add_argument("--repeats", type=int, default=1)
    a = p.parse_args(argv)
    print("| el/link | DOFs | levels r | max|μ| - 1 | last change | seconds | full model |")
    print("|---|---|---|---|---|---|---|")
    for n in (int(x) for x in a.elements.split(",")):
        model = Model(with_elements(load_scene(a.scene), n))
        moving, full, tf, tm = None, None, [], []
        for _ in range(a.repeats):
            moving, t = timed(lambda: floquet_multipliers(PeriodicSystem(model, a.speed, a.case),
                                                          PeriodicSettings(reduce="moving")))
            tm.append(t)
            if model.n_free <= a.full_max:
                full, t = timed(lambda: floquet_multipliers(PeriodicSystem(model, a.speed, a.case),
                                                            PeriodicSettings(reduce="none")))
                tf.append(t)
        tr = moving.truncation
        ref = f"{full.max_abs - 1:.8g}, {statistics.median(tf):.1f} s" if full is not None else "not run"
        print(f"| {n} | {model.n_free} | {', '.join(str(lv[0]) for lv in tr.levels)} | {moving.max_abs - 1:.8g} | "
              f"{tr.max_abs:.2g}{'' if tr.converged else ' (not converged)'} | {statistics.median(tm):.1f} | {ref} |",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
