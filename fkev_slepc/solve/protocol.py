"""What every engine is and returns: the :class:`Engine` protocol, :class:`EigenSolution`, :class:`Divergence`.

Engines (solve/dense.py ``DenseEngine``, solve/slepc.py ``SlepcEngine``, solve/engines.py
``CrossCheckEngine``) implement :class:`Engine` in full; callers use it without probing.
Each holds the run's :class:`~fkev_slepc.solve.thresholds.SolveSettings` (``solve_settings``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from fkev_slepc.solve.thresholds import IMAG_TOL, SolveSettings


@dataclass(frozen=True)
class Divergence:
    """Whole-spectrum divergence verdict of one QEP (solve/stability.py, docs/stability.md).

    ``divergent``: the QEP has a real eigenvalue λ > 0 somewhere in its spectrum.
    ``proven``: decided by a certificate (a Cholesky factorization or a determinant sign),
    not by locating eigenvalues. ``real_eigenvalues``: the positive real eigenvalues located
    (1/s, ascending; may be empty for a proven divergence whose values were not located).
    ``method`` says how, ``scope`` which part of the spectrum the verdict covers.
    """

    divergent: bool
    proven: bool
    real_eigenvalues: np.ndarray
    method: str
    scope: str = "whole spectrum"


@dataclass(frozen=True)
class EigenSolution:
    """Eigenpairs of a QEP as a solver returned them (unsorted, unfiltered).

    ``errors`` holds :func:`~fkev_slepc.solve.acceptance.pair_error` for each pair. ``vectors`` is (n, k) or None.
    ``converged`` is False when the solver stopped short of what was asked.
    """

    eigenvalues: np.ndarray  # complex (k,)
    errors: np.ndarray  # float (k,)
    vectors: np.ndarray | None
    converged: bool
    solver: str
    message: str = ""
    divergence: Divergence | None = None  # None: no whole-spectrum check was made
    imag_tol: float = IMAG_TOL  # |Im λ| <= imag_tol·|λ| was real for the engine (its SolveSettings)


@runtime_checkable
class Engine(Protocol):
    """An eigen-engine: the protocol every engine implements (no optional members).

    ``name`` ("dense" or "slepc"), ``solve_settings`` (the thresholds it decides with),
    ``max_pair_error`` (= ``solve_settings.max_pair_error``), :meth:`solve`, :meth:`solve_many`
    (several problems of one model, e.g. the cases of one crank speed; engines that cannot batch
    solve them one by one), :meth:`settings` (JSON-able, archived) and :meth:`close`.
    """

    name: str
    solve_settings: SolveSettings

    @property
    def max_pair_error(self) -> float: ...

    def solve(self, qep, n_modes: int, want_vectors: bool = False, hint: float | None = None) -> EigenSolution: ...

    def solve_many(self, qeps: list, n_modes: int, want_vectors: bool = False,
                   hints: list | None = None) -> list[EigenSolution]: ...

    def settings(self) -> dict: ...

    def close(self) -> None: ...
