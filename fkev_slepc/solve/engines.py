"""Choosing an eigen-engine (``--solver auto|slepc|dense``) and cross-checking the two.

Both engines follow one protocol: ``solve(qep, n_modes, want_vectors=False, hint=None) ->
EigenSolution``, ``settings() -> dict``, ``close()``, ``name``. ``auto`` picks by model size:
below :data:`CROSSOVER_N_FREE` free DOFs LAPACK's dense QZ (all 2n eigenvalues) costs less per
point than a sparse factorization plus a Krylov solve; above it SLEPc wins, by a margin that
grows like n³ (measured by ``scripts/bench_crossover.py``; numbers in docs/engine.md).
"""

from __future__ import annotations

import numpy as np

from fkev_slepc.model.qep import QEP

METHODS = ("auto", "slepc", "dense")

# Measured with scripts/bench_crossover.py (Bahgat-Willmert four-bar, six cases, median of 5):
# dense faster at 18 free DOFs, SLEPc faster from 27 on (UMFPACK; docs/engine.md, "Crossover").
CROSSOVER_N_FREE = 24


def make_engine(method: str, n_free: int, petsc_options=(), *, crossover: int = CROSSOVER_N_FREE, **slepc_kw):
    """The engine for ``method`` and a model of ``n_free`` DOFs.

    Parameters
    ----------
    method : {"auto", "slepc", "dense"}
        ``auto``: dense below ``crossover`` free DOFs, SLEPc from there on.
    n_free : int
        Free DOFs of the model.
    petsc_options : iterable of (name, value)
        The scene's ``[solver.petsc]`` table (used by the SLEPc engine only).
    crossover : int
        Model size from which ``auto`` uses SLEPc.
    **slepc_kw
        Passed to :class:`~fkev_slepc.solve.slepc.SlepcEngine` (e.g. ``max_pair_error``).

    Returns
    -------
    engine
        A :class:`~fkev_slepc.solve.dense.DenseEngine` or :class:`~fkev_slepc.solve.slepc.SlepcEngine`.

    Raises
    ------
    SceneError
        When PETSc/SLEPc reject the options (scene ``[solver.petsc]`` or ``-fkev_...``).

    Examples
    --------
    >>> make_engine("auto", 20).name
    'dense'
    >>> engine = make_engine("auto", 5000)          # doctest: +SKIP
    >>> engine.name                                  # doctest: +SKIP
    'slepc'
    """
    if method not in METHODS:
        raise ValueError(f"solver method must be one of {', '.join(METHODS)} (got {method!r})")
    if method == "dense" or (method == "auto" and n_free < crossover):
        from fkev_slepc.solve.dense import DenseEngine

        check_petsc_options(petsc_options)  # a misspelt option is an error whichever engine runs
        return DenseEngine(_max_pair_error(petsc_options, slepc_kw.get("max_pair_error")))
    return _slepc_engine(petsc_options, **slepc_kw)


def _slepc_engine(petsc_options, **slepc_kw):
    from fkev_slepc.solve.slepc import OptionsError, SlepcEngine  # imports PETSc: only now, after the CLI initialised it
    from fkev_slepc.scene import Problem, SceneError

    try:
        return SlepcEngine(petsc_options, **slepc_kw)
    except OptionsError as err:  # reported like any bad scene value (exit code 2), not a traceback
        raise SceneError("PETSc options", [Problem(p, m) for p, m in err.problems]) from None


def check_petsc_options(petsc_options=()) -> None:
    """Raise SceneError when PETSc/SLEPc reject the options or some option is read by no solver
    object (a misspelt name: PETSc itself would ignore it). Builds and destroys a SLEPc engine."""
    _slepc_engine(petsc_options).close()


def _max_pair_error(petsc_options, explicit) -> float:
    """``max_pair_error`` for the dense engine, with the SLEPc engine's precedence:
    command line (-fkev_max_pair_error) > scene [solver.petsc] > code default."""
    from fkev_slepc.solve.petsc_init import command_line_options
    from fkev_slepc.model.qep import MAX_PAIR_ERROR
    from fkev_slepc.scene import Problem, SceneError

    value, source = (MAX_PAIR_ERROR, "default") if explicit is None else (explicit, "code")
    scene = {k.removeprefix("-").removeprefix("fkev_"): v for k, v in dict(petsc_options).items()}
    if "max_pair_error" in scene:
        value, source = scene["max_pair_error"], "solver.petsc.max_pair_error"
    argv = command_line_options()
    for i, tok in enumerate(argv[:-1]):
        if tok in ("-fkev_max_pair_error", "--fkev_max_pair_error"):
            value, source = argv[i + 1], "-fkev_max_pair_error"
    try:
        out = float(value)
    except ValueError:
        out = float("nan")
    if not out > 0:
        raise SceneError("PETSc options", [Problem(source, f"must be a number > 0 (got {value!r})")])
    return out


def frequencies(engine, qep: QEP, n_modes: int) -> np.ndarray:
    """The ``n_modes`` lowest frequencies (Hz) one engine finds (NaN where it found fewer)."""
    from fkev_slepc.solve.modes import postprocess

    return postprocess(engine.solve(qep, n_modes), n_modes).frequency_hz


def relative_difference(f_a: np.ndarray, f_b: np.ndarray) -> float:
    """Largest relative difference of two frequency lists; ``inf`` when either misses a mode
    (a mode one engine misses is a disagreement, not a detail to skip)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        diff = np.abs(np.asarray(f_a) - np.asarray(f_b)) / np.abs(np.asarray(f_b))
    return float(np.inf) if not np.all(np.isfinite(diff)) else float(diff.max())


def cross_check(qep: QEP, n_modes: int, petsc_options=()) -> float:
    """Largest relative difference of the ``n_modes`` lowest frequencies, SLEPc vs dense QZ.

    Examples
    --------
    >>> cross_check(qep, 4)          # doctest: +SKIP
    3.1e-12
    """
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.solve.slepc import SlepcEngine

    slepc = SlepcEngine(petsc_options)
    try:
        f_slepc = frequencies(slepc, qep, n_modes)
    finally:
        slepc.close()
    return relative_difference(f_slepc, frequencies(DenseEngine(), qep, n_modes))


class CrossCheckEngine:
    """An engine that also solves every point with the other engine (dense QZ <-> SLEPc).

    The results returned (and archived) are the primary engine's; ``max_rel_diff`` is the
    largest relative frequency difference seen so far (over points where both converged),
    ``n_points`` how many points were compared and ``n_skipped`` how many were not (one side
    did not converge: that point's status already says so).
    """

    def __init__(self, primary, other):
        self.primary, self.other = primary, other
        self.name = primary.name
        self.max_rel_diff, self.n_points, self.n_skipped = 0.0, 0, 0

    def solve(self, qep: QEP, n_modes: int, want_vectors: bool = False, hint=None):
        from fkev_slepc.solve.modes import postprocess

        sol = self.primary.solve(qep, n_modes, want_vectors=want_vectors, hint=hint)
        ref = self.other.solve(qep, n_modes, hint=hint)
        if sol.converged and ref.converged:
            d = relative_difference(postprocess(sol, n_modes).frequency_hz, postprocess(ref, n_modes).frequency_hz)
            self.max_rel_diff = max(self.max_rel_diff, d)
            self.n_points += 1
        else:
            self.n_skipped += 1
        return sol

    def settings(self) -> dict:
        out = dict(self.primary.settings())
        out["cross_check"] = {"other_engine": self.other.name, "max_rel_diff": self.max_rel_diff,
                              "points": self.n_points, "skipped": self.n_skipped}
        return out

    def close(self) -> None:
        self.primary.close()
        self.other.close()


def make_cross_check_engine(method: str, n_free: int, petsc_options=()) -> CrossCheckEngine:
    """``make_engine(method, ...)`` paired with the other kind of engine."""
    primary = make_engine(method, n_free, petsc_options)
    other_method = "slepc" if primary.name == "dense" else "dense"
    return CrossCheckEngine(primary, make_engine(other_method, n_free, petsc_options))
