"""A design study: the sweep of a scene repeated over a grid of values of scene keys, into one archive.

``fkev design SCENE --set links[1].length_m=0.25:0.40:0.05 …`` and :meth:`Study.design
<fkev_slepc.api.study.Study.design>`. The design grid is the product of the values of every key
(first key slowest); each **design point** is the scene with those values
(:func:`fkev_slepc.scene.edit.replace_values`: validated like a file, every point before anything
is solved) and is one unit of work of the archive's ``design`` product
(:data:`fkev_slepc.archive.products.DESIGN`), dealt over the MPI ranks by
:func:`fkev_slepc.sweep.units.run_units` like the crank angles of a sweep. At each design point
the sweep's grid (crank angles x speeds x cases) is solved by the sweep's own solver
(:class:`fkev_slepc.sweep.runner.Sweep`, sorted modes) and the lowest divergence (buckling)
speed over the crank angles of every motion case is computed (K(Ω) = K₀ + Ω²K₂ singular,
:func:`fkev_slepc.solve.critical.divergence_speed`), and the design check's columns at every
speed (:mod:`fkev_slepc.design.point_checks`: torque range, peak joint and wrist-pin forces,
weak-axis buckling factors; optionally stresses, safety factors and sensitivities).

The archive is an ordinary sweep archive of the scene as written (the root datasets, so every
``fkev`` command reads it) with the group ``/design`` beside it. It is resumable: the base
sweep, then the design points still pending (``resume``); a resume with another design grid
is refused. :func:`fkev_slepc.design.results.open_design` reads it as an xarray Dataset with
the design keys as dimensions.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive import store
from fkev_slepc.archive.writer import Block
from fkev_slepc.design import point_checks as pc
from fkev_slepc.design.point_checks import CheckOptions, stress_option_problems, stress_point_problems
from fkev_slepc.design.results import open_design
from fkev_slepc.design.study_keys import fixed_key_problems
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.operators import AssemblyError, Model
from fkev_slepc.periodic.steady import SharedModel
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.scene.edit import replace_values
from fkev_slepc.solve.critical import divergence_speed
from fkev_slepc.solve.engines import make_engine
from fkev_slepc.solve.modes import failed
from fkev_slepc.solve.thresholds import SolveSettings
from fkev_slepc.sweep.grid import configure, parse_range, scene_problems
from fkev_slepc.sweep.parallel import local
from fkev_slepc.sweep.run_steps import RunRefused, finish, open_product, solve_pending
from fkev_slepc.sweep.runner import Sweep, SweepOptions
from fkev_slepc.sweep.session import SweepRequest, run_sweep
from fkev_slepc.sweep.units import pending


MAX_DESIGN_POINTS = 10_000  # each design point is a whole sweep (and is checked as a scene before any solve)


@dataclass(frozen=True)
class DesignGrid:
    """Design keys and the values of each (scene units: SI); points in C order (first key slowest)."""

    keys: tuple[str, ...]
    axes: tuple[tuple[float, ...], ...]

    @property
    def points(self) -> np.ndarray:
        """(n_points, n_keys) values."""
        return np.array(list(itertools.product(*self.axes)), dtype=float).reshape(-1, len(self.keys))

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes)


def design_grid(params: dict, name: str = "params", names: dict | None = None) -> DesignGrid:
    """``{key: values}`` (values: ``"START:STOP:STEP"`` with STOP included, ``"a,b,c"``, a number
    or a sequence) as a :class:`DesignGrid`; ``names`` as in
    :func:`~fkev_slepc.design.study_keys.fixed_key_problems`.

    Raises
    ------
    SceneError
        An empty grid, a key given twice, values that are not numbers, or a key the study holds
        fixed (fkev_slepc/design/study_keys.py), named with the key.

    Examples
    --------
    >>> g = design_grid({"links[1].length_m": "0.25:0.4:0.05"})
    >>> g.axes
    ((0.25, 0.3, 0.35, 0.4),)
    """
    if not params:
        raise SceneError(name, [Problem(name, "give at least one scene key and its values")])
    keys, axes, bad = [], [], []
    for key, values in params.items():
        try:
            vals = parse_range(values if isinstance(values, str) else np.atleast_1d(values).tolist())
        except ValueError as err:
            bad.append(Problem(f"{name}[{key}]", str(err)))
            continue
        if not vals:
            bad.append(Problem(f"{name}[{key}]", "needs at least one value"))
            continue
        keys.append(str(key))
        axes.append(tuple(float(f"{v:.15g}") for v in vals))  # 0.25 + 3 x 0.05 -> 0.4
    n_points = int(np.prod([len(a) for a in axes], dtype=float)) if axes else 0
    if n_points > MAX_DESIGN_POINTS:
        bad.append(Problem(name, f"{n_points:,} design points ({' x '.join(str(len(a)) for a in axes)}), each a whole "
                                 f"sweep, exceed the limit of {MAX_DESIGN_POINTS:,} (docs/cli.md, Limits): use coarser "
                                 "steps or fewer keys"))
    if len(set(keys)) != len(keys):
        bad.append(Problem(name, f"a key is given twice (got {', '.join(keys)})"))
    bad += fixed_key_problems(params, name, names)
    if bad:
        raise SceneError(name, bad)
    return DesignGrid(tuple(keys), tuple(axes))


def design_scenes(scene: Scene, grid: DesignGrid, checks: CheckOptions | None = None, names=None,
                  models: dict | None = None) -> list[Scene]:
    """The scene of every design point (validated like files, then checked as ``fkev check`` checks
    one: assembly at every crank angle, modes, operator overflow;
    :func:`fkev_slepc.sweep.grid.scene_problems`; with ``checks.stress`` the periodic responses'
    refusals too, :func:`~fkev_slepc.design.point_checks.stress_point_problems`), or one SceneError listing
    every design point that is not a valid scene (the stress refusals up to the first point; nothing
    computed). Each point's checks share one Model (:class:`~fkev_slepc.periodic.steady.SharedModel`),
    kept in ``models`` (point index -> Model) for its solve for the first :data:`KEEP_CHECKED_MODELS`
    points (a bound on the memory), dropped after for the rest."""
    checks = checks or CheckOptions()
    angles, cases = scene.analysis.crank_angles_deg, scene.analysis.cases
    out, bad, cycle, stress = [], [], [], []
    for i, values in enumerate(grid.points):
        said = ", ".join(f"{k} = {v:g}" for k, v in zip(grid.keys, values))
        try:
            out.append(replace_values(scene, {k: int(v) if float(v).is_integer() and abs(v) < 2**53 else v
                                              for k, v in zip(grid.keys, values.tolist())}))  # integer keys too
        except SceneError as err:
            bad += [Problem(f"design point {i} ({said}): {p.path}", p.message) for p in err.problems]
            continue
        shared = SharedModel(cases)
        bad += [Problem(f"design point {i} ({said}): {p.path}", p.message) for p in scene_problems(out[-1], shared)]
        if checks.stress and not bad:
            cycle = cycle or stress_option_problems([out[-1]], angles, checks, names)
            stress = stress or pc.point_named(i, len(grid.points),
                                              stress_point_problems(out[-1], angles, cases, checks, names, shared))
        if models is not None and shared.model is not None and len(models) < KEEP_CHECKED_MODELS:
            models[i] = shared.model
    bad = bad or cycle or stress
    if bad:
        raise SceneError(scene.source, bad)
    return out


KEEP_CHECKED_MODELS = 64  # design points whose checked Model is kept for their solve (the rest build it again)


class DesignSolver:
    """Solves one design point (a unit of work of the ``design`` product) into a writer Block."""

    def __init__(self, scenes: list[Scene], base: Scene, engine, n_modes: int, grid: DesignGrid | None = None,
                 checks: CheckOptions | None = None, models: dict | None = None):
        an = base.analysis
        self.models = models if models is not None else {}  # point index -> its checked Model (design_scenes)
        self.scenes, self.engine = scenes, engine
        self.design, self.checks = grid, checks or CheckOptions()
        self.grid = P.Grid(np.asarray(an.crank_angles_deg, float), np.asarray(base.driver.speeds, float),
                           tuple(an.cases), int(n_modes))
        self.opts = SweepOptions(int(n_modes), an.imag_tol, an.damping_tol)

    def solve(self, unit: tuple, mask: np.ndarray):
        (ip,) = unit
        grid, nm = self.grid, self.opts.n_modes
        na, ns, nc = grid.shape
        rows = (P.D_FREQUENCY, P.D_EIGENVALUE, P.D_DAMPING, P.D_MAX_REAL)
        data = {v.path: np.full((na, ns, nc) + ((nm,) if v.dims[-1] == P.MODE else ()), v.fill, dtype=v.dtype)
                for v in rows}
        status = np.zeros((na, ns, nc), dtype=np.uint8)
        errors = []
        model = self.models.pop(ip, None) or Model(self.scenes[ip], cases=grid.cases)
        sweep = Sweep(model, grid, self.engine, None, self.opts, np.full((na, ns, nc), np.nan))
        div = np.full((len(grid.cases), na), np.nan)
        for ia in range(na):
            theta = float(np.radians(grid.angles_deg[ia]))
            try:
                if mask[ia].any():
                    b = sweep.solve_angle(ia, mask[ia])
                    for v in rows:
                        data[v.path][ia] = b.data[P.SWEEP.var(v.name).path]
                    status[ia] = b.status
                    errors += [((ip, *i), s, m) for i, s, m in b.errors]
                pieces = model.pieces(theta)
                div[:, ia] = [divergence_speed(model, pieces, c) for c in grid.cases]
            except AssemblyError as exc:
                bad = failed(nm, str(exc))
                for js, jc in np.argwhere(mask[ia]):
                    status[ia, js, jc] = bad.status.code
                    errors.append(((ip, ia, int(js), int(jc)), bad.status.code, bad.message))
        lowest = np.full(len(grid.cases), np.nan)
        angle = np.full(len(grid.cases), np.nan)
        for jc in range(len(grid.cases)):
            if np.isfinite(div[jc]).any():
                k = int(np.nanargmin(div[jc]))
                lowest[jc], angle[jc] = div[jc, k], grid.angles_deg[k]
        data[P.D_DIVERGENCE.path], data[P.D_DIVERGENCE_ANGLE.path] = lowest, angle
        data.update(self.check_columns(ip, model))
        return Block((ip,), np.asarray(mask, bool), data, status, errors)

    def check_columns(self, ip: int, model: Model | None = None) -> dict:
        """The design-check columns of design point ``ip`` (fkev_slepc/design/point_checks.py), the
        stresses on ``model`` (the point's sweep model; default a new one)."""
        scene, grid = self.scenes[ip], self.grid
        out = pc.kinetostatic_columns(scene, grid.angles_deg, grid.speeds)
        if self.checks.stress:
            out.update(pc.stress_columns(scene, grid.angles_deg, grid.speeds, grid.cases, self.checks, model))
        if self.checks.sensitivity and self.design is not None:
            out.update(pc.sensitivity_columns(scene, self.design.keys, self.design.points[ip], grid.angles_deg,
                                              grid.speeds, out))
        return out


def run_design(scene: Scene, grid: DesignGrid, output, comm=None, *, resume: bool = False, force: bool = False,
               solver: str | None = None, notify=None, progress: bool = False, command_line: str = "",
               checks: CheckOptions | None = None, names=None, model=None) -> Path:
    """Collective over ``comm`` (default this process alone): the base sweep of ``scene`` (its grid
    already configured) into ``output``, then every pending design point into its ``/design``,
    with the design check's columns of ``checks`` (fkev_slepc/design/point_checks.py; default
    the kinetostatic ones only). ``names`` maps argument names to the caller's in messages;
    ``model``: the base sweep's model (``Study.design``: its pool's; default a new one).

    Raises
    ------
    SceneError
        A design point that is not a valid scene (before anything is solved).
    RunRefused
        ``resume`` of an archive of another design grid, or the base sweep refused.
    SweepInterrupted
        Ctrl-C or SIGTERM (every rank): the ``.part`` holds the design points finished so far.
    """
    comm = local(comm)
    output = Path(output)
    note = notify if (notify is not None and comm.rank == 0) else (lambda _m: None)
    checks = checks or CheckOptions()
    models: dict = {}  # the design points' checked Models, kept for their solves (design_scenes)
    scenes = design_scenes(scene, grid, checks, names, models)  # every design point valid, or nothing is done
    base_resume = resume and (output.exists() or store.partial_path(output).exists())
    command_line = command_line or "fkev design"
    run_sweep(SweepRequest(scene, output, resume=base_resume, force=force and not resume, solver=solver,
                           command_line=command_line), comm, notify=notify, progress=progress, model=model)
    points = grid.points
    scales = {P.D_POINT: np.arange(len(points), dtype="i4"), P.D_KEY: list(grid.keys),
              P.D_LINK: [lk.name for lk in scene.links], P.D_JOINT: [j.name for j in scene.joints]}
    criterion = {P.D_FATIGUE_SF.path: {"fatigue_criterion": checks.criterion}} if checks.stress else None
    part, status = open_product(output, P.DESIGN, scales, {}, resume, comm, data={P.D_VALUE.path: points},
                                same=lambda part: _same_design(part, output, grid, checks), needs=checks.needs,
                                attrs=criterion)
    todo = pending(status)
    note(f"{len(grid.points)} design point(s) of {', '.join(grid.keys)}; "
         f"{int(todo.any(axis=(1, 2, 3)).sum())} to solve")
    engine = make_engine(solver or scene.solver.method, _n_free(scenes), scene.solver.petsc,
                         settings=SolveSettings.from_scene(scene))
    try:
        ds = DesignSolver(scenes, scene, engine, scene.analysis.modes, grid, checks, models)
        report = (lambda done, total: note(f"{done}/{total} design-study points")) if progress else None
        solve_pending(part, output, P.DESIGN, todo, ds.solve, comm, 1, notify, "design points", report)
    finally:
        engine.close()
    return finish(part, output, command_line, None, comm)


def study_design(study, params: dict, speeds=None, cases=None, angles=None, output=None, *, modes: int | None = None,
                 resume: bool = False, force: bool = False, comm=None, solver: str | None = None,
                 progress: bool = False, stress: bool = False, sensitivity: bool = False, criterion: str = "goodman",
                 harmonics: int | None = None):
    """:meth:`Study.design <fkev_slepc.api.study.Study.design>`.

    Parameters
    ----------
    params : dict
        Scene key path -> values (``"0.25:0.40:0.05"`` with the stop included, ``"a,b,c"``, a
        number or a sequence); several keys give their product (first key slowest).
    speeds, cases, angles, modes
        The sweep grid at each design point (default the scene's; as ``Study.sweep``).
    output : str or Path, optional
        Default ``<scene dir>/out/<scene stem>-design.h5`` (required for a study from text).
    resume, force, comm, solver, progress
        As ``Study.sweep``: continue an interrupted study of the same grid; replace an archive;
        ``MPI.COMM_WORLD`` under ``mpirun`` (design points dealt over the ranks).
    stress, criterion, harmonics
        Per link the design check's peak |σ|, static and fatigue (``criterion``: goodman,
        soderberg, gerber) factors at every speed and case: one periodic response each
        (``harmonics`` fixed, default doubled until converged), far more than the frequencies.
    sensitivity
        d/dp of the kinetostatic columns for every design key p (central differences).

    Returns
    -------
    xarray.Dataset
        :func:`fkev_slepc.design.results.open_design`: the design keys are dimensions;
        ``frequency_min_hz`` is each mode's lowest frequency over the crank cycle,
        ``divergence_speed_rad_s`` the lowest divergence speed over the crank angles; the design
        check's columns (``torque_min_n_m``, ``peak_joint_force_n``, ``buckling_sf``, ...,
        fkev_slepc/design/point_checks.py).

    Raises
    ------
    SceneError
        A bad key or value (any design point that is not a valid scene), before anything is solved.
    """
    grid = design_grid(params)
    scene = configure(study.scene, angles=angles, speeds=speeds, cases=cases, modes=modes)
    if output is None:
        if study.path is None:
            raise SceneError(study.scene.source, [Problem("output", "required for a study made from text")])
        output = Path(study.path).parent / "out" / f"{Path(study.path).stem}-design.h5"
    run_design(scene, grid, output, comm, resume=resume, force=force, solver=solver,
               notify=logging.getLogger(__name__).info, progress=progress, command_line="Study.design",
               checks=CheckOptions(stress, sensitivity, criterion, harmonics),
               model=study.pool.for_scene(scene).model(scene.analysis.cases))
    return open_design(output)


def _n_free(scenes: list[Scene]) -> int:
    return max(build_mechanism(s).n_free for s in scenes)


def _same_design(part: Path, output: Path, grid: DesignGrid, checks: CheckOptions) -> bool:
    """Rank 0, on a resume of an archive that has a design product: True when it is of the design
    grid ``grid`` with the columns of ``checks``; a resume of another grid or other columns is refused."""
    with h5py.File(part, "r") as f:
        keys = tuple(k.decode() if isinstance(k, bytes) else str(k) for k in f[P.D_KEY][()])
        values = f[P.D_VALUE.path][()]
        had = (P.D_TORQUE_MIN.path in f, P.D_PEAK_STRESS.path in f, P.D_SENSITIVITY[0].path in f,
               f[P.D_FATIGUE_SF.path].attrs.get("fatigue_criterion") if P.D_FATIGUE_SF.path in f else None)
    points = grid.points
    if not (keys == grid.keys and values.shape == points.shape and np.array_equal(values, points)):
        raise RunRefused(f"{output}: --resume of a design study over other values: the archive has "
                         f"{', '.join(keys)} at {len(values)} point(s), this run {', '.join(grid.keys)} at "
                         f"{len(points)} (use another -o, or --force to start over)")
    if had != (True, checks.stress, checks.sensitivity, checks.criterion if checks.stress else None):
        raise RunRefused(f"{output}: --resume with other design-check columns (--stress, --criterion, "
                         "--sensitivity) than the archive's (use another -o, or --force to start over)")
    return True
