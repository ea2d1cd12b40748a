"""Choosing an eigen-engine (``--solver auto|slepc|dense``) and cross-checking the two.

Every engine implements :class:`~fkev_slepc.solve.protocol.Engine` (``solve``, ``solve_many``,
``settings``, ``close``, ``name``, ``solve_settings``, ``max_pair_error``) and decides with the
run's :class:`~fkev_slepc.solve.thresholds.SolveSettings`. ``auto`` picks by model size:
below :data:`CROSSOVER_N_FREE` free DOFs LAPACK's dense QZ (all 2n eigenvalues) costs less per
point than a sparse factorization plus a Krylov solve; above it SLEPc wins, by a margin that
grows like n³ (measured by ``scripts/bench_crossover.py``; numbers in docs/engine.md).
"""

from __future__ import annotations

import logging
import dataclasses

import numpy as np

from fkev_slepc.model.qep import QEP
from fkev_slepc.solve.protocol import EigenSolution, Engine
from fkev_slepc.solve.thresholds import SolveSettings, max_pair_error_option
from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.solve.petsc_init import command_line_options
from fkev_slepc.solve.stability import DENSE_LIMIT

METHODS = ("auto", "slepc", "dense")
log = logging.getLogger(__name__)

# Measured with scripts/bench_crossover.py (Bahgat-Willmert four-bar, six cases, median of 5):
# dense faster at 18 free DOFs, SLEPc faster from 27 on (UMFPACK; docs/engine.md, "Crossover").
CROSSOVER_N_FREE = 24


def engine_kind(method: str, n_free: int, crossover: int = CROSSOVER_N_FREE) -> str:
    """``"dense"`` or ``"slepc"``: the engine ``method`` means for a model of ``n_free`` DOFs."""
    if method not in METHODS:
        raise ValueError(f"solver method must be one of {', '.join(METHODS)} (got {method!r})")
    return "dense" if method == "dense" or (method == "auto" and n_free < crossover) else "slepc"


def make_engine(method: str, n_free: int, petsc_options=(), *, settings: SolveSettings | None = None,
                crossover: int = CROSSOVER_N_FREE, max_pair_error: float | None = None) -> Engine:
    """The engine for ``method`` and a model of ``n_free`` DOFs.

    Parameters
    ----------
    method : {"auto", "slepc", "dense"}
        ``auto``: dense below ``crossover`` free DOFs, SLEPc from there on.
    n_free : int
        Free DOFs of the model.
    petsc_options : iterable of (name, value)
        The scene's ``[solver.petsc]`` table (PETSc options: the SLEPc engine's; ``max_pair_error``:
        every engine's).
    settings : SolveSettings, optional
        The run's thresholds (:meth:`SolveSettings.from_scene`); default the code defaults.
    crossover : int
        Model size from which ``auto`` uses SLEPc.
    max_pair_error : float, optional
        Code default of ``max_pair_error`` (the options override it).

    Returns
    -------
    Engine
        A :class:`~fkev_slepc.solve.dense.DenseEngine` or :class:`~fkev_slepc.solve.slepc.SlepcEngine`.

    Raises
    ------
    SceneError
        When PETSc/SLEPc reject the options (scene ``[solver.petsc]`` or ``-fkev_...``): checked
        for the dense engine too (a misspelt option is an error whichever engine runs), without
        building a SLEPc engine, and without PETSc at all when no PETSc option was given.

    Examples
    --------
    >>> make_engine("auto", 20).name
    'dense'
    >>> engine = make_engine("auto", 5000)          # doctest: +SKIP
    >>> engine.name                                  # doctest: +SKIP
    'slepc'
    """
    settings = SolveSettings() if settings is None else settings
    kind = engine_kind(method, n_free, crossover)
    engine = _one_engine(kind, petsc_options, settings, max_pair_error)
    if method != "auto":  # the engine the user chose, and only that one
        return engine
    other = "slepc" if kind == "dense" else "dense"
    return FallbackEngine(engine, lambda: _one_engine(other, petsc_options, settings, max_pair_error))


def _one_engine(kind: str, petsc_options, settings: SolveSettings, max_pair_error) -> Engine:
    if kind == "dense":
        check_petsc_options(petsc_options)
        code = settings.max_pair_error if max_pair_error is None else max_pair_error
        return DenseEngine(settings.replace(max_pair_error=max_pair_error_option(petsc_options, code)))
    return _slepc_engine(petsc_options, max_pair_error=max_pair_error, settings=settings)


def _slepc_engine(petsc_options, **kw):
    from fkev_slepc.solve.slepc import OptionsError, SlepcEngine  # imports PETSc: only now, after the CLI initialised it

    try:
        return SlepcEngine(petsc_options, **kw)
    except OptionsError as err:  # reported like any bad scene value (exit code 2), not a traceback
        raise SceneError("PETSc options", [Problem(p, m) for p, m in err.problems]) from None


def check_petsc_options(petsc_options=()) -> None:
    """Raise SceneError when PETSc/SLEPc reject the options or some option is read by no solver
    object (a misspelt name: PETSc itself would ignore it). Only fkev's own options given (or
    none): nothing to check, PETSc is not even imported. Otherwise the solver objects are
    configured with the options and destroyed (solve/slepc.py ``check_options``)."""
    fkev_keys = {"max_pair_error"}
    scene = [k for k, _ in petsc_options if str(k).lstrip("-").removeprefix("fkev_") not in fkev_keys]
    argv = command_line_options()
    cmd = [t for i, t in enumerate(argv) if t.startswith("-") and t.lstrip("-").removeprefix("fkev_") not in fkev_keys
           and not (i > 0 and argv[i - 1].lstrip("-").removeprefix("fkev_") in fkev_keys)]
    if not scene and not cmd:
        return
    from fkev_slepc.solve.slepc_options import OptionsError, check_options

    try:
        check_options(petsc_options)
    except OptionsError as err:
        raise SceneError("PETSc options", [Problem(p, m) for p, m in err.problems]) from None


def frequencies(engine: Engine, qep: QEP, n_modes: int) -> np.ndarray:
    """The ``n_modes`` lowest frequencies (Hz) one engine finds (NaN where it found fewer)."""
    return postprocess(engine.solve(qep, n_modes), n_modes).frequency_hz


def relative_difference(f_a: np.ndarray, f_b: np.ndarray) -> float:
    """Largest relative difference of two frequency lists; ``inf`` when either misses a mode
    (a mode one engine misses is a disagreement, not a detail to skip)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        diff = np.abs(np.asarray(f_a) - np.asarray(f_b)) / np.abs(np.asarray(f_b))
    return float(np.inf) if not np.all(np.isfinite(diff)) else float(diff.max())


def cross_check(qep: QEP, n_modes: int, petsc_options=(), settings: SolveSettings | None = None) -> float:
    """Largest relative difference of the ``n_modes`` lowest frequencies, SLEPc vs dense QZ.

    Examples
    --------
    >>> cross_check(qep, 4)          # doctest: +SKIP
    3.1e-12
    """
    from fkev_slepc.solve.slepc import SlepcEngine

    settings = SolveSettings() if settings is None else settings
    slepc = SlepcEngine(petsc_options, settings=settings)
    try:
        f_slepc = frequencies(slepc, qep, n_modes)
    finally:
        slepc.close()
    return relative_difference(f_slepc, frequencies(DenseEngine(settings), qep, n_modes))


class _Paired:
    """An engine made of a primary engine (whose results, name and thresholds it has) and a
    second one; :meth:`solve` is :meth:`solve_many` of one problem."""

    def __init__(self, primary: Engine):
        self.primary, self.name, self.solve_settings = primary, primary.name, primary.solve_settings

    @property
    def max_pair_error(self) -> float:
        return self.primary.max_pair_error

    def solve(self, qep: QEP, n_modes: int, want_vectors: bool = False, hint=None) -> EigenSolution:
        return self.solve_many([qep], n_modes, want_vectors, [hint])[0]

    def _second(self):
        return None

    def close(self) -> None:
        self.primary.close()
        if self._second() is not None:
            self._second().close()


class CrossCheckEngine(_Paired):
    """An engine that also solves every point with the other engine (dense QZ <-> SLEPc).

    The results returned (and archived) are the primary engine's; ``max_rel_diff`` is the
    largest relative frequency difference seen so far (over points where both converged),
    ``n_points`` how many points were compared and ``n_skipped`` how many were not (one side
    did not converge: that point's status already says so). Implements
    :class:`~fkev_slepc.solve.protocol.Engine` with the primary's thresholds.
    """

    def __init__(self, primary: Engine, other: Engine):
        super().__init__(primary)
        self.other = other
        self.max_rel_diff, self.n_points, self.n_skipped = 0.0, 0, 0

    def _second(self):
        return self.other

    def solve_many(self, qeps: list, n_modes: int, want_vectors: bool = False, hints=None) -> list[EigenSolution]:
        sols = self.primary.solve_many(qeps, n_modes, want_vectors, hints)
        for sol, ref in zip(sols, self.other.solve_many(qeps, n_modes, False, hints)):
            self._compare(sol, ref, n_modes)
        return sols

    def _compare(self, sol: EigenSolution, ref: EigenSolution, n_modes: int) -> None:
        if sol.converged and ref.converged:
            d = relative_difference(postprocess(sol, n_modes).frequency_hz, postprocess(ref, n_modes).frequency_hz)
            self.max_rel_diff = max(self.max_rel_diff, d)
            self.n_points += 1
        else:
            self.n_skipped += 1

    def settings(self) -> dict:
        out = dict(self.primary.settings())
        out["cross_check"] = {"other_engine": self.other.name, "max_rel_diff": self.max_rel_diff,
                              "points": self.n_points, "skipped": self.n_skipped}
        return out


class FallbackEngine(_Paired):
    """``--solver auto``: a point the chosen engine does not converge is solved by the other one
    (dense QZ <-> SLEPc; dense only up to ``stability.DENSE_LIMIT`` DOFs), made on first need.

    A point keeps the first engine's result when the other does not converge either. The
    solver name of a rescued point says so; ``settings()['fallback']`` counts them (archived).
    Measured: Bahgat-Willmert with a 1e-8 m crank (15 DOFs: dense) is flagged by the dense
    engine's polish check and solved by SLEPc (tests/test_solver_defects.py).
    """

    def __init__(self, primary: Engine, make_other):
        super().__init__(primary)
        self._make_other, self._other = make_other, None
        self.rescued, self.tried = 0, 0

    def _second(self):
        return self._other

    def solve_many(self, qeps: list, n_modes: int, want_vectors: bool = False, hints=None) -> list[EigenSolution]:
        hints = [None] * len(qeps) if hints is None else list(hints)
        sols = self.primary.solve_many(qeps, n_modes, want_vectors, hints)
        for i, (q, sol) in enumerate(zip(qeps, sols)):
            if sol.converged or (self.primary.name == "slepc" and q.n > DENSE_LIMIT):
                continue
            if self._other is None:
                self._other = self._make_other()
            self.tried += 1
            alt = self._other.solve(q, n_modes, want_vectors, hints[i])
            if alt.converged:
                self.rescued += 1
                log.info("%s did not converge (%s): solved by %s", self.primary.name, sol.message, alt.solver)
                sols[i] = dataclasses.replace(alt, solver=f"{alt.solver} (after {self.primary.name} did not converge)")
        return sols

    def settings(self) -> dict:
        out = dict(self.primary.settings())
        out["fallback"] = {"other_engine": "slepc" if self.primary.name == "dense" else "dense",
                           "points_tried": self.tried, "points_rescued": self.rescued}
        return out


def make_cross_check_engine(method: str, n_free: int, petsc_options=(), *,
                            settings: SolveSettings | None = None) -> CrossCheckEngine:
    """``make_engine(method, ...)`` paired with the other kind of engine."""
    primary = make_engine(method, n_free, petsc_options, settings=settings)
    other_method = "slepc" if primary.name == "dense" else "dense"
    return CrossCheckEngine(primary, make_engine(other_method, n_free, petsc_options, settings=settings))
