"""Constants shared by every stage, defined once: per-point statuses and the exit codes (and the
one NaN/∞ -> None rule of every JSON number, :func:`json_number`).

This module imports nothing from the package (numpy only), so any stage may import it.
"""

from __future__ import annotations

import math

import numpy as np

from enum import StrEnum


class Status(StrEnum):
    """Per-point outcome: a ``str`` (``Status.OK == "ok"``), archived as an HDF5 enum.

    Convergence takes precedence: a point is ``not_converged`` or ``failed`` whatever its
    eigenvalues say. A converged point is ``divergent`` if it has a real eigenvalue pair,
    else ``unstable`` if some Re λ > 0 beyond the stability threshold, else ``ok``.
    ``pending`` marks archive points not solved yet. The stability numbers themselves
    (max Re λ) are archived alongside, for every point.

    The archive stores the integer :attr:`code` (``STATUS_CODES``); these integers are part
    of the archive format and never change.

    Examples
    --------
    >>> Status.OK == "ok", Status("divergent").code, Status.from_code(2)
    (True, 4, <Status.NOT_CONVERGED: 'not_converged'>)
    """

    PENDING = "pending"
    OK = "ok"
    NOT_CONVERGED = "not_converged"
    UNSTABLE = "unstable"
    DIVERGENT = "divergent"
    FAILED = "failed"

    @property
    def code(self) -> int:
        """The integer stored in the archive's ``status`` enum dataset."""
        return STATUS_CODES[self]

    @classmethod
    def from_code(cls, code) -> Status:
        """The status archived as integer ``code``."""
        return _BY_CODE[int(code)]


STATUS_CODES: dict[Status, int] = {
    Status.PENDING: 0,
    Status.OK: 1,
    Status.NOT_CONVERGED: 2,
    Status.UNSTABLE: 3,
    Status.DIVERGENT: 4,
    Status.FAILED: 5,
}
"""Archive integer of each status (the HDF5 enum's values; archive format, fixed)."""
_BY_CODE = {v: k for k, v in STATUS_CODES.items()}

CONVERGED: tuple[Status, ...] = (Status.OK, Status.UNSTABLE, Status.DIVERGENT)
"""Statuses of points whose eigenvalues were computed and accepted."""
RETRYABLE: tuple[Status, ...] = (Status.FAILED, Status.NOT_CONVERGED)
"""Statuses that ``--retry-failed`` solves again."""

EXIT_OK = 0  # every point converged (unstable/divergent points included)
EXIT_BAD_INPUT = 2  # bad scene, options, archive or path; nothing was solved
EXIT_NOT_CONVERGED = 3  # some points failed or did not converge (they are flagged, not guessed)
EXIT_INTERRUPTED = 130  # Ctrl-C/SIGTERM: every rank stopped cleanly, the partial archive is resumable


def codes(statuses) -> list[int]:
    """Archive integers of ``statuses`` (for ``np.isin`` on archived status arrays)."""
    return [Status(s).code for s in statuses]


def converged_codes() -> list[int]:
    """``CONVERGED`` as archive integers."""
    return codes(CONVERGED)


def json_number(x) -> float | None:
    """``float(x)``, or None for None, NaN and ±∞ (JSON has neither: ``null``)."""
    return None if x is None or not math.isfinite(x) else float(x)


def json_list(a) -> list:
    """:func:`json_number` of every entry of ``a`` (flattened; numpy arrays, sequences)."""
    return [json_number(v) for v in np.asarray(a, dtype=float).ravel()]
