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

**A sync point to interrupt at** (``FKEV_PAUSE_AFTER=K``, for tests and demonstrations that must
not race the sweep): at the first sync where at least K points are written and points are left
to solve, every rank waits there, solving nothing, until a signal reaches it (rank 0 says so on
stderr, :data:`PAUSED`): SIGINT/SIGTERM/SIGUSR1 then stop the sweep at this very sync, SIGUSR2
lets it go on (not SIGCONT: Open MPI's mpirun sends it before SIGTERM), SIGKILL kills it with
exactly those points in the archive. Each rank waits for its own signal, so none is still on
its way when the ranks agree. The wait ends by itself after :data:`PAUSE_LIMIT_S` seconds.

A rank stopped by another rank's signal (``fkev run --np N`` relays Ctrl-C as SIGUSR1 to every
rank, one after the other) leaves SIGUSR1 ignored on its way out, so that its own relayed copy,
arriving late, does not kill it with SIGUSR1's default action.
"""

from __future__ import annotations

import os
import select
import signal
import sys
import time
from pathlib import Path

from fkev_slepc.status import EXIT_INTERRUPTED

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1)
NP_VARIABLE = "FKEV_NP"  # set by ``fkev run --np N`` for the ranks it launches (cli/launch.py)
PAUSE_VARIABLE = "FKEV_PAUSE_AFTER"
PAUSED = "fkev run: paused"  # start of rank 0's stderr line while paused
PAUSE_LIMIT_S = 600.0


def pause_after(environ=None) -> int | None:
    """The K of ``FKEV_PAUSE_AFTER=K`` (None when unset or empty)."""
    value = (os.environ if environ is None else environ).get(PAUSE_VARIABLE, "").strip()
    if not value:
        return None
    try:
        return max(int(value), 0)
    except ValueError:
        print(f"fkev: ignoring {PAUSE_VARIABLE}={value!r} (expected a whole number of points)",
              file=sys.stderr, flush=True)
        return None


def signal_words(signum: int, environ=None) -> str:
    """How the notice names the signal: Ctrl-C as the user pressed it, also when
    ``fkev run --np N`` passed it on to the ranks as SIGUSR1.

    Examples
    --------
    >>> signal_words(signal.SIGINT), signal_words(signal.SIGUSR1, {NP_VARIABLE: "2"})
    ('Ctrl-C (SIGINT)', 'Ctrl-C or SIGTERM (passed on by fkev run --np as SIGUSR1)')
    """
    if signum == signal.SIGINT:
        return "Ctrl-C (SIGINT)"
    name = signal.Signals(signum).name
    if signum == signal.SIGUSR1 and (os.environ if environ is None else environ).get(NP_VARIABLE):
        return "Ctrl-C or SIGTERM (passed on by fkev run --np as SIGUSR1)"
    return name


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
        self._pause_after = pause_after()  # FKEV_PAUSE_AFTER (module docstring)
        self._installed = False  # our handlers are in place (main thread)

    def _handle(self, signum, frame) -> None:
        if self.requested is not None:  # second signal: give up waiting
            signal.signal(signum, self._previous.get(signum, signal.SIG_DFL))
            signal.raise_signal(signum)
            return
        self.requested = signum
        self._tell(signal_words(signum))

    def _tell(self, what: str) -> None:
        if self._notify is not None:
            notify, self._notify = self._notify, None
            notify(what)

    def agreed(self, comm, done: int = 0, total: int = 0) -> bool:
        """Collective: True on every rank when any rank received a signal.

        ``done`` of ``total`` points are written; with ``FKEV_PAUSE_AFTER`` rank 0 may first
        wait here for a signal (module docstring)."""
        from mpi4py import MPI

        k = self._pause_after
        if k is not None and k <= done < total and self._installed:
            self._pause_after = None
            self._wait_for_signal(done, total, say=comm.rank == 0)

        self.stopped = bool(comm.allreduce(self.requested is not None, op=MPI.LOR))
        if self.stopped:
            self._tell("a signal on another rank")
        return self.stopped

    def _wait_for_signal(self, done: int, total: int, say: bool) -> None:
        """Block until a signal (SIGUSR2: go on) or :data:`PAUSE_LIMIT_S`; signals wake the
        wait through :func:`signal.set_wakeup_fd`, so none is missed between check and wait."""
        went_on = []
        r, w = os.pipe()
        os.set_blocking(w, False)
        old_fd = signal.set_wakeup_fd(w)
        old_go = signal.signal(signal.SIGUSR2, lambda signum, frame: went_on.append(signum))
        if say:
            print(f"{PAUSED} after {done} of {total} points ({PAUSE_VARIABLE}): waiting for a signal "
                  f"(SIGINT/SIGTERM/SIGUSR1 stop here, SIGUSR2 goes on)", file=sys.stderr, flush=True)
        deadline = time.monotonic() + PAUSE_LIMIT_S
        try:
            while self.requested is None and not went_on and time.monotonic() < deadline:
                if select.select([r], [], [], max(deadline - time.monotonic(), 0.0))[0]:
                    os.read(r, 512)
        finally:
            signal.signal(signal.SIGUSR2, old_go)
            signal.set_wakeup_fd(old_fd)
            os.close(r)
            os.close(w)

    def __enter__(self):
        for sig in SIGNALS:
            try:
                self._previous[sig] = signal.signal(sig, self._handle)
            except ValueError:  # not the main thread: leave signals alone
                pass
        self._installed = bool(self._previous)
        return self

    def __exit__(self, *exc):
        for sig, prev in self._previous.items():
            if sig == signal.SIGUSR1 and self.stopped and self.requested is None:
                prev = signal.SIG_IGN  # a relayed copy may still be on its way (module docstring)
            signal.signal(sig, prev)
        self._previous = {}
        self._installed = False
        return False


class SweepInterrupted(Exception):
    """Every rank stopped after a signal (Ctrl-C, SIGTERM): ``part`` holds the points finished
    so far and is resumable; ``exit_code`` is 130 (the shell's code for SIGINT)."""

    exit_code = EXIT_INTERRUPTED

    def __init__(self, part: Path, n_solved: int):
        super().__init__(f"interrupted after {n_solved} points; {part} is kept for a resume")
        self.part, self.n_solved = part, n_solved
