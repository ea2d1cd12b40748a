#!/usr/bin/env python
"""Operator pieces per crank angle: one vectorised call over many angles against the scalar call.

For every mesh (``--elements``) and BLAS thread setting (``--threads``: ``1`` sets
OPENBLAS_NUM_THREADS=OMP_NUM_THREADS=1, ``default`` leaves OpenBLAS its own choice) a child
process builds the model with every case's terms and times, alternately in each repeat:

* vectorised: ``Model.piece_stack(θ)`` for all ``--angles`` angles of a revolution in one call;
* scalar: ``Model.pieces(θ)`` angle by angle (what the per-point consumers call);
* loads: ``Model.load_pieces(θ)`` for all angles in one call.

It prints milliseconds per angle (medians of the repeats) side by side, and the median of the
per-repeat ratios scalar / vectorised. Before timing, every row of the stack is checked equal to
the scalar pieces of its angle. ``--baseline DIR`` adds a column: the scalar call of another
checkout's package (e.g. an export of the commit before the vectorised path), timed in the same
child, alternately with the others.

    PYTHONPATH=$PWD .venv/bin/python scripts/bench_pieces.py
    PYTHONPATH=$PWD .venv/bin/python scripts/bench_pieces.py --elements 5,50 --baseline /tmp/fkev-before
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import benchlib

ANGLES, REPEATS = 360, 7
THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="runs/bahgat-willmert-1976.toml")
    ap.add_argument("--elements", default="5", help="elements per link, comma-separated meshes (default 5)")
    ap.add_argument("--angles", type=int, default=ANGLES, help="angles over one revolution (default 360)")
    ap.add_argument("--repeats", type=int, default=REPEATS)
    ap.add_argument("--threads", default="1,default", help="BLAS thread settings to compare (default 1,default)")
    ap.add_argument("--baseline", help="directory holding another fkev_slepc package: time its scalar call too")
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    return ap.parse_args(argv)


def child(args) -> dict:
    """Time the three calls on one mesh in this process (BLAS threads fixed by the parent)."""
    import numpy as np

    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.scene.cases import CASE_NAMES

    scene = with_elements(load_scene(benchlib.ROOT / args.scene), args.child)
    model = Model(scene, cases=CASE_NAMES)
    theta = np.linspace(0.0, 2 * np.pi, args.angles, endpoint=False)
    stack = model.piece_stack(theta)
    theta = theta[stack.ok]  # angles at which the linkage assembles
    stack = model.piece_stack(theta)
    for i in (0, theta.size // 2, theta.size - 1):
        one = model.pieces(theta[i])
        for name in ("mass", "structural", "coriolis", "normal"):
            assert np.array_equal(getattr(stack, name)[i], getattr(one, name)), name
        assert np.array_equal(stack.pseudo_normal[0][i], one.pseudo_normal[0])
    calls = {"vectorised": lambda: model.piece_stack(theta),
             "scalar": lambda: [model.pieces(t) for t in theta],
             "loads": lambda: model.load_pieces(theta)}
    if args.baseline:
        calls["baseline"] = baseline_call(args.baseline, args.scene, args.child, theta)
    times = {k: [] for k in calls}
    for _ in range(args.repeats):
        for name, call in calls.items():
            t = time.perf_counter()
            call()
            times[name].append((time.perf_counter() - t) / theta.size)
    ratios = [s / v for s, v in zip(times["scalar"], times["vectorised"])]
    out = {k: float(np.median(v)) for k, v in times.items()}
    out.update(n_free=model.n_free, n_angles=int(theta.size), ratio=float(np.median(ratios)))
    if args.baseline:
        out["baseline_ratio"] = float(np.median([b / v for b, v in zip(times["baseline"], times["vectorised"])]))
    return out


def baseline_call(path: str, scene: str, elements: int, theta):
    """The scalar ``Model(scene).pieces(θ)`` loop of the package under ``path`` (imported under
    its own name while this checkout's modules are set aside)."""
    saved = {k: m for k, m in sys.modules.items() if k == "fkev_slepc" or k.startswith("fkev_slepc.")}
    for k in saved:
        del sys.modules[k]
    sys.path.insert(0, path)
    try:
        from fkev_slepc.model.operators import Model as Old
        from fkev_slepc.scene.cases import CASE_NAMES
        from fkev_slepc.scene import load_scene, with_elements

        old = Old(with_elements(load_scene(benchlib.ROOT / scene), elements), cases=CASE_NAMES)
    finally:
        sys.path.remove(path)
        for k in [k for k in sys.modules if k == "fkev_slepc" or k.startswith("fkev_slepc.")]:
            del sys.modules[k]
        sys.modules.update(saved)
    return lambda: [old.pieces(t) for t in theta]


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.child:
        print(json.dumps(child(args)))
        return 0
    meshes = [int(v) for v in args.elements.split(",")]
    settings = args.threads.split(",")
    print(f"{args.scene}, {args.angles} angles of a revolution, all six cases' terms; "
          f"ms per angle, medians of {args.repeats} repeats")
    head = f"{'el/link':>7} {'n_free':>6} {'BLAS threads':>12} {'vectorised':>10} {'scalar':>8} {'scalar/vect':>11}"
    head += f" {'loads':>7}" + (f" {'baseline':>8} {'base/vect':>9}" if args.baseline else "")
    print(head)
    for n in meshes:
        for threads in settings:
            env = {k: v for k, v in os.environ.items() if k not in THREAD_VARS}
            if threads != "default":
                env.update({k: threads for k in THREAD_VARS})
            cmd = [sys.executable, __file__, "--child", str(n), "--scene", args.scene, "--angles", str(args.angles),
                   "--repeats", str(args.repeats)] + (["--baseline", args.baseline] if args.baseline else [])
            res = json.loads(subprocess.run(cmd, env=env, check=True, capture_output=True, text=True).stdout)
            row = (f"{n:>7} {res['n_free']:>6} {threads:>12} {1e3 * res['vectorised']:>10.4f} "
                   f"{1e3 * res['scalar']:>8.4f} {res['ratio']:>11.1f} {1e3 * res['loads']:>7.4f}")
            if args.baseline:
                row += f" {1e3 * res['baseline']:>8.4f} {res['baseline_ratio']:>9.1f}"
            print(row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
