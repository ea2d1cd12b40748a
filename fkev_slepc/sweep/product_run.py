"""A product added to the archive of a finished frozen sweep and solved unit by unit over the MPI ranks:
what ``fkev floquet`` (fkev_slepc/sweep/floquet_run.py) and ``fkev response --speeds -o``
(fkev_slepc/api/response_archive.py) are asked, and their steps; docs/archive.md, "Units of work".

:meth:`ProductRequest.run_frozen_sweep` runs (or resumes) the root product, the frozen sweep; then
:func:`open_product`, :func:`solve_pending` and :func:`finish` (fkev_slepc/sweep/run_steps.py, the
steps every product shares with the frozen sweep and the design study) add the product to it. A
periodic product archives its :class:`~fkev_slepc.periodic.settings.PeriodicSettings` whole in
``<product>/settings`` (:func:`settings_attrs`, written by ``open_product``), and a resume compares
them whole first (:func:`refuse_changed_settings`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py

from fkev_slepc.archive import store
from fkev_slepc.scene import Scene
from fkev_slepc.sweep.run_steps import finish, open_product, solve_pending  # noqa: F401 (the steps of every product)
from fkev_slepc.sweep.session import SweepRequest, run_sweep


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
    model: object = field(default=None, compare=False, repr=False)  # of the frozen sweep and the product
    # (of ``plane``, assembling the case's terms; a Study: its pool's; None: a new one)

    @property
    def case(self) -> str:
        return self.scene.analysis.cases[0]

    def run_frozen_sweep(self, comm, notify=None, progress: bool = False) -> None:
        """The root product: the frozen sweep of the scene's grid (resumed or forced as asked)."""
        run_sweep(SweepRequest(self.scene, Path(self.output), resume=self.resume, force=self.force,
                               solver=self.solver, command_line=self.command_line, make_dirs=self.make_dirs,
                               plane=self.plane), comm,
                  notify=notify, progress=progress, model=self.model)


def settings_attrs(product, settings) -> dict:
    """``open_product``'s ``attrs`` for the run's PeriodicSettings: ``{"<product>/settings": attributes}``
    (``PeriodicSettings.to_attrs`` and the group's description)."""
    path = f"{product.name}/settings"
    return {path: {**settings.to_attrs(), "description": product.groups.get(path, "")}}


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
