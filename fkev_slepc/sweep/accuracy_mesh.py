"""The element and mesh a sweep is run on when it asks for an accuracy (``analysis.rel_error``).

``fkev run --rel-error TOL`` and ``Study.sweep(rel_error=TOL)`` set ``analysis.rel_error``
(:func:`fkev_slepc.sweep.grid.configure`) and both call :func:`mesh_for_accuracy` before the
sweep: rank 0 measures the convergence at a few sample points (solve/accuracy.py,
docs/accuracy.md §3) and every rank gets the re-meshed scene.
"""

from __future__ import annotations

from typing import Callable

from fkev_slepc.scene import Problem, Scene, SceneError, with_elements
from fkev_slepc.solve.accuracy import planned_scene, sample_points, with_element
from fkev_slepc.sweep.parallel import local


def mesh_for_accuracy(scene: Scene, solver: str | None, comm=None,
                      notify: Callable[[str], None] | None = None, name: str = "rel_error") -> tuple[Scene, dict | None]:
    """Collective (``comm`` None: this process alone). With ``scene.analysis.rel_error``
    (``fkev run --rel-error``, ``Study.sweep(rel_error=...)``, both set through
    :func:`fkev_slepc.sweep.grid.configure`): rank 0 plans the element and mesh at a few sample
    points of the grid (:mod:`fkev_slepc.solve.accuracy`), every rank gets the re-meshed scene
    and the plan (archived as the ``accuracy`` attribute: :attr:`SweepRequest.accuracy`).
    Without it: ``(scene, None)``.

    Raises ``SceneError`` (naming ``name``) on every rank when no element reaches ``rel_error``."""
    rel_error = scene.analysis.rel_error
    if rel_error is None:
        return scene, None
    comm = local(comm)
    out: dict | Problem | None = None
    if comm.rank == 0:
        an = scene.analysis
        points = sample_points(an.crank_angles_deg, scene.driver.speeds, an.cases)
        try:
            _, plan = planned_scene(scene, points, an.modes, rel_error, solver or scene.solver.method)
            out = dict(plan.summary(), sample_points=points)
        except ValueError as err:
            out = Problem(name, str(err))
    out = comm.bcast(out, root=0)
    if isinstance(out, Problem):
        raise SceneError(scene.source, [out])
    scene = with_elements(with_element(scene, out["element"]), out["elements_per_link"])
    if notify is not None and comm.rank == 0:
        notify(f"rel_error {rel_error:g}: element {out['element']}, {out['elements_per_link']} elements per link, "
               f"estimated max relative error {out['predicted_rel_error']:.1e} at {len(out['sample_points'])} "
               "sample points")
    return scene, out
