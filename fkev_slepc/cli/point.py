"""``fkev point``: frequencies, eigenvalues and stability at one operating point."""

from __future__ import annotations

import json
import sys

import numpy as np

from fkev_slepc.scene.cases import case_name
from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.status import CONVERGED, EXIT_NOT_CONVERGED, EXIT_OK
from .common import (
    RAD_S_PER_RPM, add_accuracy_arguments, add_elements_argument, apply_element, load_checked, modes_problem,
    report_scene_error, scene_uses_rpm, transmission_warning, with_rpm,
)


def add_parser(sub) -> None:
    p = sub.add_parser("point", help="solve one operating point (angle, speed, case)",
                       description="Natural frequencies and stability at one crank angle, speed and case.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--angle", type=float, help="crank angle, deg (default: the scene's first)")
    speed = p.add_mutually_exclusive_group()
    speed.add_argument("--speed", type=float, help="crank speed, rad/s (default: the scene's first)")
    speed.add_argument("--speed-rpm", type=float, metavar="RPM", help="crank speed, rev/min")
    p.add_argument("--case", help="case name or Table 3.1 number (default: the scene's first)")
    p.add_argument("--modes", type=int, help="number of modes (default: the scene's)")
    add_elements_argument(p)
    add_accuracy_arguments(p)
    p.add_argument("--solver", choices=("auto", "slepc", "dense"), help="eigen-solver (default: the scene's)")
    p.add_argument("--cross-check", action="store_true", help="solve with SLEPc and dense QZ and compare")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args) -> int:
    from fkev_slepc.solve.engines import cross_check, make_engine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.model.operators import Model

    try:
        scene = load_checked(args.scene, args.elements, check_angles=False)  # only --angle matters
        case = case_name(args.case) if args.case is not None else scene.analysis.cases[0]
    except SceneError as err:
        return report_scene_error(err)
    except ValueError as err:
        return report_scene_error(SceneError(args.scene, [Problem("--case", str(err))]))
    angle = scene.analysis.crank_angles_deg[0] if args.angle is None else args.angle
    speed = scene.driver.speeds[0] if args.speed is None else args.speed
    if args.speed_rpm is not None:
        speed = args.speed_rpm * RAD_S_PER_RPM
    rpm = args.speed_rpm is not None or (args.speed is None and scene_uses_rpm(scene.source_text))
    n_modes = scene.analysis.modes if args.modes is None else args.modes
    bad = []
    if n_modes < 1:
        bad.append(Problem("--modes", f"must be >= 1 (got {n_modes})"))
    if not np.isfinite(angle):
        bad.append(Problem("--angle", f"must be finite (got {angle})"))
    if not np.isfinite(speed):
        bad.append(Problem("--speed-rpm" if args.speed_rpm is not None else "--speed", f"must be finite (got {speed})"))
    if bad:
        return report_scene_error(SceneError(args.scene, bad))
    scene = apply_element(scene, args.element)
    model = Model(scene, cases=(case,))
    too_many = modes_problem(n_modes, model.n_free, "--modes" if args.modes is not None else None)
    if too_many:
        return report_scene_error(SceneError(args.scene, [too_many]))
    try:
        pieces = model.pieces(np.radians(angle))
    except ValueError as err:
        return report_scene_error(SceneError(args.scene, [Problem("--angle", f"{err} (got {angle:g})")]))
    rel_error = scene.analysis.rel_error if args.rel_error is None else args.rel_error
    plan = None
    if rel_error is not None:  # re-mesh for the requested accuracy (solve/accuracy.py)
        from fkev_slepc.solve.accuracy import planned_scene

        try:
            scene, plan = planned_scene(scene, [(angle, speed, case)], n_modes, rel_error, args.solver or scene.solver.method)
        except ValueError as err:
            return report_scene_error(SceneError(args.scene, [Problem("--rel-error", str(err))]))
        model = Model(scene, cases=(case,))
        pieces = model.pieces(np.radians(angle))
    qep = model.qep(pieces, speed, case)
    mu = transmission_warning(model, np.radians(angle))
    method = args.solver or scene.solver.method
    try:
        engine = make_engine(method, model.n_free, scene.solver.petsc)
    except SceneError as err:  # e.g. a PETSc option the solver rejects
        return report_scene_error(err)
    sol = engine.solve(qep, n_modes)
    res = postprocess(sol, n_modes, scene.analysis.imag_tol, scene.analysis.stability_tol)
    out = {
        "scene": scene.title, "angle_deg": angle, "speed_rad_s": speed,
        "speed_rpm": speed / RAD_S_PER_RPM if rpm else None, "case": case,
        "n_free": model.n_free, "kind": qep.kind, "solver": sol.solver,
        "frequency_hz": _nan_to_none(res.frequency_hz),
        "eigenvalue": [[_f(z.real), _f(z.imag)] for z in res.eigenvalue],
        "residual": _nan_to_none(res.residual),
        "max_real": _f(res.max_real), "divergent": [float(v) for v in res.divergent],
        "status": res.status.value, "message": res.message, "transmission_angle_deg": _f(mu),
        "element": scene.analysis.element, "elements": [lk.elements for lk in scene.links],
    }  # fmt: skip
    if plan is not None:
        out["rel_error_estimate"] = plan.predicted_error
        out["accuracy"] = plan.summary()
    if args.cross_check:
        out["cross_check_max_rel_diff"] = cross_check(qep, n_modes, scene.solver.petsc)
    engine.close()
    if args.json:
        json.dump(out, sys.stdout, indent=1)
        print()
    else:
        _print_table(out)
    return EXIT_OK if res.status in CONVERGED else EXIT_NOT_CONVERGED


def _f(v):
    return None if not np.isfinite(v) else float(v)


def _nan_to_none(a):
    return [_f(v) for v in np.asarray(a, dtype=float)]


def _print_table(o: dict) -> None:
    print(f"{o['scene']}: θ = {o['angle_deg']:g}°, Ω = {with_rpm(o['speed_rad_s'], o['speed_rpm'] is not None)}, "
          f"case {o['case']}, "
          f"{o['n_free']} DOFs, {o['kind']} problem, solver {o['solver']}")
    print(f"{'mode':>4} {'f [Hz]':>14} {'Re λ [1/s]':>14} {'Im λ [1/s]':>14} {'residual':>10}")
    for i, (f, (re, im), r) in enumerate(zip(o["frequency_hz"], o["eigenvalue"], o["residual"]), 1):
        fmt = lambda v, w: f"{v:{w}.6g}" if v is not None else f"{'—':>{w}}"  # noqa: E731
        print(f"{i:>4} {fmt(f, 14)} {fmt(re, 14)} {fmt(im, 14)} {fmt(r, 10) if r is None else f'{r:10.1e}'}")
    print(f"max Re λ = {o['max_real']!r} 1/s; status: {o['status']}"
          + (f"; divergent (real) eigenvalues: {o['divergent']}" if o["divergent"] else "")
          + (f" ({o['message']})" if o["message"] else ""))
    if "rel_error_estimate" in o:
        a = o["accuracy"]
        print(f"requested rel_error {a['rel_error']:g}: element {a['element']}, {a['elements_per_link']} elements per "
              f"link, estimated max relative error {o['rel_error_estimate']:.1e}")
    if "cross_check_max_rel_diff" in o:
        print(f"cross-check SLEPc vs dense: max relative frequency difference {o['cross_check_max_rel_diff']:.2e}")
