"""A requested accuracy: the element and elements per link from an a-posteriori estimate.

``--rel-error TOL`` (``analysis.rel_error``) asks that the requested modes' frequencies be
within TOL (relative) of the converged model's. For each element type (model/element_types.py)
the point is solved on meshes N₀, 2N₀, 4N₀, ... elements per link until the observed
convergence rate p = log₂(|f_N - f_2N| / |f_2N - f_4N|) (the smallest over the modes) is the
same on two consecutive mesh triples (within :data:`RATE_AGREEMENT`): the rate is measured, not
assumed, and the thesis element's pre-asymptotic h⁴ regime is not mistaken for its h² one.
The error of the finest mesh is then estimated by Richardson, e = |f_N - f_N/2| / (2^p - 1),
the mesh that meets TOL is predicted as N* = N·(e/TOL)^(1/p), and the element whose N* has the
fewest DOFs is chosen (docs/accuracy.md §3).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from fkev_slepc.scene import Scene, with_elements
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.operators import Model
from fkev_slepc.solve.engines import engine_kind, make_engine
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.solve.thresholds import SolveSettings

RATE_AGREEMENT = 0.5
START = {"thesis": 4, "cubic": 2, "timoshenko": 4}  # first mesh of the sequence (elements per link)
# the meshes a plan chooses between discretise one beam theory: Euler–Bernoulli (thesis or cubic
# element) or Timoshenko (its own element, another model: never swapped for a mesh choice)
PLANNED = {"thesis": ("thesis", "cubic"), "cubic": ("thesis", "cubic"), "timoshenko": ("timoshenko",)}
MAX_MEASURED = 256  # finest mesh solved to measure the rate
MAX_ELEMENTS = 8192  # finest mesh a plan may ask for
SAFETY = 1.1  # N* is rounded up after scaling by this (the estimate is not exact)


@dataclass(frozen=True)
class ElementPlan:
    """What one element type needs to meet the tolerance (``elements`` None: it cannot)."""

    element: str
    meshes: tuple[int, ...]  # elements per link solved
    frequencies: tuple[tuple[float, ...], ...]  # per mesh, f₁… (Hz)
    rate: float  # observed rate (NaN if it could not be measured)
    estimate: float  # Richardson estimate of the finest mesh's max relative error
    extrapolated: tuple[float, ...]  # Richardson extrapolation (Hz)
    elements: int | None  # predicted elements per link for the tolerance
    n_free: int | None
    predicted: float = math.inf  # estimated max relative error at ``elements``


@dataclass(frozen=True)
class Plan:
    """The chosen element and mesh, with the estimate it predicts (``predicted_error``)."""

    rel_error: float
    element: str
    elements: int
    n_free: int
    predicted_error: float
    candidates: tuple[ElementPlan, ...]

    def scene(self, scene: Scene) -> Scene:
        """``scene`` with the chosen element and mesh."""
        return with_elements(with_element(scene, self.element), self.elements)

    def summary(self) -> dict:
        """JSON-able description (archived and printed by ``--json``)."""
        return {"rel_error": self.rel_error, "element": self.element, "elements_per_link": self.elements,
                "n_free": self.n_free, "predicted_rel_error": self.predicted_error,
                "candidates": [dataclasses.asdict(c) for c in self.candidates]}


def with_element(scene: Scene, element: str) -> Scene:
    """``scene`` with ``analysis.element`` replaced."""
    return dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, element=element))


def plan_element(solve, element: str, rel_error: float, n_free_of) -> ElementPlan:
    """Measure the convergence of one element type and predict the mesh for ``rel_error``.

    ``solve(element, n)`` returns the requested frequencies (Hz) at ``n`` elements per link
    (NaN where a mode was not found); ``n_free_of(element, n)`` the model size.
    """
    meshes, freqs, rates = [], [], []
    n = START[element]
    while n <= MAX_MEASURED:
        meshes.append(n)
        freqs.append(np.asarray(solve(element, n), dtype=float))
        if len(freqs) >= 3:
            d1, d2 = np.abs(freqs[-3] - freqs[-2]), np.abs(freqs[-2] - freqs[-1])
            with np.errstate(divide="ignore", invalid="ignore"):
                p = np.log2(d1 / d2)
            # a mode already converged to round-off (d2 ~ 0) says nothing about the rate
            live = np.isfinite(p) & (d2 > 1e-13 * np.abs(freqs[-1]))
            rates.append(float(p[live].min()) if live.any() else np.inf)
            if len(rates) >= 2 and abs(rates[-1] - rates[-2]) <= RATE_AGREEMENT:
                break
            if rates[-1] == np.inf:
                break
        n *= 2
    f = np.array(freqs)
    if len(rates) == 0 or not np.all(np.isfinite(f[-2:])):
        return ElementPlan(element, tuple(meshes), _tup2(f), math.nan, math.inf, (), None, None, math.inf)
    p = min(rates[-2:]) if len(rates) >= 2 else rates[-1]
    if p == np.inf:  # every mode converged to round-off between the last two meshes
        est, extrap = float(np.max(np.abs(f[-1] - f[-2]) / np.abs(f[-1]))), f[-1]
    else:
        p = float(np.clip(p, 0.5, 8.0))
        err = np.abs(f[-1] - f[-2]) / (2.0**p - 1.0)
        extrap = f[-1] + (f[-1] - f[-2]) / (2.0**p - 1.0)
        est = float(np.max(err / np.abs(extrap)))
    p_use = p if p != np.inf else 8.0
    errs = np.max(np.abs(f - extrap) / np.abs(extrap), axis=1)  # a-posteriori, every measured mesh
    errs[-1] = est
    elements, pred = _mesh_for(np.array(meshes), errs, p_use, rel_error)
    if elements > MAX_ELEMENTS:
        return ElementPlan(element, tuple(meshes), _tup2(f), float(p), est, tuple(map(float, extrap)), None, None,
                           math.inf)
    return ElementPlan(element, tuple(meshes), _tup2(f), float(p), est, tuple(map(float, extrap)), elements,
                       int(n_free_of(element, elements)), pred)


def _mesh_for(meshes: np.ndarray, errs: np.ndarray, p: float, tol: float) -> tuple[int, float]:
    """Fewest elements per link whose estimated error is <= tol, and that estimate.

    Beyond the finest mesh: the finest estimate scaled with the measured rate ``p``. Within the
    measured range: interpolated (in log-log) between the two measured meshes around tol.
    Below the coarsest: the coarsest (a rate measured on finer meshes does not hold there).
    """
    if errs[-1] > tol:
        n = max(1, math.ceil(meshes[-1] * (errs[-1] / tol) ** (1.0 / p) * SAFETY))
        return n, float(errs[-1] * (meshes[-1] / n) ** p)
    i = int(np.flatnonzero(errs <= tol)[0])
    if i == 0:
        return int(meshes[0]), float(errs[0])
    p_loc = max(math.log2(errs[i - 1] / errs[i]) / math.log2(meshes[i] / meshes[i - 1]), 0.5)
    n = min(int(meshes[i]), math.ceil(meshes[i - 1] * (errs[i - 1] / tol) ** (1.0 / p_loc) * SAFETY))
    return n, float(errs[i - 1] * (meshes[i - 1] / n) ** p_loc)


def choose(candidates, rel_error: float) -> Plan:
    """The candidate that meets ``rel_error`` with the fewest DOFs.

    Raises
    ------
    ValueError
        When no element type can (the message gives each one's finest estimate).
    """
    ok = [c for c in candidates if c.elements is not None]
    if not ok:
        best = ", ".join(f"{c.element}: {c.estimate:.1e} at {c.meshes[-1]} elements per link" for c in candidates)
        raise ValueError(f"no element reaches rel_error {rel_error:g} within {MAX_ELEMENTS} elements per link ({best})")
    c = min(ok, key=lambda c: (c.n_free, c.element))
    return Plan(rel_error, c.element, c.elements, c.n_free, c.predicted, tuple(candidates))


def plan_point(scene: Scene, points, n_modes: int, rel_error: float, engine_for, elements=None) -> Plan:
    """Plan the element and mesh so that ``n_modes`` frequencies at every one of ``points``
    ((angle_deg, speed, case) triples) meet ``rel_error``; the finest need over the points wins.

    ``engine_for(n_free)`` returns an engine for a model of that size (reused, not closed here);
    ``elements`` the element types compared (default: those of the scene's beam theory, :data:`PLANNED`).
    """
    cases = tuple(dict.fromkeys(c for _, _, c in points))

    def solve(element, n):
        model = Model(with_elements(with_element(scene, element), n), cases=cases)
        engine = engine_for(model.n_free)
        out = []
        for angle, speed, case in points:
            qep = model.qep(model.pieces(np.radians(angle)), speed, case)
            out.append(postprocess(engine.solve(qep, n_modes), n_modes).frequency_hz)
        return np.concatenate(out)

    def n_free_of(element, n):
        return build_mechanism(with_elements(with_element(scene, element), n)).n_free

    elements = PLANNED[scene.analysis.element] if elements is None else elements
    return choose([plan_element(solve, e, rel_error, n_free_of) for e in elements], rel_error)


def _tup2(f: np.ndarray) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in f)


class EngineCache:
    """``engine_for(n_free)``: one dense and one SLEPc engine, made on first use and reused."""

    def __init__(self, method: str, petsc_options=(), settings=None):
        self.method, self.petsc, self.settings, self._engines = method, petsc_options, settings, {}

    def __call__(self, n_free: int):
        kind = engine_kind(self.method, n_free)
        if kind not in self._engines:
            self._engines[kind] = make_engine(kind, n_free, self.petsc, settings=self.settings)
        return self._engines[kind]

    def close(self) -> None:
        for e in self._engines.values():
            e.close()
        self._engines.clear()


def planned_scene(scene: Scene, points, n_modes: int, rel_error: float, method: str = "auto"):
    """``(scene re-meshed for rel_error, Plan)``; see :func:`plan_point`.

    Raises
    ------
    ValueError
        When no element reaches ``rel_error`` (message names the best each could do).

    Examples
    --------
    >>> s, plan = planned_scene(scene, [(10.0, 1000.0, "full")], 4, 1e-6)   # doctest: +SKIP
    >>> plan.element, plan.elements                                          # doctest: +SKIP
    ('cubic', 31)
    """
    engines = EngineCache(method, scene.solver.petsc, SolveSettings.from_scene(scene))
    try:
        plan = plan_point(scene, points, n_modes, rel_error, engines)
    finally:
        engines.close()
    return plan.scene(scene), plan


def sample_points(angles_deg, speeds, cases, n_angles: int = 4):
    """Points a sweep's plan is measured at: ``n_angles`` angles spread over the grid, the
    highest speed, every case (the discretization error hardly depends on speed)."""
    a = np.asarray(angles_deg, dtype=float)
    pick = np.unique(np.linspace(0, a.size - 1, min(n_angles, a.size)).round().astype(int))
    top = float(np.max(speeds))
    return [(float(a[i]), top, c) for i in pick for c in cases]
