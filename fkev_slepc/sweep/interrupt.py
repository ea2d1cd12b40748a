"""Ctrl-C (SIGINT) and SIGTERM during a sweep: every rank stops at the same point, cleanly.

A signal only sets a flag (:class:`StopRequest`); the sweep polls it at each synchronisation,
where the ranks agree with one collective OR whether any of them was interrupted. They then
leave the loop together: the points written so far stay in the ``.part`` archive (statuses
flushed after their data, as at every sync), so ``--resume`` continues from there. Raising
KeyboardInterrupt on one rank instead would leave the others waiting in a collective.
Open MPI's ``mpirun`` answers Ctrl-C by sending SIGTERM to the ranks (and SIGKILL one second
later: the archive is then as after ``kill -9``, consistent and resumable); it forwards SIGUSR1,
which ``fkev run --np N`` sends instead, so that the ranks reach their next sync. Hence three
signals. The first rank-0 notice is printed from the handler, before any SIGKILL can come.
"""

from __future__ import annotations

import signal
from pathlib import Path

from fkev_slepc.status import EXIT_INTERRUPTED

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1)


class StopRequest:
    """Context manager: while active, SIGINT/SIGTERM set :attr:`requested` instead of killing.

    A second signal of the same kind while stopping restores the previous behaviour (so a
    second Ctrl-C still ends a rank that is stuck).
    """

    def __init__(self, notify=None):
        self.requested: int | None = None  # the signal number received, if any
        self.stopped = False  # the ranks agreed to stop (set by :meth:`agreed`)
        self._notify = notify  # called once, with the signal's name, on the rank that has it
        self._previous: dict = {}

    def _handle(self, signum, frame) -> None:
        if self.requested is not None:  # second signal: give up waiting
            signal.signal(signum, self._previous.get(signum, signal.SIG_DFL))
            signal.raise_signal(signum)
            return
        self.requested = signum
        self._tell(signal.Signals(signum).name)

    def _tell(self, what: str) -> None:
        if self._notify is not None:
            notify, self._notify = self._notify, None
            notify(what)

    def agreed(self, comm) -> bool:
        """Collective: True on every rank when any rank received a signal."""
        from mpi4py import MPI

        self.stopped = bool(comm.allreduce(self.requested is not None, op=MPI.LOR))
        if self.stopped:
            self._tell("a signal on another rank")
        return self.stopped

    def __enter__(self):
        for sig in SIGNALS:
            try:
                self._previous[sig] = signal.signal(sig, self._handle)
            except ValueError:  # not the main thread: leave signals alone
                pass
        return self

    def __exit__(self, *exc):
        for sig, prev in self._previous.items():
            signal.signal(sig, prev)
        self._previous = {}
        return False


class SweepInterrupted(Exception):
    """Every rank stopped after a signal (Ctrl-C, SIGTERM): ``part`` holds the points finished
    so far and is resumable; ``exit_code`` is 130 (the shell's code for SIGINT)."""

    exit_code = EXIT_INTERRUPTED

    def __init__(self, part: Path, n_solved: int):
        super().__init__(f"interrupted after {n_solved} points; {part} is kept for a resume")
        self.part, self.n_solved = part, n_solved
