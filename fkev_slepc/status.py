"""Constants shared by every stage, defined once: per-point statuses and the exit codes.

This module imports nothing from the package, so any stage may import it.
"""

from __future__ import annotations

from enum import IntEnum


class Status(IntEnum):
    """Per-point outcome (archived as an HDF5 enum).

    Convergence takes precedence: a point is ``not_converged`` or ``failed`` whatever its
    eigenvalues say. A converged point is ``divergent`` if it has a real eigenvalue pair,
    else ``unstable`` if some Re λ > 0 beyond the stability threshold, else ``ok``.
    The stability numbers themselves (max Re λ) are archived alongside, for every point.
    """

    PENDING = 0
    OK = 1
    NOT_CONVERGED = 2
    UNSTABLE = 3
    DIVERGENT = 4
    FAILED = 5


CONVERGED: tuple[Status, ...] = (Status.OK, Status.UNSTABLE, Status.DIVERGENT)
"""Statuses of points whose eigenvalues were computed and accepted."""
RETRYABLE: tuple[Status, ...] = (Status.FAILED, Status.NOT_CONVERGED)
"""Statuses that ``--retry-failed`` solves again."""

EXIT_OK = 0  # every point converged (unstable/divergent points included)
EXIT_BAD_INPUT = 2  # bad scene, options, archive or path; nothing was solved
EXIT_NOT_CONVERGED = 3  # some points failed or did not converge (they are flagged, not guessed)


def converged_codes() -> list[int]:
    """``CONVERGED`` as archive integers (for ``np.isin`` on status arrays)."""
    return [int(s) for s in CONVERGED]
