"""Every limit and refusal of the periodic commands that needs no solve, in one place: the mesh
size (free DOFs), the memory of a response on link components, the dense harmonic-balance size,
over-critical damping and operators that overflow double precision at the top speed.

Called by the CLI (:func:`fkev_slepc.cli.common.preflight`) and by the Python API alike
(:func:`fkev_slepc.periodic.steady.checked_point`: ``Study.response``, ``Study.design_check``,
``fkev design-check``), so each refuses an oversize model with the same words (docs/cli.md, "Limits").
``names`` maps the argument keys ``elements``, ``harmonics`` and ``speed_rad_s`` to the caller's
names of them (a CLI passes its flags; default the API's argument names).
"""

from __future__ import annotations

from dataclasses import replace

from fkev_slepc.scene import Problem, Scene

MAX_FREE_DOFS = 100_000  # a mesh beyond: refused before meshing (docs/cli.md, "Limits"; 50,400 DOFs measured in docs/engine.md)
MAX_PERIODIC_DOFS = 1_000  # floquet and response integrate dense 2n x 2n states: beyond, refused
MAX_COMPONENT_DOFS = 2_000  # the response on link components (54 s, 1.7 GB at 999 DOFs, docs/engine.md): beyond, refused


def size_problems(scene: Scene, periodic: bool, harmonics: int | None = None, reduce=None,
                  names: dict | None = None) -> list[Problem]:
    """The mesh (and harmonic balance) too large to be worth starting, with the numbers and the way
    out: at most :data:`MAX_FREE_DOFS` free DOFs, :data:`MAX_PERIODIC_DOFS` for the ``periodic``
    commands; a response on link components (``reduce`` not None) up to the memory its estimate
    allows (:func:`fkev_slepc.periodic.component_response.memory_problem`) and :data:`MAX_COMPONENT_DOFS`."""
    from fkev_slepc.model.mechanism import build_mechanism
    from fkev_slepc.periodic.component_response import memory_problem
    from fkev_slepc.periodic.harmonic_balance import MAX_UNKNOWNS

    names = names or {}
    elements, h_name = names.get("elements", "elements"), names.get("harmonics", "harmonics")
    mech = build_mechanism(scene)
    n = mech.n_free
    limit, what = (MAX_PERIODIC_DOFS, "the periodic solvers integrate dense states of 2n") if periodic else (
        MAX_FREE_DOFS, "the limit of one command")
    if periodic and reduce is not None and n > MAX_COMPONENT_DOFS:
        limit, what = MAX_COMPONENT_DOFS, "the response on link components: 54 s and 1.7 GB at 999 DOFs"
    elif periodic and reduce is not None:
        try:
            text = memory_problem(mech, reduce, harmonics)
        except ValueError:
            text = None  # a bad reduce: named by the response's own check
        if text != "full":
            return [] if text is None else [Problem(elements, text)]
    if n > limit:
        return [Problem(elements, f"{n} free DOFs exceed {limit} ({what}; docs/cli.md, Limits): use fewer "
                                  "--elements")]
    if harmonics is not None and (2 * harmonics + 1) * n > MAX_UNKNOWNS:
        return [Problem(h_name, f"{harmonics} harmonics x {n} DOFs = {(2 * harmonics + 1) * n} unknowns "
                                f"exceed the dense limit {MAX_UNKNOWNS}: use at most "
                                f"{max(MAX_UNKNOWNS // n - 1, 0) // 2} harmonics (got {harmonics})")]
    return []


def plausibility_problems(scene: Scene, speeds=None, periodic: bool = False, names: dict | None = None,
                          model_for=None) -> list[Problem]:
    """Over-critical damping (the ``periodic`` commands; :func:`fkev_slepc.scene.plausible.damping_warnings`)
    and ``speeds`` whose operators overflow double precision at the top one
    (:func:`fkev_slepc.solve.finite.overflow_problems`, named ``names["speed_rad_s"]``), on the model
    ``model_for(scene, cases, "in")`` of every case of the scene (default: a new one)."""
    from fkev_slepc.scene.plausible import damping_warnings, summarize_scene
    from fkev_slepc.solve.finite import overflow_problems

    bad: list[Problem] = []
    if periodic:
        bad += [Problem("damping", w.removeprefix("damping: ")) for w in damping_warnings(scene, summarize_scene(scene))]
    if speeds is not None and len(speeds):
        top = max((float(w) for w in speeds), key=abs)
        at = replace(scene, driver=replace(scene.driver, speeds=(top,)))
        speed = (names or {}).get("speed_rad_s", "speed_rad_s")
        every = tuple(dict.fromkeys(("structure", *at.analysis.cases)))
        model = None if model_for is None else model_for(at, every, "in")
        bad += [Problem(speed if p.path == "driver.speeds" else p.path, p.message) for p in overflow_problems(at, model)]
    return bad
