"""The bodies of :meth:`Study.point <fkev_slepc.api.study.Study.point>` and
:meth:`Study.critical <fkev_slepc.api.study.Study.critical>`: arguments checked once
(:mod:`fkev_slepc.api.checks`), models and engines taken from the study's
:class:`~fkev_slepc.api.pool.ModelPool`, and plain results."""

from __future__ import annotations

import weakref

import numpy as np

from fkev_slepc.api.checks import modes_fit, point_arguments
from fkev_slepc.api.results import PointResult
from fkev_slepc.archive.reader import NodeDofMap
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.scene.validity import OUT_OF_PLANE_THESIS, in_plane_only
from fkev_slepc.solve import modes as _modes
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.operators import AssemblyError, Model
from fkev_slepc.model.out_of_plane import section_of
from fkev_slepc.model.plane import BY_NAME, unknown_plane
from fkev_slepc.solve.accuracy import planned_scene
from fkev_slepc.solve.critical import DEFAULT_MAX_FACTOR, scan
from fkev_slepc.solve.engines import cross_check as _cross_check
from fkev_slepc.solve.engines import make_engine
from fkev_slepc.solve.thresholds import SolveSettings


def mesh_of(model) -> NodeDofMap:
    """The node and DOF map of ``model`` with the exact direction of every node's U DOF."""
    m = model.mechanism
    return NodeDofMap(np.asarray(m.node_link), np.asarray(m.node_s), np.asarray(m.node_dofs), np.asarray(m.elem_nodes),
                tuple(m.link_names), np.asarray(m.node_axis, float))


def solve_point(pool, angle_deg, speed_rad_s, case, modes, solver, shapes, cross_check, rel_error,
                plane="in") -> PointResult:
    """One operating point of ``pool.scene`` (see ``Study.point`` for the arguments)."""
    from fkev_slepc.sweep.runner import recoverable_errors

    sc = pool.scene
    an = sc.analysis
    case, n_modes = point_arguments(sc, case, modes, angle_deg=angle_deg, speed_rad_s=speed_rad_s,
                                    need_angle=True, need_speed=True)
    out_of_plane_arguments(sc, plane, rel_error)
    model = pool.model(case, plane)
    modes_fit(sc, n_modes, model.n_free, modes is not None)
    theta = float(np.radians(angle_deg))
    try:  # the rigid-body kinematics (the mesh does not change them) decide assembly
        kin = model.kinematics(theta)
    except ValueError as err:
        raise SceneError(sc.source, [Problem("angle_deg", f"{err} (got {angle_deg:g})")]) from None
    planned, plan = _planned(sc, angle_deg, speed_rad_s, case, n_modes, rel_error, solver)
    settings = SolveSettings.from_scene(sc)
    method = solver or sc.solver.method
    if plan is None:
        engine, close = pool.engine(method, model, settings), False
    else:  # this point on the element and mesh planned for rel_error: its own model and engine
        model = Model(planned, cases=(case,))
        engine, close = make_engine(method, model.n_free, sc.solver.petsc, settings=settings), True
    qep = model.qep(model.pieces(theta), float(speed_rad_s), case)
    mu = kin.transmission
    try:
        sol = engine.solve(qep, n_modes, want_vectors=shapes)
        res = _modes.postprocess(sol, n_modes, an.imag_tol, an.damping_tol, want_shapes=shapes)
    except recoverable_errors() as exc:
        res = _modes.failed(n_modes, f"{type(exc).__name__}: {exc}", engine.name)
    finally:
        if close:
            engine.close()
    diff = _cross_check(qep, n_modes, sc.solver.petsc, settings) if cross_check else None
    return PointResult(
        float(angle_deg), float(speed_rad_s), case, res, sc.title, model.n_free, qep.kind,
        float(np.degrees(mu[0])) if mu is not None else float("nan"), mesh_of(model),
        np.asarray(model.node_positions(theta)), model.scene, diff, plan, engine.max_pair_error, an.damping_tol, plane,
        weakref.ref(pool))


def out_of_plane_arguments(sc: Scene, plane, rel_error, asked: str | None = None) -> None:
    """SceneError naming every argument the point of ``plane`` cannot take: an unknown plane, or out of
    plane (docs/theory.md §19) links without section data and a rel_error; ``asked``: the plane as the user
    gave it when it differs (``both`` of a sweep), for the messages."""
    bad = []
    kind = BY_NAME.get(plane)
    if kind is None:
        bad.append(Problem("plane", unknown_plane(plane)))
    elif kind.section and in_plane_only(sc, OUT_OF_PLANE_THESIS) is not None:
        bad.append(in_plane_only(sc, OUT_OF_PLANE_THESIS))
    elif kind.section:
        try:
            section_of(build_mechanism(sc))
        except ValueError as err:
            bad.append(Problem("plane", f"{err} (got {asked or plane!r})"))
    if (kind is None or not kind.accuracy_plan) and (rel_error is not None or sc.analysis.rel_error is not None):
        bad.append(Problem("rel_error", f"the accuracy plan is in plane only (got a rel_error with plane "
                                        f"{asked or plane!r})"))
    if bad:
        raise SceneError(sc.source, bad)


def _planned(sc: Scene, angle_deg, speed_rad_s, case, modes, rel_error, solver) -> tuple[Scene, dict | None]:
    """The scene re-meshed for ``rel_error`` at this point and the plan (solve/accuracy.py);
    the scene itself and None without ``rel_error``."""
    rel_error = sc.analysis.rel_error if rel_error is None else rel_error
    if rel_error is None:
        return sc, None

    try:
        planned, plan = planned_scene(sc, [(float(angle_deg), float(speed_rad_s), case)], modes, rel_error,
                                      solver or sc.solver.method)
    except ValueError as err:
        raise SceneError(sc.source, [Problem("rel_error", str(err))]) from None
    return planned, plan.summary()


def critical_scan(pool, case, angle_deg, max_speed_rad_s, modes, solver, plane="in"):
    """Critical speeds of ``pool.scene`` (see ``Study.critical``)."""
    sc = pool.scene
    case, n_modes = point_arguments(sc, case, modes, angle_deg=angle_deg, max_speed_rad_s=max_speed_rad_s)
    out_of_plane_arguments(sc, plane, None)
    model = pool.model(case, plane)
    modes_fit(sc, n_modes, model.n_free, modes is not None)
    angles = sc.analysis.crank_angles_deg if angle_deg is None else (float(angle_deg),)
    engine = pool.engine(solver or sc.solver.method, model, SolveSettings.from_scene(sc))
    try:
        return scan(engine, model, angles, case, n_modes, sc.analysis.damping_tol, max_speed_rad_s,
                    DEFAULT_MAX_FACTOR * max(abs(s) for s in sc.driver.speeds))
    except AssemblyError as err:
        raise SceneError(sc.source, [Problem("angle_deg", f"{err} (got {angle_deg:g})")]) from None
