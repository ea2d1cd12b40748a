"""``Study.floquet``: the cycle (Floquet) verdict over a speed range, its unstable bands and the
frozen-time critical speeds beside them (docs/stability.md, "Frozen-time and cycle verdicts")."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from fkev_slepc.api.point import critical_scan, out_of_plane_arguments
from fkev_slepc.api.pool import ModelPool
from fkev_slepc.model.plane import Plane
from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.scene import Problem, SceneError

API_NAMES = {"speeds": "speeds_rad_s", "speeds_rpm": "speeds_rpm", "angles": "angles_deg", "cases": "case",
             "modes": "modes", "element": "element", "rel_error": "rel_error", "tol": "tol", "rtol": "rtol",
             "monodromy_tol": "monodromy_tol", "output": "output", "resonance_order": "resonance_order", "reduce": "reduce",
             "plane": "plane", "zeta_floor": "zeta_floor"}
SETTING_NAMES = {"verdict_tol": "tol", "edge_rtol": "rtol", "monodromy_tol": "monodromy_tol",
                 "resonance_order": "resonance_order", "reduce": "reduce",
                 "zeta_floor": "zeta_floor"}  # settings field -> key of ``names``
MAX_MAGNUS_STEPS = DEFAULTS.max_steps  # full-model Magnus steps of one monodromy (docs/engine.md, "Work limits")


def work_problems(scene, case: str, reduce, names: dict, pool=None,
                  max_steps: int = MAX_MAGNUS_STEPS, plane: str = "in") -> list[Problem]:
    """Before any work: operators that overflow double precision at the top speed
    (:func:`fkev_slepc.solve.finite.overflow_problems`), and the work of the full-model monodromy at
    the lowest speed, 2·2π·ρ(A) Magnus steps (:func:`~fkev_slepc.periodic.floquet.full_min_steps`,
    growing like 1/Ω) on a state of 2n, beyond :data:`MAX_MAGNUS_STEPS` (not checked for a fixed
    basis ``reduce`` = r, whose steps are the reduced model's), with the estimate and the ways out.
    ``pool``: the :class:`~fkev_slepc.api.pool.ModelPool` of ``scene`` that gives the model (default a new one);
    ``max_steps``: the limit (``PeriodicSettings.max_steps``); ``plane``: the plane whose model is run
    ("in" or "out"), the one whose steps are estimated."""
    from fkev_slepc.solve.finite import overflow_problems
    from fkev_slepc.periodic.floquet import full_min_steps

    with np.errstate(all="ignore"):  # an overflow is the finding of overflow_problems, not a warning
        model = (ModelPool(scene) if pool is None else pool).model(case, plane)  # its terms include the structure's
    bad = [Problem(names["speeds"] if p.path == "driver.speeds" else p.path, p.message)
           for p in overflow_problems(scene, model)]
    if bad or isinstance(reduce, int):
        return bad
    low = float(np.min(scene.driver.speeds))
    with np.errstate(all="ignore"):
        try:
            steps = float(full_min_steps(model, low, case))
        except (OverflowError, ValueError, np.linalg.LinAlgError):
            steps = float("inf")
    if not steps <= max_steps:
        n = 2 * model.n_free
        return [Problem(names["speeds"], f"{low:g} rad/s needs about {steps:.3g} Magnus steps per monodromy on a state "
                        f"of {n} (work ~ steps x state² = {steps * n * n:.2g}), beyond the limit of {max_steps:,} "
                        "steps (docs/engine.md, \"Work limits\"): the steps grow like 1/speed and with the highest "
                        "frequency: use higher speeds, fewer --elements, less stiffness-proportional damping, or "
                        "--reduce N")]
    return []


def study_floquet(study, speeds_rad_s=None, case="full", output=None, *, speeds_rpm=None, angles_deg=None,
                  resume: bool = False,
                  force: bool = False, tol: float | None = None, rtol: float | None = None,
                  monodromy_tol: float | None = None, resonance_order: int | None = None, probe: bool | None = None,
                  solver: str | None = None, comm=None, critical: bool = True, names: dict = API_NAMES,
                  command_line: str = "", notify=None, progress: bool = False, reduce=None, plane: str = "in",
                  settings=None, zeta_floor: float | None = None):
    """The body of :meth:`fkev_slepc.api.study.Study.floquet` (see there); ``names`` says how
    messages name the arguments (the CLI passes its flags); ``speeds_rpm`` the speeds in rev/min
    instead of ``speeds_rad_s``. ``reduce``: the reduction of each
    monodromy, "auto", "none", r frozen modes per angle, "links", "links:N" (link-frame component
    modes) or "default" (per speed, :func:`fkev_slepc.periodic.floquet.default_reduction`;
    :func:`fkev_slepc.periodic.truncation.resolve_reduce`).
    ``plane``: "out" for the out-of-plane problem (docs/theory.md §19.9; archive ``<stem>-out-floquet.h5``).
    ``settings``: every periodic tolerance (:class:`~fkev_slepc.periodic.settings.PeriodicSettings`, default
    its defaults, ``reduce`` "default"); ``tol``, ``rtol``, ``monodromy_tol``, ``resonance_order``, ``probe``
    and ``reduce``, when given, override its verdict_tol, edge_rtol, monodromy_tol, resonance_order, probe
    and reduce; ``zeta_floor`` its zeta_floor (an undamped scene's bands listed as surviving real damping
    where their ζ* exceeds it; docs/stability.md). The result is archived whole (``/floquet/settings``) and compared whole on ``resume``."""
    from fkev_slepc.model.operating_point import full_turn_problems
    from fkev_slepc.scene.cases import case_name
    from fkev_slepc.periodic.settings import checked_settings
    from fkev_slepc.periodic.truncation import resolve_reduce
    from fkev_slepc.sweep.floquet_run import FloquetRequest, read_floquet, run_floquet
    from fkev_slepc.sweep.grid import configure
    from fkev_slepc.sweep.parallel import local
    from fkev_slepc.sweep.session import default_output

    sc = study.scene
    bad = []
    try:
        case = case_name(case)
    except ValueError as err:
        bad.append(Problem(names["cases"], str(err)))
    if sc.driver.acceleration != 0.0:
        bad.append(Problem("driver.acceleration_rad_s2", "the Floquet analysis needs a constant crank speed "
                           f"(got {sc.driver.acceleration:g} rad/s²)"))
    bad += full_turn_problems(sc)
    st = checked_settings(sc.source, settings, dict(verdict_tol=tol, edge_rtol=rtol, monodromy_tol=monodromy_tol,
                                             resonance_order=resonance_order, probe=probe, reduce=reduce,
                                             zeta_floor=zeta_floor),
                          {field: names[key] for field, key in SETTING_NAMES.items() if key in names}, bad)
    reduce = resolve_reduce(st.reduce)
    try:
        out_of_plane_arguments(sc, plane, None)
    except SceneError as err:
        raise SceneError(err.source, [Problem(names["plane"] if p.path == "plane" else p.path, p.message)
                                      for p in err.problems]) from None
    scene = configure(sc, angles=angles_deg, speeds=speeds_rad_s, speeds_rpm=speeds_rpm, cases=[case], names=names)
    speeds = np.asarray(scene.driver.speeds, dtype=float)
    if not np.all(speeds > 0):
        raise SceneError(sc.source, [Problem(names["speeds"], "Floquet speeds must be > 0 rad/s (at rest the frozen "
                                             f"verdict is exact; use fkev point) (got {', '.join(f'{w:g}' for w in speeds)})")])
    pool = study.pool.for_scene(scene)  # the study's models, on this grid
    problems = work_problems(scene, case, reduce, names, pool, st.max_steps, plane)
    if problems:
        raise SceneError(sc.source, problems)
    if output is None:
        if study.path is None:
            raise SceneError(sc.source, [Problem(names["output"], "required for a study made from text")])
        stem = Path(study.path).stem + Plane.parse(plane).suffix
        output = default_output(study.path).with_name(stem + "-floquet.h5")
    request = FloquetRequest(scene, Path(output), settings=st, resume=resume, force=force,
                             solver=solver, command_line=command_line, plane=plane, model=pool.model(case, plane))
    comm = local(comm)
    out = run_floquet(request, comm, notify=notify, progress=progress)
    res = read_floquet(out)
    if critical and comm.rank == 0:
        res = replace(res, extras={"frozen_time_critical": _frozen_critical(pool, case, speeds, solver, plane)})
    return res


def _frozen_critical(pool, case, speeds, solver, plane="in") -> dict:
    """The lowest frozen-time divergence and flutter speeds over the frozen sweep's crank angles
    (those of ``pool.scene``), up to the top Floquet speed (solve/critical.py), with what they are."""
    scan = critical_scan(pool, case, None, float(speeds.max()), None, solver, plane)
    d = scan.as_dict()
    return {"divergence_speed_rad_s": d["divergence_speed_rad_s"], "divergence_angle_deg": d["divergence_angle_deg"],
            "flutter_speed_rad_s": d["flutter_speed_rad_s"], "flutter_angle_deg": d["flutter_angle_deg"],
            "max_speed_rad_s": float(speeds.max()),
            "time": "frozen-time: lowest over the crank angles of the frozen sweep (fkev critical)"}
