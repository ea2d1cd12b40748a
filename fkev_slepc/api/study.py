"""The Python face of fkev_slepc: load a scene, solve one operating point, sweep, open an archive.

Everything here delegates to the pipeline stages (scene -> model -> solve -> archive -> sweep
-> plots); the command line (``fkev point``, ``fkev run``) calls these same functions.
PETSc is imported only when a SLEPc solve needs it (the CLI initialises it first with its
``-fkev_...`` options, :mod:`fkev_slepc.solve.petsc_init`; from Python, a scene's
``[solver.petsc]`` table sets them). See docs/api.md.

Examples
--------
>>> import fkev_slepc as fk
>>> study = fk.load(RUNS / "bahgat-willmert-1976.toml")
>>> r = study.point(10, 1000, "full")
>>> r.frequency_hz.round(2)
array([ 362.71,  652.08, 1078.94, 2898.89])
>>> r.status
<Status.UNSTABLE: 'unstable'>
"""

from __future__ import annotations

import builtins
import io
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fkev_slepc.api.point import critical_scan, out_of_plane_arguments, solve_point
from fkev_slepc.api.pool import ModelPool
from fkev_slepc.api.results import PointResult
from fkev_slepc.api.running import RunningSpeed
from fkev_slepc.api.table import table, write_csv
from fkev_slepc.archive import reader
from fkev_slepc.model.plane import planes_of
from fkev_slepc.scene import Problem, Scene, SceneError, load_scene, parse_scene, with_elements
from fkev_slepc.scene.edit import replace_values
from fkev_slepc.sweep.grid import configure

# Imported where used, measured: the sweep and design stages (h5py with them) add about 0.5-0.9 s to
# ``import fkev_slepc`` and so to every ``fkev`` command, matplotlib (plots.draw) about 2 s.

__all__ = ["load", "open", "Study", "SweepResults"]
log = logging.getLogger(__name__)


def load(path, elements=None) -> Study:
    """Read a scene file (TOML) into a :class:`Study`.

    Parameters
    ----------
    path : str or Path
    elements : int or sequence of int, optional
        Re-mesh: this many elements on every link, or one count per link (scene order).

    Raises
    ------
    SceneError
        Listing every problem of the file (or of ``elements``).
    """
    scene = load_scene(path)
    return Study(_remesh(scene, elements), Path(path))


def open(archive, verify: bool = True, plane: str | None = None) -> SweepResults:  # noqa: A001 - reads like io.open
    """Read a sweep archive (``fkev run`` / :meth:`Study.sweep` output) as :class:`SweepResults`.

    ``verify`` (default): check it against its checksums first and warn
    (``reader.DamagedArchiveWarning``) when it changed since its run finished; ``False`` reads it unchecked.
    ``plane`` ("in", "out"): that plane's sweep of a two-plane archive (``res.planes``; also
    ``res.on_plane("out")``); default the root sweep (in plane, or the one plane of a ``--plane out`` archive).

    Raises
    ------
    ArchiveError
        The file is missing, not an fkev archive of a supported version, has damaged metadata,
        or is being written.
    """
    return reader.load(archive, cls=SweepResults, verify=verify, plane=plane)


def _remesh(scene: Scene, elements) -> Scene:
    if elements is None:
        return scene
    return with_elements(scene, elements if isinstance(elements, int) else tuple(int(n) for n in elements))


class Study(RunningSpeed):
    """A validated scene: solve operating points and run sweeps of it.

    Build with :func:`load` or :meth:`from_text`; ``scene`` is the frozen scene tree.
    """

    def __init__(self, scene: Scene, path: Path | None = None):
        self.scene, self.path = scene, path
        self.pool = ModelPool(scene)  # models by motion terms, engines per (method, model): reused by every call

    def close(self) -> None:
        """Free the engines the study keeps between calls (also on leaving ``with study:``)."""
        self.pool.close()

    def __enter__(self) -> Study:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def n_free(self) -> int:
        """Free DOFs of the scene's model."""
        return self.pool.n_free()

    @classmethod
    def from_text(cls, toml_text: str, elements=None, source: str = "<text>") -> Study:
        """A study of a scene given as TOML text (``source`` names it in messages).

        Examples
        --------
        >>> Study.from_text((RUNS / "bahgat-willmert-1976.toml").read_text())
        Study('Bahgat-Willmert crank-rocker (Table 3.3), 5 elements': 3 links, 15 free DOFs)
        """
        return cls(_remesh(parse_scene(toml_text, source), elements))

    def __repr__(self) -> str:
        n = len(self.scene.links)
        return f"Study({self.scene.title!r}: {n} link{'s' if n != 1 else ''}, {self.n_free} free DOFs)"

    def replace(self, key, value=None) -> Study:
        """A new study with one scene key path set (``None`` removes it), or several (a dict), in SI,
        validated like a file (SceneError naming key and value): :func:`fkev_slepc.scene.edit.replace_values`."""
        return Study(replace_values(self.scene, dict(key) if isinstance(key, dict) else {key: value}), self.path)

    def design(self, params: dict, speeds=None, cases=None, angles=None, output=None, **options):
        """Design study (``fkev design``): this study's sweep at every point of a grid of scene-key values
        (``params``: key -> ``"0.25:0.40:0.05"``, ``"a,b,c"`` or numbers) into one archive; returns the
        xarray Dataset with the keys as dimensions. See :func:`fkev_slepc.design.study.study_design`."""
        from fkev_slepc.design.study import study_design

        return study_design(self, params, speeds, cases, angles, output, **options)

    def drive(self, fluctuation: float | None = None, gravity_m_s2=None, progress=None):
        """The rigid machine's steady cycle with the scene's ``[drive]`` (``fkev drive``):
        :func:`fkev_slepc.api.drive.study_drive` (``fluctuation``: the flywheel for that δ)."""
        from fkev_slepc.api.drive import study_drive

        return study_drive(self.scene, fluctuation, gravity_m_s2, progress)

    def point(self, angle_deg: float, speed_rad_s: float, case="full", modes: int | None = None,
              solver: str | None = None, shapes: bool = False, *, cross_check: bool = False,
              rel_error: float | None = None, plane: str = "in") -> PointResult:
        """Solve one operating point: crank angle (deg), constant crank speed (rad/s), case.

        Parameters
        ----------
        angle_deg, speed_rad_s : float
        case : str or int
            Case name or Table 3.1 number (docs/theory.md §11).
        modes : int, optional
            Modes to report (default the scene's ``analysis.modes``, 4 unless it says otherwise).
        solver : {"auto", "slepc", "dense"}, optional
            Default the scene's ``[solver] method`` ("auto" unless it says otherwise).
        shapes : bool
            Also compute mode shapes (:meth:`PointResult.mode_shape`, :meth:`PointResult.plot`).
        cross_check : bool
            Also solve with the other engine; the largest relative frequency difference is
            :attr:`PointResult.cross_check`.
        rel_error : float, optional
            Re-mesh so that the frequencies are within this relative error (default the scene's
            ``analysis.rel_error``; docs/accuracy.md); the plan is :attr:`PointResult.accuracy`.
        plane : {"in", "out"}
            The in-plane problem (default) or the out-of-plane one (bending out of the plane and
            torsion, docs/theory.md §19; needs every link's out-of-plane section data; mode shapes
            as (w, θ_X, θ_Y) per node, drawn as w along the links with the twist marked; no
            ``rel_error`` or sensitivities yet).

        Raises
        ------
        SceneError
            A bad argument (named, with its value) or a crank angle where the linkage cannot
            be assembled; or PETSc options the solver rejects. A solver failure is not raised:
            the result has status ``failed`` and the message.

        Examples
        --------
        A clamped-free steel strip at rest: Euler-Bernoulli's first frequency is
        1.8751² / (2π sqrt(ρ A L⁴ / (E I))) = 1.6686 Hz (the root is 0.335356 s for this strip).

        >>> r = load(RUNS / "rotating-cantilever.toml").point(0, 0, "structure", modes=2)
        >>> exact = 1.8751041**2 / (2 * np.pi * 0.335356181)
        >>> round(r.frequency_hz[0], 4), abs(r.frequency_hz[0] / exact - 1) < 1e-5
        (1.6686, True)
        >>> r.status, np.abs(r.damping_ratio).max() < 1e-9  # undamped, no gyroscopic term
        (<Status.OK: 'ok'>, True)
        """
        return solve_point(self.pool, angle_deg, speed_rad_s, case, modes, solver, shapes, cross_check, rel_error,
                           plane)

    def critical(self, case="full", angle_deg: float | None = None, max_speed_rad_s: float | None = None,
                 modes: int | None = None, solver: str | None = None, plane: str = "in"):
        """Divergence (buckling) and flutter onset speeds of ``case``: the code path of ``fkev critical``.

        Divergence: the lowest Ω at which K(Ω) = K₀ + Ω²K₂ is singular, an eigenproblem in Ω²;
        flutter: the lowest Ω at which the smallest damping ratio of the reported modes crosses 0
        on its way below ``-analysis.damping_tol``, refined to 1e-8 relative (docs/stability.md).

        Parameters
        ----------
        case : str or int
        angle_deg : float, optional
            One crank angle (deg); default every angle of the scene, the lowest speeds reported
            with the angle where they occur.
        max_speed_rad_s : float, optional
            Highest speed considered (default: divergence unbounded; flutter searched up to the
            divergence speed, else ``DEFAULT_MAX_FACTOR`` x the scene's top speed).
        modes, solver
            Modes whose damping is watched and the engine (default the scene's).
        plane : {"in", "out"}
            The in-plane problem (default) or the out-of-plane one (docs/theory.md §19): its
            divergence is the weak-axis buckling of a compressed link; it has no flutter.

        Returns
        -------
        fkev_slepc.solve.critical.CriticalScan
            ``lowest("divergence_speed")`` / ``lowest("flutter_speed")`` give (speed, angle);
            ``as_dict()`` the JSON of ``fkev critical --json``.

        Examples
        --------
        The Turcic-Midha follower buckles near 66.7 rad/s at θ = 10° (docs/stability.md):

        >>> tm = load(RUNS / "turcic-midha-1984.toml")
        >>> speed, angle = tm.critical("full", angle_deg=10).lowest("divergence_speed")
        >>> round(speed, 4), angle
        (66.6916, 10.0)
        """
        return critical_scan(self.pool, case, angle_deg, max_speed_rad_s, modes, solver, plane)

    def sweep(self, angles_deg=None, speeds_rad_s=None, cases=None, output=None, resume: bool = False,
              comm=None, *, modes: int | None = None, mode_shapes: bool = False, solver: str | None = None,
              retry_failed: bool = False, cross_check: bool = False, progress: bool = False,
              force: bool = False, element: str | None = None, rel_error: float | None = None,
              plane: str | None = None) -> SweepResults:
        """Sweep crank angle x speed x case into an HDF5 archive: the code path of ``fkev run``.

        Parameters
        ----------
        angles_deg, speeds_rad_s, cases : sequence or str, optional
            The grid (default the scene's); strings as on the command line ("0:360:5", "all").
        output : str or Path, optional
            Archive path; default ``<scene dir>/out/<scene stem>.h5`` (required for a study
            made with :meth:`from_text`).
        resume : bool
            Continue an interrupted run of the same scene and grid into ``output``.
        comm : mpi4py communicator, optional
            ``MPI.COMM_WORLD`` under ``mpirun`` (call on every rank); default this process
            alone (``MPI.COMM_SELF``).
        modes, mode_shapes, solver, retry_failed, cross_check, progress
            As ``fkev run --modes --mode-shapes --solver --retry-failed --cross-check`` and
            its progress output (stderr, rank 0).
        force : bool
            Replace an existing archive (or unfinished run) at ``output`` (``fkev run --force``);
            without it, and without ``resume``, an existing one is refused and left untouched.
        element : {"thesis", "cubic"}, optional
            Element type (``fkev run --element``; default the scene's ``analysis.element``).
        rel_error : float, optional
            Requested relative error of the frequencies, in (0, 1) (``fkev run --rel-error``;
            default the scene's ``analysis.rel_error``): before the sweep the element and the
            elements per link are chosen at a few sample points of the grid, and the plan is
            archived as the root attribute ``accuracy`` (docs/accuracy.md §3).
        plane : {"in", "out", "both"}, optional
            As ``fkev run --plane``: the in-plane problem, the out-of-plane one (docs/theory.md §19;
            alone in its archive, root attribute ``plane``; default output ``<scene stem>-out.h5``), or
            both in one archive (the out-of-plane sweep of the same grid in ``/planes/out``; the
            returned results are the in-plane sweep, ``.on_plane("out")`` the other). Default
            ``both`` when every link gives its out-of-plane section data and no ``rel_error`` is
            asked, else ``in``.

        Returns
        -------
        SweepResults
            The finished archive, on every rank; points that failed are flagged in ``status``.

        Raises
        ------
        SceneError
            A bad argument or solver option (nothing written).
        RunRefused
            ``resume`` of an archive of another scene or grid (nothing written).

        Examples
        --------
        Two angles of the Bahgat-Willmert linkage at rest, meshed for a relative error of 1e-3
        (the thesis scene has 1, 2, 2 elements per link; the plan is archived):

        >>> import json, tempfile
        >>> out = Path(tempfile.mkdtemp()) / "bw.h5"
        >>> res = load(RUNS / "bahgat-willmert-1976.toml").sweep([0, 90], [0], ["structure"], out, rel_error=1e-3)
        >>> plan = json.loads(res.attrs["accuracy"])
        >>> plan["element"], plan["elements_per_link"], res.settings()["elements"], plan["predicted_rel_error"] < 1e-3
        ('thesis', 7, (7, 7, 7), True)
        """
        from fkev_slepc.sweep.accuracy_mesh import mesh_for_accuracy
        from fkev_slepc.sweep.session import SweepRequest, default_output, run_sweep
        from fkev_slepc.sweep.plane_run import PLANE_CHOICES, default_plane, run_out_of_plane

        scene = configure(self.scene, angles=angles_deg, speeds=speeds_rad_s, cases=cases, modes=modes,
                          mode_shapes=mode_shapes, element=element, rel_error=rel_error)
        plane = default_plane(scene, plane, rel_error)
        if plane not in PLANE_CHOICES:
            raise SceneError(self.scene.source, [Problem("plane", f"must be one of {', '.join(PLANE_CHOICES)} "
                                                                  f"(got {plane!r})")])
        planes = planes_of(plane)
        for p in planes:
            out_of_plane_arguments(scene, p.name, rel_error, plane)
        sweep_plane = planes[0].name
        if output is None:
            if self.path is None:
                raise SceneError(self.scene.source, [Problem("output", "required for a study made from text")])
            output = default_output(self.path, sweep_plane)
        scene, plan = mesh_for_accuracy(scene, solver, comm, log.info)
        request = SweepRequest(scene, Path(output), resume=resume, retry_failed=retry_failed, solver=solver,
                               cross_check=cross_check, force=force, accuracy=plan, plane=sweep_plane)
        pool = self.pool.for_scene(scene)  # re-meshed for rel_error: a pool of its own
        outcome = run_sweep(request, comm, notify=log.info, progress=progress,
                            model=pool.model(scene.analysis.cases, sweep_plane))
        if len(planes) > 1:
            run_out_of_plane(request, comm, log.info, progress, model=pool.model(scene.analysis.cases, planes[1].name))
        return open(outcome.output)


@dataclass(frozen=True)
class SweepResults(reader.SweepResults):
    """:class:`fkev_slepc.archive.reader.SweepResults` with :meth:`plot` (matplotlib)."""

    def plot(self, kind: str, **options):
        """Draw a figure of this archive (a matplotlib Figure).

        ``kind``: one of :data:`fkev_slepc.plots.draw.KINDS`; ``options`` as
        :func:`fkev_slepc.plots.draw.draw` takes them: ``cases``, ``speeds``, ``angles``, ``modes``
        (a value or a list), ``order``, ``orders``. A kind drawn at one crank angle (``campbell``,
        ``param-speed``, ``mode-shape``) takes one angle, ``angles=90``; a list of several is an
        ArchiveError naming ``angles`` (draw one figure per angle).
        """
        from fkev_slepc.plots.draw import draw

        return draw(self, kind, **options)

    def to_csv(self, path=None) -> str | None:
        """The archive as the long table of ``fkev export`` (one row per angle, speed, case and
        mode; columns :data:`fkev_slepc.api.table.COLUMNS`): written to ``path`` (returns None),
        or returned as text without one.

        Examples
        --------
        >>> import tempfile
        >>> out = Path(tempfile.mkdtemp()) / "bw.h5"
        >>> res = load(RUNS / "bahgat-willmert-1976.toml").sweep([0, 90], [0], ["structure"], out, modes=2)
        >>> print(res.to_csv().splitlines()[1])
        0.0,0.0,structure,1,228.6885738113997,0.0,ok
        """
        if path is None:
            buf = io.StringIO()
            write_csv(table(self), buf)
            return buf.getvalue()
        with builtins.open(path, "w", newline="", encoding="utf-8") as fh:
            write_csv(table(self), fh)
        return None
