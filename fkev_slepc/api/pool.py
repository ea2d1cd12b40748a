"""The models and engines a :class:`~fkev_slepc.api.study.Study` reuses between calls.

A :class:`~fkev_slepc.model.operators.Model` assembles the motion terms its cases keep (Table
3.1); any case whose terms are among a model's is solved with that model (after a ``full``
point, a ``no_coriolis`` point reuses the ``full`` model; ``structure`` needs none), so models
are kept by the terms they hold, not by case name. An engine is made once per (method, model)
and reused by every later call on that model; :meth:`ModelPool.close` (or the Study's) frees
them. A call on another grid of the study's scene (other crank angles, speeds, cases or modes:
``sweep.grid.configure``) takes its pool from :meth:`ModelPool.for_scene`, which shares them.

Every Study method takes its models here: ``point``, ``critical``, ``sweep`` (both planes), ``design``'s
base sweep, ``floquet`` (overflow and work checks, frozen sweep, monodromies, frozen-time scan),
``response``, ``response_vs_speed`` (archived or not), ``design_check`` (in plane and out of plane) and
:meth:`PointResult.sensitivity <fkev_slepc.api.results.PointResult.sensitivity>` of a point the study
solved; the stages below api (periodic/, design/, sweep/) are given a model, or
:meth:`ModelPool.model_for` as their ``model_for`` (default ``Model`` itself: a model of their own).
Called in turn, they build each distinct (scene facts, motion terms, plane) model once. Models of
other scenes are their own: a point re-meshed for ``rel_error``, the design points of ``design``, the
scenes moved by a sensitivity's key. ``loads`` builds no model (the mechanism alone).
"""

from __future__ import annotations

import copy
from dataclasses import replace

from fkev_slepc.model.operators import Model
from fkev_slepc.model.plane import Plane
from fkev_slepc.scene import Scene
from fkev_slepc.scene.cases import terms_used
from fkev_slepc.solve.engines import make_engine


def model_facts(scene: Scene) -> Scene:
    """``scene`` without what a :class:`Model` does not depend on: the grid (crank angles, cases,
    modes, mode shapes; the driver's speeds and their unit). Scenes with equal facts have equal models."""
    an, drv = scene.analysis, scene.driver
    return replace(scene, analysis=replace(an, crank_angles_deg=(), cases=(), modes=0, mode_shapes=False),
                   driver=replace(drv, speeds=(), speed_unit=""))


class ModelPool:
    """Models of ``scene`` by the motion terms they assemble, and engines per (method, model)."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self._built_from = scene  # every model of the pool (and of the pools that share it) is of this scene
        self._models: dict[tuple[str, frozenset], Model] = {}
        self._engines: dict[tuple[str, int], object] = {}

    def __len__(self) -> int:
        """The number of models built so far."""
        return len(self._models)

    def for_scene(self, scene: Scene) -> ModelPool:
        """A pool of ``scene``: this pool's models and engines shared when ``scene`` differs from this
        pool's only in its grid (:func:`model_facts`), else a pool of its own."""
        if scene is self.scene:
            return self
        if model_facts(scene) != model_facts(self.scene):
            return ModelPool(scene)
        view = copy.copy(self)  # the same dictionaries of models and engines
        view.scene = scene
        return view

    def model(self, case, plane: str = "in") -> Model:
        """A model of ``plane`` ("in" or "out", docs/theory.md §19) that can solve ``case`` (a case
        name, or a tuple of them): one already built whose terms include the case's (the fewest such
        terms), else a new one for this case."""
        cases = (case,) if isinstance(case, str) else tuple(case)
        need = frozenset(t for t in terms_used(cases) if Plane.parse(plane).has_term(t))
        fits = [key for key in self._models if key[0] == plane and need <= key[1]]
        if fits:
            return self._models[min(fits, key=lambda key: len(key[1]))]
        model = self._models[(plane, need)] = Model(self._built_from, cases=cases, plane=plane)
        return model

    def model_for(self, scene: Scene, cases, plane: str = "in") -> Model:
        """A model of ``scene`` for ``cases`` in ``plane``, called as ``Model(scene, cases, plane)``:
        :meth:`model` of :meth:`for_scene`. What the stages below api take as ``model_for``."""
        return self.for_scene(scene).model(cases, plane)

    def n_free(self) -> int:
        """Free DOFs of the scene's model (the same for every case)."""
        return self.model("structure").n_free

    def engine(self, method: str, model, settings):
        """The engine for ``method`` on ``model`` (made on first use; SceneError for options
        PETSc/SLEPc reject)."""
        key = (method, id(model))
        if key not in self._engines:
            self._engines[key] = make_engine(method, model.n_free, self.scene.solver.petsc, settings=settings)
        return self._engines[key]

    def close(self) -> None:
        for engine in self._engines.values():
            engine.close()
        self._engines.clear()
