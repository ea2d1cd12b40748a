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
from fkev_slepc.model.operators import OUT_OF_PLANE_ABSENT, Model
from fkev_slepc.solve.engines import make_engine


class ModelPool:
    """Models of ``scene`` by the motion terms they assemble, and engines per (method, model)."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self._models: dict[tuple[str, frozenset], object] = {}
        self._engines: dict[tuple[str, int], object] = {}

    def model(self, case: str, plane: str = "in"):
        """A model of ``plane`` ("in" or "out", docs/theory.md §19) that can solve ``case``: one
        already built whose terms include the case's (the fewest such terms), else a new one for
        this case."""
        need = frozenset(t for t in terms_used((case,)) if plane == "in" or t not in OUT_OF_PLANE_ABSENT)
        fits = [key for key in self._models if key[0] == plane and need <= key[1]]
        if fits:
            return self._models[min(fits, key=lambda key: len(key[1]))]
        model = self._models[(plane, need)] = Model(self.scene, cases=(case,), plane=plane)
        return model

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
