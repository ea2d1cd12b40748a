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

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fkev_slepc.archive import reader
from fkev_slepc.scene import Problem, Scene, SceneError, load_scene, parse_scene, with_elements
from fkev_slepc.scene.cases import case_name
from fkev_slepc.solve import modes as _modes
from fkev_slepc.status import CONVERGED, Status

__all__ = ["load", "open", "Study", "PointResult", "ModeShape", "SweepResults", "Status"]
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


def open(archive) -> SweepResults:  # noqa: A001 - fkev_slepc.open(archive) reads like io.open
    """Read a sweep archive (``fkev run`` / :meth:`Study.sweep` output) as :class:`SweepResults`.

    Raises
    ------
    ArchiveError
        The file is missing or not an fkev archive of a supported version.
    """
    return reader.load(archive, cls=SweepResults)


def _remesh(scene: Scene, elements) -> Scene:
    if elements is None:
        return scene
    return with_elements(scene, elements if isinstance(elements, int) else tuple(int(n) for n in elements))


class Study:
    """A validated scene: solve operating points and run sweeps of it.

    Build with :func:`load` or :meth:`from_text`; ``scene`` is the frozen scene tree.
    """

    def __init__(self, scene: Scene, path: Path | None = None):
        self.scene, self.path = scene, path
        self._models: dict[str, object] = {}

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
        return f"Study({self.scene.title!r}: {n} link{'s' if n != 1 else ''}, {self._model('full').n_free} free DOFs)"

    def _model(self, case: str):
        if case not in self._models:
            from fkev_slepc.model.operators import Model

            self._models[case] = Model(self.scene, cases=(case,))
        return self._models[case]

    def point(self, angle_deg: float, speed_rad_s: float, case="full", modes: int | None = None,
              solver: str | None = None, shapes: bool = False, *, cross_check: bool = False,
              rel_error: float | None = None) -> PointResult:
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
        from fkev_slepc.solve.engines import cross_check as _cross_check
        from fkev_slepc.solve.engines import make_engine
        from fkev_slepc.sweep.grid import check_modes, modes_problem
        from fkev_slepc.sweep.runner import recoverable_errors

        sc, an = self.scene, self.scene.analysis
        explicit_modes, modes = modes is not None, an.modes if modes is None else modes
        bad = []
        try:
            case = case_name(case)
        except ValueError as err:
            bad.append(Problem("case", str(err)))
        bad += check_modes(modes, "modes")
        for name, v in (("angle_deg", angle_deg), ("speed_rad_s", speed_rad_s)):
            if not np.isfinite(v):
                bad.append(Problem(name, f"must be finite (got {v})"))
        if bad:
            raise SceneError(sc.source, bad)
        model = self._model(case)
        too_many = modes_problem(int(modes), model.n_free, "modes" if explicit_modes else None)
        if too_many:
            raise SceneError(sc.source, [too_many])
        theta = float(np.radians(angle_deg))
        try:
            pieces = model.pieces(theta)
        except ValueError as err:
            raise SceneError(sc.source, [Problem("angle_deg", f"{err} (got {angle_deg:g})")]) from None
        planned, plan = self._plan(angle_deg, speed_rad_s, case, int(modes), rel_error, solver)
        if plan is not None:  # this point on the element and mesh planned for rel_error
            from fkev_slepc.model.operators import Model

            model = Model(planned, cases=(case,))
            pieces = model.pieces(theta)
        qep = model.qep(pieces, float(speed_rad_s), case)
        mu = model.kinematics(theta).transmission
        mu_deg = float(np.degrees(mu[0])) if mu is not None else float("nan")
        engine = make_engine(solver or sc.solver.method, model.n_free, sc.solver.petsc)
        try:
            sol = engine.solve(qep, int(modes), want_vectors=shapes)
            res = _modes.postprocess(sol, int(modes), an.imag_tol, an.stability_tol, want_shapes=shapes)
        except recoverable_errors() as exc:
            res = _modes.failed(int(modes), f"{type(exc).__name__}: {exc}", engine.name)
        finally:
            engine.close()
        diff = _cross_check(qep, int(modes), sc.solver.petsc) if cross_check else None
        return PointResult(float(angle_deg), float(speed_rad_s), case, res, sc.title, model.n_free, qep.kind,
                           mu_deg, model, theta, diff, plan)

    def _plan(self, angle_deg, speed_rad_s, case, modes, rel_error, solver) -> tuple[Scene, dict | None]:
        """The scene re-meshed for ``rel_error`` at this point and the plan (solve/accuracy.py);
        the scene itself and None without ``rel_error``."""
        sc = self.scene
        rel_error = sc.analysis.rel_error if rel_error is None else rel_error
        if rel_error is None:
            return sc, None
        from fkev_slepc.solve.accuracy import planned_scene

        try:
            planned, plan = planned_scene(sc, [(float(angle_deg), float(speed_rad_s), case)], modes, rel_error,
                                          solver or sc.solver.method)
        except ValueError as err:
            raise SceneError(sc.source, [Problem("rel_error", str(err))]) from None
        return planned, plan.summary()

    def sweep(self, angles_deg=None, speeds_rad_s=None, cases=None, output=None, resume: bool = False,
              comm=None, *, modes: int | None = None, mode_shapes: bool = False, solver: str | None = None,
              retry_failed: bool = False, cross_check: bool = False, progress: bool = False) -> SweepResults:
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
        """
        from fkev_slepc.sweep.grid import configure
        from fkev_slepc.sweep.session import SweepRequest, default_output, run_sweep

        scene = configure(self.scene, angles=angles_deg, speeds=speeds_rad_s, cases=cases, modes=modes,
                          mode_shapes=mode_shapes)
        if output is None:
            if self.path is None:
                raise SceneError(self.scene.source, [Problem("output", "required for a study made from text")])
            output = default_output(self.path)
        request = SweepRequest(scene, Path(output), resume=resume, retry_failed=retry_failed, solver=solver,
                               cross_check=cross_check)
        outcome = run_sweep(request, comm, notify=log.info, progress=progress)
        return open(outcome.output)


@dataclass(frozen=True)
class ModeShape:
    """One mode at one operating point, node by node.

    ``displacement[i]`` is the (x, y, rotation) displacement of node ``i`` in the global frame
    (m, m, rad), complex, scaled to unit largest modulus and phase-aligned so that its real
    part is the shape to draw (gyroscopic modes are complex). Constrained DOFs are 0. Pin
    joints are two nodes (one per link) sharing x, y.
    """

    mode: int  # 1-based
    frequency_hz: float
    eigenvalue: complex
    node_xy: np.ndarray  # (n_node, 2) undeformed positions, m
    displacement: np.ndarray  # (n_node, 3) complex
    node_link: np.ndarray  # (n_node,) link index
    link_names: tuple[str, ...]


@dataclass(frozen=True, repr=False)
class PointResult:
    """The outcome of :meth:`Study.point` at one (crank angle, speed, case).

    Arrays have one entry per mode (NaN where fewer modes were found): ``eigenvalues`` λ
    (1/s, the Im λ > 0 member of each pair), ``frequency_hz`` = Im λ / 2π, ``pair_error`` the
    relative residual of each eigenpair (docs/theory.md §10). ``max_real`` is the largest
    Re λ over every computed eigenvalue (stability indicator), ``divergent`` the positive real
    eigenvalues (divergence, never frequencies).
    """

    angle_deg: float
    speed_rad_s: float
    case: str
    raw: _modes.PointResult
    title: str
    n_free: int
    kind: str  # the QEP's structure (see model/operators.classify)
    transmission_angle_deg: float  # smallest transmission angle of the dyads (90 ideal, 0 toggle; NaN: none)
    _model: object = None  # the Model solved (mesh, node positions)
    _theta: float = 0.0
    cross_check: float | None = None  # largest relative frequency difference vs the other engine
    accuracy: dict | None = None  # with rel_error: the planned element and mesh, and its estimate

    eigenvalues = property(lambda self: self.raw.eigenvalue)
    frequency_hz = property(lambda self: self.raw.frequency_hz)
    pair_error = property(lambda self: self.raw.residual)
    max_real = property(lambda self: self.raw.max_real)
    divergent = property(lambda self: self.raw.divergent)
    status = property(lambda self: self.raw.status)
    message = property(lambda self: self.raw.message)
    solver = property(lambda self: self.raw.solver)

    @property
    def damping_ratio(self) -> np.ndarray:
        """-Re λ / |λ| per mode (negative: the mode grows)."""
        lam = self.raw.eigenvalue
        return -lam.real / np.abs(lam)

    @property
    def converged(self) -> bool:
        return self.status in CONVERGED

    def __repr__(self) -> str:
        f = ", ".join("—" if not np.isfinite(v) else f"{v:.6g}" for v in self.frequency_hz)
        msg = f" ({self.message})" if self.message else ""
        return (f"PointResult(θ={self.angle_deg:g}°, Ω={self.speed_rad_s:g} rad/s, case {self.case}: "
                f"{self.status.value}{msg}; f = [{f}] Hz; max Re λ = {self.max_real:.3g} 1/s)")

    def mode_shape(self, k: int) -> ModeShape:
        """Mode ``k`` (1-based) at every node; needs ``shapes=True`` in :meth:`Study.point`.

        Examples
        --------
        >>> r = load(RUNS / "rotating-cantilever.toml").point(0, 0, "structure", modes=1, shapes=True)
        >>> m = r.mode_shape(1)
        >>> m.node_xy.shape, m.displacement.shape      # 16 elements: 17 nodes, (x, y, rotation)
        ((17, 2), (17, 3))
        >>> tip = m.node_xy[:, 0].argmax()             # the strip lies along x: bending moves y,
        >>> abs(m.displacement[:, 1]).argmax() == tip  # most at the free tip
        True
        """
        if self.raw.shapes is None:
            raise ValueError("no mode shapes: solve the point with shapes=True")
        n = self.raw.shapes.shape[1]
        if not 1 <= k <= n:
            raise ValueError(f"mode: must be 1..{n} (got {k})")
        from fkev_slepc.plots.shapes import align_phase

        mech = self._model.mechanism
        q = align_phase(self.raw.shapes[:, k - 1], None)
        disp = np.append(q, 0.0)[mech.node_dofs]  # DOF -1 (constrained) -> the appended 0
        return ModeShape(k, float(self.frequency_hz[k - 1]), complex(self.eigenvalues[k - 1]),
                         self._model.node_positions(self._theta), disp, np.asarray(mech.node_link),
                         tuple(mech.link_names))

    def plot(self, modes=None):
        """Mode shapes on the undeformed linkage (a matplotlib Figure; needs ``shapes=True``)."""
        if self.raw.shapes is None:
            raise ValueError("no mode shapes to plot: solve the point with shapes=True")
        from fkev_slepc.plots.shapes import shapes_figure

        mech = self._model.mechanism
        mesh = reader.Mesh(mech.node_link, mech.node_s, mech.node_dofs, mech.elem_nodes, tuple(mech.link_names))
        picked = list(range(len(self.frequency_hz))) if modes is None else [int(m) - 1 for m in modes]
        heading = (f"{self.title}\nmode shapes at θ = {self.angle_deg:g}°, Ω = {self.speed_rad_s:g} rad/s, "
                   f"case {self.case}")
        return shapes_figure(mesh, self._model.node_positions(self._theta),
                             [(self.case, self.raw.shapes, self.frequency_hz)], picked, heading)

    def as_dict(self) -> dict:
        """JSON-ready summary (None for missing values), as ``fkev point --json`` prints it."""
        def num(v):
            return None if not np.isfinite(v) else float(v)

        out = {"scene": self.title, "angle_deg": self.angle_deg, "speed_rad_s": self.speed_rad_s,
               "case": self.case, "n_free": self.n_free, "kind": self.kind, "solver": self.solver,
               "frequency_hz": [num(v) for v in self.frequency_hz],
               "eigenvalue": [[num(z.real), num(z.imag)] for z in self.eigenvalues],
               "residual": [num(v) for v in self.pair_error],
               "damping_ratio": [num(v) for v in self.damping_ratio],
               "max_real": num(self.max_real), "divergent": [float(v) for v in self.divergent],
               "status": self.status.value, "message": self.message,
               "transmission_angle_deg": num(self.transmission_angle_deg),
               "element": self._model.scene.analysis.element,
               "elements": [lk.elements for lk in self._model.scene.links]}
        if self.accuracy is not None:
            out["rel_error_estimate"] = self.accuracy["predicted_rel_error"]
            out["accuracy"] = self.accuracy
        if self.cross_check is not None:
            out["cross_check_max_rel_diff"] = self.cross_check
        return out


@dataclass(frozen=True)
class SweepResults(reader.SweepResults):
    """:class:`fkev_slepc.archive.reader.SweepResults` with :meth:`plot` (matplotlib)."""

    def plot(self, kind: str, **options):
        """Draw a figure of this archive (a matplotlib Figure).

        ``kind``: one of :data:`fkev_slepc.plots.draw.KINDS`; ``options`` as
        :func:`fkev_slepc.plots.draw.draw` takes them (``cases``, ``speeds``, ``angles``,
        ``modes``: lists; ``order``).
        """
        from fkev_slepc.plots.draw import draw

        return draw(self, kind, **options)

