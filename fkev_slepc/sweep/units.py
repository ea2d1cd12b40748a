"""The unit of work of a distributed run, for every product (docs/archive.md, "Units of work").

A product of the archive (:class:`fkev_slepc.archive.products.Product`) names its unit axes:
the sweep of ``fkev run`` solves one crank angle at a time (its (speed, case) points inside);
a Floquet or response product would solve one (speed, case), a design study one design point.
:func:`run_units` deals the units that still hold points to solve cyclically to the ranks
(mpi4py's mandelbrot demo), one unit per rank per round, in equal rounds so that the collective
syncs of :class:`fkev_slepc.archive.writer.Writer` line up on every rank; it hands each solved
unit's :class:`~fkev_slepc.archive.writer.Block` to the writer, calls the writer's sync when
due (about every 2 s of work), reports progress on rank 0 and stops every rank at the same
sync when one was signalled (:class:`fkev_slepc.sweep.interrupt.StopRequest`). Locking (one
writer per archive, :mod:`fkev_slepc.archive.lock`), creation and resume
(:func:`fkev_slepc.archive.store.read_status`) and finalisation are per file and so serve
every product alike.
"""

from __future__ import annotations

import logging
from typing import Callable

import numpy as np
from fkev_slepc.status import codes, Status

log = logging.getLogger(__name__)


def assign(todo: np.ndarray, rank: int, size: int, n_unit_axes: int = 1) -> tuple[np.ndarray, int]:
    """Units this rank solves (flat unit numbers, C order over the first ``n_unit_axes`` axes of
    ``todo``; cyclic over the units that have points to do) and the number of rounds every
    rank must take part in."""
    todo = np.asarray(todo)
    n_units = int(np.prod(todo.shape[:n_unit_axes]))
    units = np.flatnonzero(todo.reshape(n_units, -1).any(axis=1))
    return units[rank::size], -(-units.size // size)


def run_units(todo: np.ndarray, solve: Callable, writer, comm, n_unit_axes: int = 1, progress=None,
              stop=None, collective: bool = False) -> int:
    """Collective over ``comm``: solve the points of ``todo`` unit by unit. Returns the number
    of points solved by all ranks.

    Parameters
    ----------
    todo : bool array over the product's point axes, the unit axes first (``Product.point_axes``).
    solve : ``solve(unit, mask) -> Block``: solve the points ``mask`` (``todo[unit]``) of the unit
        ``unit`` (a tuple of indices on the unit axes) on this rank.
    writer : :class:`fkev_slepc.archive.writer.Writer` of this rank (for the product).
    progress : ``progress(done, total)`` called on rank 0 after every sync.
    stop : :class:`~fkev_slepc.sweep.interrupt.StopRequest`, polled at every sync: when any rank was
        signalled, every rank leaves after that sync (the points synced so far are in the
        archive) and ``stop.stopped`` is set.
    collective : every rank solves every unit together (``solve`` is collective, e.g. one monodromy
        split over the ranks when there are fewer units than ranks) and rank 0 writes the block.
    """
    unit_shape = todo.shape[:n_unit_axes]
    mine, n_rounds = assign(todo, 0, 1, n_unit_axes) if collective else assign(todo, comm.rank, comm.size, n_unit_axes)
    total, done = int(np.count_nonzero(todo)), 0
    log.info("%d points to solve on %d rank(s): %d unit(s) here, %d rounds", total, comm.size, mine.size, n_rounds)
    for rnd in range(n_rounds):
        if rnd < mine.size:
            unit = tuple(int(i) for i in np.unravel_index(int(mine[rnd]), unit_shape))
            block = solve(unit, todo[unit])
            if not collective or comm.rank == 0:
                writer.write_block(block)
        if writer.end_round() or rnd == n_rounds - 1:
            done += writer.sync()
            if progress is not None and comm.rank == 0:
                progress(done, total)
            if stop is not None and rnd < n_rounds - 1 and stop.agreed(comm, done, total):
                break
    return done


def pending(status: np.ndarray, retry: tuple = ()) -> np.ndarray:
    """Mask of the points of a product still to solve: ``pending`` ones, and those whose status
    is in ``retry`` (e.g. :data:`fkev_slepc.status.RETRYABLE` for a retry of failed points)."""
    return np.isin(status, codes([Status.PENDING, *retry]))
