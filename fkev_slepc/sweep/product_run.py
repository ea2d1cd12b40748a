"""A product added to the archive of a finished frozen sweep and solved unit by unit over the MPI ranks:
the steps shared by ``fkev floquet`` (fkev_slepc/sweep/floquet_run.py) and ``fkev response --speeds -o``
(fkev_slepc/api/response_archive.py); docs/archive.md, "Units of work".

1. :func:`open_product` (collective; the archive's lock held by rank 0 from here to the end):
   the finished archive copied back to its ``.part`` (``store.reopen_finished``), the product's
   statuses kept when resuming the same settings, else its datasets created afresh (all pending),
   its settings written as attributes of its group, the whole
   :class:`~fkev_slepc.periodic.settings.PeriodicSettings` in its ``settings`` subgroup
   (:func:`refuse_changed_settings` compares them on a resume first);
2. :func:`solve_pending` (collective): the pending units dealt to the ranks by
   :func:`~fkev_slepc.sweep.units.run_units`, with a clean stop on Ctrl-C/SIGTERM (every rank
   leaves after the same sync; :class:`~fkev_slepc.sweep.interrupt.SweepInterrupted` is raised on
   every rank with the ``.part`` resumable);
3. :func:`finish` (rank 0): checksums stamped, the file renamed into place, the lock released.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import h5py
import numpy as np

from fkev_slepc.archive import lock, store
from fkev_slepc.scene import Scene


@dataclass(frozen=True)
class ProductRequest:
    """What every product run beside a frozen sweep is asked: ``scene`` with its speeds and its one case
    (``analysis.cases``) set, the archive, and how to treat an existing one (as ``fkev run``)."""

    scene: Scene
    output: Path
    resume: bool = False
    force: bool = False
    solver: str | None = None
    command_line: str = ""
    make_dirs: bool = True
    plane: str = "in"  # the frozen sweep's and the product's problem (docs/theory.md §19: "out")

    @property
    def case(self) -> str:
        return self.scene.analysis.cases[0]

    def run_frozen_sweep(self, comm, notify=None, progress: bool = False) -> None:
        """The root product: the frozen sweep of the scene's grid (resumed or forced as asked)."""
        from fkev_slepc.sweep.session import SweepRequest, run_sweep

        run_sweep(SweepRequest(self.scene, Path(self.output), resume=self.resume, force=self.force,
                               solver=self.solver, command_line=self.command_line, make_dirs=self.make_dirs,
                               plane=self.plane), comm,
                  notify=notify, progress=progress)


def open_product(out: Path, product, values: dict, settings: dict, resume: bool, comm, data: dict | None = None,
                 same: Callable | None = None, periodic=None) -> tuple[Path, np.ndarray]:
    """Collective: ``(part, status)`` of ``product`` in the reopened archive ``out`` on every rank.

    ``values``/``data``: the product's scales and fixed datasets (``store.add_product``).
    ``same(part) -> bool``: whether the archived product was computed with this run's settings
    (default: yes); a resume keeps its statuses only then, and otherwise every unit is pending.
    ``periodic``: the run's PeriodicSettings, written whole as the attributes of ``<product>/settings``."""
    part, status = None, None
    if comm.rank == 0:
        lock.hold(out)
        part = store.reopen_finished(out)
        status = store.read_status(part, product)
        if status is None or not resume or (same is not None and not same(part)):
            store.add_product(part, product, values, data)
            status = store.read_status(part, product)
        with h5py.File(part, "r+") as f:
            f[product.name].attrs.update(settings)
            if periodic is not None:
                g = f[product.name].require_group("settings")
                g.attrs.update(periodic.to_attrs())
                g.attrs["description"] = product.groups.get(g.name.lstrip("/"), "")
    return comm.bcast((part, status), root=0)


def refuse_changed_settings(out: Path, product, settings, comm) -> None:
    """Collective, on a resume before the product's work: raise
    :class:`~fkev_slepc.sweep.session.OutputError` (exit 2, on every rank; nothing written) when the
    archive's ``<product>/settings`` differ from ``settings`` (one line naming every differing field
    with both values, :func:`fkev_slepc.periodic.settings.resume_refusal`) or are missing from an
    archive that holds the product (written before they were archived). No product yet: nothing to compare."""
    from fkev_slepc.periodic.settings import PeriodicSettings, SettingsError, resume_refusal
    from fkev_slepc.sweep.session import OutputError

    why = None
    if comm.rank == 0:
        part = store.partial_path(out)
        src = part if part.exists() else out
        if src.exists():
            with h5py.File(src, "r") as f:
                if product.name in f:
                    g = f[product.name].get("settings")
                    try:
                        archived = None if g is None else PeriodicSettings.from_attrs(g.attrs)
                        why = resume_refusal(archived, settings, product.name)
                    except SettingsError as err:
                        why = f"cannot resume: the archived /{product.name}/settings are unreadable ({err})"
        why = None if why is None else f"--resume: {src}: {why}"
    why = comm.bcast(why, root=0)
    if why is not None:
        raise OutputError(why)


def solve_pending(part: Path, out: Path, product, todo: np.ndarray, solve: Callable, comm, n_unit_axes: int, notify=None,
                  label: str = "units", progress: Callable | None = None, collective: bool = False) -> int:
    """Collective: solve the units of ``todo`` (``run_units``; ``collective``: each unit by all ranks
    together) into ``part``; returns the number solved. Raises SweepInterrupted on every rank after
    Ctrl-C/SIGTERM (the lock released)."""
    from fkev_slepc.archive.writer import Writer
    from fkev_slepc.sweep.interrupt import StopRequest, SweepInterrupted
    from fkev_slepc.sweep.units import run_units

    def say(text: str) -> None:
        if notify is not None and comm.rank == 0:
            notify(text)

    stop = StopRequest(notify=lambda what: say(f"interrupted by {what}: stopping at the next sync; the {label} "
                                               f"finished so far stay in {part}; continue with --resume"))
    writer = Writer(part, comm, product=product)
    try:
        with stop:
            done = run_units(todo, solve, writer, comm, n_unit_axes=n_unit_axes, progress=progress, stop=stop,
                             collective=collective)
    finally:
        writer.close()
    if stop.stopped:
        if comm.rank == 0:
            lock.release(out)
        raise SweepInterrupted(part, done)
    return done


def finish(part: Path, out: Path, command_line: str, t0: float, comm) -> Path:
    """Rank 0: finalise (``store.finalize``: wall time since ``t0`` added) and release the lock;
    then every rank meets at a barrier."""
    if comm.rank == 0:
        try:
            store.finalize(part, out, {"last_command_line": command_line}, time.monotonic() - t0)
        finally:
            lock.release(out)
    comm.Barrier()
    return out
