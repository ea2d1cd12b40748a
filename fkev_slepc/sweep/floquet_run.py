"""``fkev floquet`` / ``Study.floquet``: Floquet multipliers over a speed range, unstable bands, labels.

One archive holds both verdicts of the same speeds (docs/stability.md, "Frozen-time and cycle verdicts"):

1. **Frozen sweep** (the root product, :func:`fkev_slepc.sweep.session.run_sweep`): the case at
   every (crank angle, speed) of the grid; it gives the frozen-time verdicts and the cycle-mean
   frozen frequencies ω̄ₖ(Ω) = mean over θ of Im λₖ(θ, Ω) that label the bands.
2. **Floquet product** (``/floquet``, :data:`fkev_slepc.archive.products.FLOQUET`): one monodromy per
   (speed, case) unit (``floquet_multipliers`` of the solve stage's linkage engine, the exact periodic
   coefficients), units dealt to the MPI ranks by :func:`fkev_slepc.sweep.units.run_units` and
   resumable like the sweep (``resume``: only pending speeds are solved; the run's
   :class:`~fkev_slepc.periodic.settings.PeriodicSettings` are archived whole in ``/floquet/settings``
   and a resume with other settings is refused before any work, :func:`refuse_changed_settings`).
3. **Gaps and probes**: the resonance candidates of order <= ``resonance_order`` (2ω̄ₖ/n,
   (ω̄ⱼ ± ω̄ₖ)/n) that fall between two stable grid speeds, where a band narrower than the spacing
   would go unseen (:func:`~fkev_slepc.periodic.bands.unsampled`); with ``probe`` one more
   monodromy at each, added to the grid's points for the bands.
4. **Bands** (:mod:`fkev_slepc.periodic.bands`): every bracket refined by the safeguarded
   interpolation of :mod:`fkev_slepc.periodic.edges`, all brackets together in rounds whose speeds
   are dealt to the ranks (two per bracket when fewer brackets than ranks are left); probes and refinement speeds
   are archived as they are solved (``/floquet/samples``, :mod:`fkev_slepc.sweep.floquet_samples`),
   so an interrupted refinement resumes where it stopped. The bands are labelled on rank 0 from ω̄ₖ
   interpolated to the band's centre, written to ``/floquet/bands``; then the archive is finalised.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace
from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.products_floquet import REDUCTION_ROWS
from fkev_slepc.archive.scene_text import heading
from fkev_slepc.archive.store import text as _text
from fkev_slepc.archive.writer import Block
from fkev_slepc.periodic.bands import (
    Band, Gap, SpeedPoint, brackets, bands_from, label, margin, unsampled,
)
from fkev_slepc.periodic.edges import refine_edges
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.results import FloquetResults
from fkev_slepc.periodic.settings import DEFAULTS, SAFETY, PeriodicSettings, resolve_reduce
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.scene.model import Damping
from fkev_slepc.status import Status
from fkev_slepc.sweep.floquet_samples import PURPOSES, Sampler, add_sample_rows, read_samples
from fkev_slepc.sweep.parallel import local
from fkev_slepc.sweep.product_run import (
    ProductRequest, finish, open_product, refuse_changed_settings, settings_attrs, solve_pending,
)
from fkev_slepc.sweep.progress import Progress
from fkev_slepc.sweep.units import pending

log = logging.getLogger(__name__)
MONODROMY_TOL = DEFAULTS.monodromy_tol  # relative error of Φ asked of the integrator
RESONANCE_ORDER = DEFAULTS.resonance_order  # candidates n <= this between stable grid speeds are reported
BAND_ATTRS = ("lower", "upper", "lower_open", "upper_open", "resonance", "predicted_speed", "peak_speed",
              "peak_max_abs", "suppressing_damping")


@dataclass(frozen=True)
class FloquetRequest(ProductRequest):
    """A Floquet run: ``scene`` with the speeds (``driver.speeds``, all > 0), the crank angles of the
    frozen sweep (``analysis.crank_angles_deg``) and the one case (``analysis.cases``) set.

    ``settings``: every tolerance (:class:`~fkev_slepc.periodic.settings.PeriodicSettings`; None: its
    defaults, ``reduce`` "default"); a field below that is given (not None) overrides
    its setting: ``tol`` verdict_tol, ``rtol`` edge_rtol, ``monodromy_tol``, ``resonance_order``,
    ``probe``, ``reduce``. :attr:`periodic` is the result, archived whole in ``/floquet/settings``."""

    tol: float | None = None
    rtol: float | None = None
    monodromy_tol: float | None = None
    resonance_order: int | None = None
    probe: bool | None = None  # one more monodromy at each resonance candidate between stable grid speeds
    reduce: int | str | None = None  # "none" (full model), "auto"/r (frozen modes), "links"/"links:N" (link components)
    settings: PeriodicSettings | None = None

    @property
    def periodic(self) -> PeriodicSettings:
        base = self.settings or DEFAULTS
        return base.with_overrides(verdict_tol=self.tol, edge_rtol=self.rtol, monodromy_tol=self.monodromy_tol,
                                   resonance_order=self.resonance_order, probe=self.probe, reduce=self.reduce)


def _evaluator(model, case: str, settings: PeriodicSettings, progress: bool = False, comm=None):
    """speed -> :class:`SpeedPoint` (not converged, with the message, if the solver raised). Reduced
    (``reduce``), the point's error adds the truncation change of max|μ| (so that it enters the verdict's
    margin), a truncation that did not converge makes the point not converged (its verdict is
    ``not_converged``, never ok: issue 27 item 1) and ``evaluate.reduction[speed]`` keeps the basis size
    and the truncation measures. With ``progress`` each speed's Magnus runs are reported on stderr
    (:class:`_SpeedProgress`). ``comm``: the ranks that share each monodromy's steps (collective evaluation)."""
    from fkev_slepc.sweep.runner import recoverable_errors

    def evaluate(speed: float) -> tuple[SpeedPoint, str]:
        report = _SpeedProgress(float(speed)) if progress else None
        try:
            res = floquet_multipliers(PeriodicSystem(model, float(speed), case), settings, comm=comm, progress=report)
        except recoverable_errors() as exc:
            return SpeedPoint(float(speed), np.zeros(0, complex), float("nan"), False), f"{type(exc).__name__}: {exc}"
        finally:
            if report is not None:
                report.close()
        point, t = SpeedPoint.of(speed, res), res.truncation
        if t is not None:
            evaluate.reduction[float(speed)] = {"basis": res.basis, "max_abs": t.max_abs, "converged": t.converged,
                                                "growth_rate": t.growth_rate, "frequency": t.frequency,
                                                "covered": np.nan if res.covered_rad_s is None else res.covered_rad_s}
            point = replace(point, error=point.error + t.max_abs * point.max_abs,
                            converged=point.converged and bool(t.converged))
        return point, ""

    evaluate.reduction = {}
    return evaluate


class _SpeedProgress:
    """A progress line per Magnus run of one speed (steps done / steps of the run, rate, ETA of the run;
    the step count doubles until the monodromy reaches its tolerance) once the speed has taken
    ``QUIET_S`` seconds: sweep/progress.Progress (a tqdm bar on a terminal, else a line every 10 s)."""

    QUIET_S = 5.0  # a speed solved faster says nothing

    def __init__(self, speed: float):
        self.speed, self.bar, self.steps, self.t0 = speed, None, None, time.monotonic()

    def __call__(self, done: int, steps: int) -> None:
        if time.monotonic() - self.t0 < self.QUIET_S:
            return
        if steps != self.steps:
            self.close()
            self.bar, self.steps = Progress(steps, label=f"fkev floquet: {self.speed:g} rad/s, run of {steps} Magnus "
                                            "steps", unit="steps"), steps
        self.bar(done, steps)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _not_converged(reduced: dict | None) -> str:
    """Why a speed is not converged: the frozen-mode truncation (with its change) or the monodromy."""
    if reduced and not reduced["converged"]:
        return (f"frozen-mode truncation did not converge (basis of {int(reduced['basis'])} vectors, change of "
                f"max|μ| {float(reduced['max_abs']):.2g}); solve this speed with --reduce none or a larger --reduce")
    return "monodromy did not reach its tolerance"


def _status(point: SpeedPoint, message: str, tol: float) -> int:
    if message:
        return Status.FAILED.code
    m = margin(point, tol)
    if not np.isfinite(m):
        return Status.NOT_CONVERGED.code
    return (Status.UNSTABLE if m > 0 else Status.OK).code


def run_floquet(request: FloquetRequest, comm=None, notify=None, progress: bool = False, evaluator=None) -> Path:
    """Collective over ``comm`` (None: this process alone). Returns the finished archive's path.

    ``evaluator(model, case, monodromy_tol)`` -> ``evaluate(speed) -> (SpeedPoint, message)``
    replaces the linkage monodromy (tests put a system with known bands through the same run)."""
    from fkev_slepc.model.operators import Model
    comm = local(comm)
    t0 = time.monotonic()
    sc, out = request.scene, Path(request.output)
    ps = request.periodic  # a bad setting: SettingsError naming it, before any work
    request.run_frozen_sweep(comm, notify, progress)
    if request.resume:  # the archived settings compared whole: a difference refused before the product's work
        refuse_changed_settings(out, P.FLOQUET, ps, comm)
    model = Model(sc, (request.case,), plane=request.plane) if request.model is None else request.model
    n_index = 2 * model.n_free
    part, status = open_product(out, P.FLOQUET, {P.F_INDEX: np.arange(1, n_index + 1)}, _settings(request, ps),
                                request.resume, comm, same=lambda p: _index_size(p) == n_index,
                                attrs=settings_attrs(P.FLOQUET, ps))
    speeds = np.asarray(sc.driver.speeds, dtype=float)
    evaluate = evaluator(model, request.case, ps.monodromy_tol) if evaluator else _evaluator(
        model, request.case, ps, progress=notify is not None)
    todo = pending(status)
    # fewer speeds than ranks: every rank works on each speed, its monodromy's steps split over them
    split = evaluator is None and comm.size > 1 and 0 < int(todo.sum()) < comm.size
    grid_evaluate = _evaluator(model, request.case, ps,
                               progress=notify is not None and comm.rank == 0, comm=comm) if split else evaluate

    def solve(unit, mask):
        js, jc = unit
        point, message = grid_evaluate(speeds[js])
        code = _status(point, message, ps.verdict_tol)
        mu = np.full(n_index, P.CNAN)
        mu[: point.multipliers.size] = point.multipliers
        data = {P.MULTIPLIER.path: mu, P.MAX_ABS_MULTIPLIER.path: np.array(point.max_abs),
                P.MULTIPLIER_ERROR.path: np.array(point.error)}
        reduced = getattr(grid_evaluate, "reduction", {}).get(float(speeds[js]))
        if reduced:
            data.update({v.path: np.array(reduced[v.source], dtype=v.dtype) for v in REDUCTION_ROWS})
        errors = [((js, jc), code, message or _not_converged(reduced))] if code in (
            Status.FAILED.code, Status.NOT_CONVERGED.code) else []
        return Block(unit, mask, data, np.array(code, np.uint8), errors)

    if notify is not None and comm.rank == 0:
        notify(f"floquet: {int(todo.sum())} of {todo.size} speed(s) to solve"
               + (f", each monodromy split over {comm.size} ranks" if split else ""))
    solve_pending(part, out, P.FLOQUET, todo, solve, comm, n_unit_axes=2, notify=notify, label="speeds",
                  collective=split)
    grid = _read_grid(part, speeds) if comm.rank == 0 else None
    grid = comm.bcast(grid, root=0)
    mean = _mean_frequencies(part) if comm.rank == 0 else None
    gaps = comm.bcast(unsampled(grid, mean, ps.resonance_order, ps.verdict_tol) if comm.rank == 0 else None)
    if comm.rank == 0:
        add_sample_rows(part)
    cmd = request.command_line
    sampler = Sampler(part, out, evaluate, lambda p, msg: _status(p, msg, ps.verdict_tol), comm, n_index, notify,
                      cmd + ("" if " --resume" in cmd else " --resume") if cmd else "")
    with sampler.stop:
        probes = sampler([g.resonance.speed for g in gaps], "probe") if ps.probe else []
        points = sorted(grid + probes, key=lambda p: p.speed)
        pairs = brackets(points, ps.verdict_tol)
        if notify is not None and comm.rank == 0 and (probes or pairs):
            notify(f"floquet: {len(probes)} resonance probe(s), {len(pairs)} band edge(s) to refine "
                   f"({sampler.resumed} speed(s) beside the grid already archived)")
        edges = refine_edges(points, pairs, lambda ws: sampler(ws, "edge"), sampler.known, ps.verdict_tol,
                             ps.edge_rtol, ranks=comm.size)
    bands = bands_from(points, edges, ps.verdict_tol)
    if comm.rank == 0:
        bands = label(bands, mean)
        _write_bands(part, bands)
    return finish(part, out, request.command_line, t0, comm)


def _settings(request: FloquetRequest, ps: PeriodicSettings) -> dict:
    """The ``/floquet`` group's attributes read back by :func:`read_floquet` (the whole settings: its
    ``settings`` group)."""
    return {"tol": ps.verdict_tol, "rtol": ps.edge_rtol, "monodromy_tol": ps.monodromy_tol,
            "safety": SAFETY, "analysed_case": request.case, "resonance_order": ps.resonance_order,
            "probe_resonances": int(ps.probe), "reduce": str(resolve_reduce(ps.reduce))}


def _index_size(part) -> int:
    """The multipliers per speed of the archived product (a resume keeps its speeds only at the same size)."""
    with h5py.File(part, "r") as f:
        return int(f[P.F_INDEX].shape[0])


def _read_grid(part, speeds) -> list[SpeedPoint]:
    """The archived grid of case 0 as points (failed and not-converged ones not converged)."""
    with h5py.File(part, "r") as f:
        mu = f[P.MULTIPLIER.path][:, 0, :]
        err = f[P.MULTIPLIER_ERROR.path][:, 0]
        st = np.asarray(f[P.F_STATUS.path][:, 0], dtype=np.uint8)
    ok = np.isin(st, [Status.OK.code, Status.UNSTABLE.code])
    return [SpeedPoint(float(w), m[np.isfinite(m)], float(e), bool(c)) for w, m, e, c in zip(speeds, mu, err, ok)]


def _mean_frequencies(part):
    """speed -> ω̄ₖ (rad/s): the frozen sweep's sorted Im λ at each grid speed (case 0) averaged
    over one revolution by :func:`fkev_slepc.periodic.cycle_mean.cycle_mean` (angle-weighted, 0° and
    360° counted once, unconverged angles left out), interpolated linearly in speed."""
    from fkev_slepc.periodic.cycle_mean import cycle_mean
    from fkev_slepc.status import CONVERGED, codes

    with h5py.File(part, "r") as f:
        freq = f[P.FREQUENCY.path][:, :, 0, :]  # (angle, speed, mode), Hz
        conv = np.isin(np.asarray(f[P.STATUS_VAR.path][:, :, 0], dtype=np.uint8), codes(CONVERGED))
        speeds, angles = f[P.SPEED][()], f[P.ANGLE][()]
    mean = cycle_mean(angles, 2.0 * np.pi * np.where(conv[..., None], freq, np.nan), 360.0)  # (speed, mode)

    def at(speed: float):
        return [float(np.interp(speed, speeds[np.isfinite(col)], col[np.isfinite(col)]))
                for col in mean.T if np.any(np.isfinite(col))]

    return at


def _write_bands(part, bands: list[Band]) -> None:
    rows = {v.source: v for v in P.BAND_ROWS if v.source}
    with h5py.File(part, "r+") as f:
        n = len(bands)
        f[P.F_BAND].resize((n,))
        f[P.F_BAND][...] = np.arange(1, n + 1, dtype="i4")
        for name in BAND_ATTRS:
            ds = f[rows[name].path]
            ds.resize((n,))
            if n:
                vals = [getattr(b, name) for b in bands]
                ds[...] = vals if rows[name].dtype == P.STRING else np.asarray(vals, dtype=ds.dtype)


def read_floquet(path) -> FloquetResults:
    """The Floquet product of an archive (case 0) with its bands and the frozen-time share of
    unstable crank angles at each speed. Verified first (``archive.reader.checked``: a damaged
    archive warns, one that cannot be decoded or is being written raises ArchiveError)."""
    from fkev_slepc.archive.verified import checked

    path = checked(path)
    with h5py.File(path, "r") as f:
        g = f[P.FLOQUET.name]
        cols = {v.source: f[v.path][()] for v in P.BAND_ROWS if v.source and v.path in f}  # older: fewer rows
        n = f[P.F_BAND].shape[0]
        bands = tuple(Band(**{k: (_text(cols[k][i]) if k == "resonance" else
                                  bool(cols[k][i]) if k.endswith("_open") else float(cols[k][i]))
                              for k in BAND_ATTRS if k in cols}) for i in range(n))
        st = np.asarray(f[P.STATUS_VAR.path][:, :, 0], dtype=np.uint8)
        frozen = np.mean(np.isin(st, [Status.UNSTABLE.code, Status.DIVERGENT.code]), axis=0)
        tol, order = float(g.attrs["tol"]), int(g.attrs.get("resonance_order", RESONANCE_ORDER))
        title = heading(_text(f.attrs.get("title", path.stem)), np.atleast_1d(f.attrs.get("elements", ())),
                        _text(f.attrs.get("scene_toml", "")))  # the mesh analysed, where re-meshed
        res = FloquetResults(path, title, _text(g.attrs["analysed_case"]), f[P.SPEED][()],
                             f[P.MULTIPLIER.path][:, 0, :], f[P.MAX_ABS_MULTIPLIER.path][:, 0],
                             f[P.MULTIPLIER_ERROR.path][:, 0], np.asarray(f[P.F_STATUS.path][:, 0], np.uint8), bands,
                             tol, float(g.attrs["rtol"]), frozen, resonance_order=order,
                             reduction={v.path.rsplit("/", 1)[1]: np.asarray(f[v.path][:, 0], float)
                                        for v in REDUCTION_ROWS if v.path in f},
                             damping=Damping(float(f.attrs.get("damping_alpha", 0.0)),
                                             float(f.attrs.get("damping_beta", 0.0))),
                             zeta_floor=float(g["settings"].attrs.get("zeta_floor", DEFAULTS.zeta_floor))
                             if "settings" in g else DEFAULTS.zeta_floor)
    samples = read_samples(path)
    mean = _mean_frequencies(path)
    gaps = unsampled(_read_grid(path, res.speed_rad_s), mean, order, tol)
    return replace(res, gaps=tuple(_probed(gap, samples.get(gap.resonance.speed), tol) for gap in gaps),
                   samples={k: sum(p == k for _s, p in samples.values()) for k in PURPOSES},
                   modal_zeta=_modal_zeta(res.damping, [mean(w) for w in res.speed_rad_s]))


def _modal_zeta(damping: Damping, mean_frequencies: list) -> tuple:
    """(min, max) of the scene damping's modal ζ(ω̄ₖ) over the cycle-mean frozen frequencies of
    every grid speed; () undamped or without frequencies."""
    w = np.concatenate([np.asarray(m, dtype=float) for m in mean_frequencies]) if mean_frequencies else np.empty(0)
    z = damping.ratio(w[np.isfinite(w) & (w > 0)]) if damping.active else np.empty(0)
    return (float(z.min()), float(z.max())) if z.size else ()


def _probed(gap: Gap, sample, tol: float) -> Gap:
    """``gap`` with the verdict of the probe solved at its speed, if any."""
    if sample is None:
        return gap
    m = margin(sample[0], tol)
    verdict = Status.NOT_CONVERGED if not np.isfinite(m) else Status.UNSTABLE if m > 0 else Status.OK
    return replace(gap, probe_max_abs=sample[0].max_abs, probe_status=verdict.value)
