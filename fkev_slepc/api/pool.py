"""The models and engines a :class:`~fkev_slepc.api.study.Study` reuses between calls.

A :class:`~fkev_slepc.model.operators.Model` assembles the motion terms its cases keep (Table
3.1); any case whose terms are among a model's is solved with that model (after a ``full``
point, a ``no_coriolis`` point reuses the ``full`` model; ``structure`` needs none), so models
are kept by the terms they hold, not by case name. An engine is made once per (method, model)
and reused by every later call on that model; :meth:`ModelPool.close` (or the Study's) frees
them.
"""

from __future__ import annotations

from fkev_slepc.scene import Scene
from fkev_slepc.scene.cases import terms_used


class ModelPool:
    """Models of ``scene`` by the motion terms they assemble, and engines per (method, model)."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self._models: dict[frozenset, object] = {}
        self._engines: dict[tuple[str, int], object] = {}

    def model(self, case: str):
        """A model that can solve ``case``: one already built whose terms include the case's
        (the fewest such terms), else a new one for this case."""
        need = frozenset(terms_used((case,)))
        fits = [terms for terms in self._models if need <= terms]
        if fits:
            return self._models[min(fits, key=len)]
        from fkev_slepc.model.operators import Model

        model = self._models[need] = Model(self.scene, cases=(case,))
        return model

    def n_free(self) -> int:
        """Free DOFs of the scene's model (the same for every case)."""
        return self.model("structure").n_free

    def engine(self, method: str, model, settings):
        """The engine for ``method`` on ``model`` (made on first use; SceneError for options
        PETSc/SLEPc reject)."""
        key = (method, id(model))
        if key not in self._engines:
            from fkev_slepc.solve.engines import make_engine

            self._engines[key] = make_engine(method, model.n_free, self.scene.solver.petsc, settings=settings)
        return self._engines[key]

    def close(self) -> None:
        for engine in self._engines.values():
            engine.close()
        self._engines.clear()
