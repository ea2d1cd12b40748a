"""The steps every product of an archive runs through, once: the frozen sweep of ``fkev run`` (the root
product, fkev_slepc/sweep/session.py), a product added beside it (Floquet, response vs speed:
fkev_slepc/sweep/product_run.py) and a design study (fkev_slepc/design/study.py); docs/archive.md,
"Units of work".

1. open (collective; the archive's lock held by rank 0 from here to the end, archive/lock.py):
   :func:`open_root` checks the output path and lets the root product create or resume its ``.part``;
   :func:`open_product` copies the finished archive back to its ``.part`` (``store.reopen_finished``),
   keeps the product's statuses when resuming the same settings, else creates its datasets afresh
   (all pending). A refusal on rank 0 (:class:`RunRefused`) releases the lock and is raised on
   every rank, so no rank is left waiting;
2. :func:`solve_pending` (collective): the pending units dealt to the ranks by
   :func:`~fkev_slepc.sweep.units.run_units`, with a clean stop on Ctrl-C/SIGTERM (every rank
   leaves after the same sync; :class:`~fkev_slepc.sweep.interrupt.SweepInterrupted` is raised on
   every rank with the ``.part`` resumable and the lock released);
3. :func:`finish` (rank 0): run attributes and checksums stamped, the file renamed into place, the
   lock released.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import h5py
import numpy as np

from fkev_slepc.archive import lock, store
from fkev_slepc.archive.paths import PathProblem, check_output
from fkev_slepc.archive.writer import Writer
from fkev_slepc.status import EXIT_BAD_INPUT
from fkev_slepc.sweep.interrupt import StopRequest, SweepInterrupted
from fkev_slepc.sweep.units import run_units


class RunRefused(Exception):
    """The run did not start: ``exit_code`` is what ``fkev run`` exits with (2: bad input).

    Raised on every rank alike (rank 0 decides and broadcasts it), so no rank is left waiting.
    """

    def __init__(self, message: str, exit_code: int = EXIT_BAD_INPUT):
        super().__init__(message, exit_code)
        self.message, self.exit_code = message, exit_code

    def __str__(self) -> str:
        return self.message


class OutputError(RunRefused):
    """The output archive cannot be used (e.g. ``resume`` of a different scene or grid)."""


def cannot_write(out: Path, exc: OSError) -> OutputError:
    """The refusal of an output the system does not let us write (one line naming the path)."""
    where = f": {exc.filename}" if exc.filename else ""
    return OutputError(f"{out}: cannot write the archive ({exc.strerror or exc}{where})")


def _decided_on_rank0(out: Path, comm, decide: Callable, check: Callable | None = None,
                      done: Callable | None = None):
    """Collective: on rank 0 ``check()`` (the path), the lock of ``out`` taken, then ``decide()``;
    its result on every rank, or its :class:`RunRefused` raised on every rank (the lock released).
    ``done(result)``: nothing is left to write, the lock released at once."""
    plan = None
    if comm.rank == 0:
        try:
            if check is not None:
                check()
            lock.hold(out)
        except (lock.ArchiveLocked, PathProblem) as exc:
            plan = OutputError(str(exc))
        except OSError as exc:
            plan = cannot_write(out, exc)
        else:
            try:
                plan = decide()
            except RunRefused as exc:
                plan = exc
            except BaseException:
                lock.release(out)
                raise
            if isinstance(plan, RunRefused) or (done is not None and done(plan)):
                lock.release(out)
    plan = comm.bcast(plan, root=0)
    if isinstance(plan, RunRefused):
        raise plan
    return plan


def open_root(out: Path, comm, create: Callable, make_dirs: bool = True, complete: Callable | None = None):
    """Collective: the root product's output (the frozen sweep): rank 0 checks the path ``out``
    (``archive.paths.check_output``; ``make_dirs``: a missing folder is created, else refused naming
    ``-o``), takes its lock and returns ``create()`` (its new or resumed ``.part``) on every rank.
    ``complete(plan)``: the archive is finished and there is nothing to write (the lock released)."""
    flag = "output" if make_dirs else "-o"
    return _decided_on_rank0(out, comm, create, lambda: check_output(out, (".h5",), flag, make_parent=make_dirs),
                             complete)


def open_product(out: Path, product, values: dict, settings: dict, resume: bool, comm, data: dict | None = None,
                 same: Callable | None = None, needs=(), attrs: dict | None = None) -> tuple[Path, np.ndarray]:
    """Collective: ``(part, status)`` of ``product`` in the reopened archive ``out`` on every rank.

    ``values``/``data``/``needs``: the product's scales, fixed datasets and options (``store.add_product``).
    ``same(part) -> bool``: whether the archived product was computed with this run's settings
    (default: yes); a resume keeps its statuses only then, and otherwise every unit is pending;
    it may raise :class:`RunRefused` instead (the reopened copy removed, the archive untouched).
    ``settings``: attributes of the product's group; ``attrs``: ``{path: attributes}`` also written (a
    group made where there is none yet)."""

    def reopen():
        part = store.reopen_finished(out)
        try:
            status = store.read_status(part, product)
            if status is None or not resume or (same is not None and not same(part)):
                store.add_product(part, product, values, data, needs=needs)
                status = store.read_status(part, product)
        except RunRefused:
            part.unlink()
            raise
        with h5py.File(part, "r+") as f:
            for path, more in {product.name: settings, **(attrs or {})}.items():
                (f[path] if path in f else f.create_group(path)).attrs.update(more)
        return part, status

    return _decided_on_rank0(out, comm, reopen)


def solve_pending(part: Path, out: Path, product, todo: np.ndarray, solve: Callable, comm, n_unit_axes: int,
                  notify=None, label: str = "units", progress: Callable | None = None, collective: bool = False,
                  how: str | None = None) -> int:
    """Collective: solve the units of ``todo`` (``run_units``; ``collective``: each unit by all ranks
    together) into ``part``; returns the number solved. Raises SweepInterrupted on every rank after
    Ctrl-C/SIGTERM (the lock released); the notice says how to continue (``how``, default ``--resume``)."""

    def say(text: str) -> None:
        if notify is not None and comm.rank == 0:
            notify(text)

    then = "continue with --resume" if how is None else f"continue with: {how}"
    stop = StopRequest(notify=lambda what: say(f"interrupted by {what}: stopping at the next sync; the {label} "
                                               f"finished so far stay in {part}; {then}"))
    writer = Writer(part, comm, product=product)
    try:
        with stop:  # Ctrl-C/SIGTERM: every rank leaves after the same sync (sweep.interrupt)
            done = run_units(todo, solve, writer, comm, n_unit_axes=n_unit_axes, progress=progress, stop=stop,
                             collective=collective)
    finally:
        writer.close()
    if stop.stopped:
        if comm.rank == 0:
            lock.release(out)
        raise SweepInterrupted(part, done)
    return done


def finish(part: Path, out: Path, command_line: str, t0: float | None, comm, attrs: dict | None = None) -> Path:
    """Rank 0: finalise (``store.finalize``: ``attrs`` and the command line stored, the wall time
    since ``t0`` added unless it is None) and release the lock; then every rank meets at a barrier."""
    if comm.rank == 0:
        try:
            store.finalize(part, out, {**(attrs or {}), "last_command_line": command_line},
                           0.0 if t0 is None else time.monotonic() - t0)
        finally:
            lock.release(out)
    comm.Barrier()
    return out
