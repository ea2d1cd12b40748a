"""Ctrl-C (SIGINT) and SIGTERM during a sweep: every rank stops at the same point, cleanly.

A signal only sets a flag (:class:`StopRequest`); the sweep polls it at each synchronisation,
where the ranks agree with one collective OR whether any of them was interrupted. They then
leave the loop together: the points written so far stay in the ``.part`` archive (statuses
flushed after their data, as at every sync), so ``--resume`` continues from there. Raising
KeyboardInterrupt on one rank instead would leave the others waiting in a collective.
Open MPI's ``mpirun`` answers Ctrl-C by sending SIGTERM to the ranks, hence both signals.
"""

from __future__ import annotations

import signal

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopRequest:
    """Context manager: while active, SIGINT/SIGTERM set :attr:`requested` instead of killing.

    A second signal of the same kind while stopping restores the previous behaviour (so a
    second Ctrl-C still ends a rank that is stuck).
    """

    def __init__(self):
        self.requested: int | None = None  # the signal number received, if any
        self._previous: dict = {}

    def _handle(self, signum, frame) -> None:
        if self.requested is not None:  # second signal: give up waiting
            signal.signal(signum, self._previous.get(signum, signal.SIG_DFL))
            signal.raise_signal(signum)
            return
        self.requested = signum

    def agreed(self, comm) -> bool:
        """Collective: True on every rank when any rank received a signal."""
        from mpi4py import MPI

        return bool(comm.allreduce(self.requested is not None, op=MPI.LOR))

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
