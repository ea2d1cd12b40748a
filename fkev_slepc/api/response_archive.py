"""``fkev response --speeds … -o`` / ``Study.response_vs_speed(..., output=...)``: the peak steady periodic
response of every station over a speed range, archived over MPI ranks and resumable (docs/response.md §5).

Like ``fkev floquet`` (and with its steps, :mod:`fkev_slepc.sweep.product_run`): the archive is the frozen
sweep of the same speeds and case (the root product), with the ``/response`` product
(:data:`fkev_slepc.archive.products.RESPONSE`) beside it: one unit of work per (speed, case), the response at
that speed by :func:`fkev_slepc.api.response_speeds.speed_peaks` (harmonic balance, and shooting when asked),
units dealt to the ranks by :func:`fkev_slepc.sweep.units.run_units`. A resume solves only the pending speeds
(refused, exit 2, when the archived periodic settings differ: ``/response/settings``, compared whole;
every speed again when the gravity or the stations differ); Ctrl-C stops every rank at the same sync with the
``.part`` resumable. :func:`read_response` reads it back as a
:class:`~fkev_slepc.api.response_speeds.SpeedResponse`, the forced resonances located from the archived
cycle-mean frequencies.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.api.pool import ModelPool
from fkev_slepc.archive import products as P
from fkev_slepc.archive.store import text as _text
from fkev_slepc.archive.writer import Block
from fkev_slepc.periodic.settings import SCAN, PeriodicSettings
from fkev_slepc.scene import Scene, SceneError
from fkev_slepc.scene.cases import case_name
from fkev_slepc.status import Status
from fkev_slepc.sweep.parallel import local
from fkev_slepc.sweep.product_run import (
    ProductRequest, finish, open_product, refuse_changed_settings, settings_attrs, solve_pending,
)
from fkev_slepc.sweep.units import pending
from fkev_slepc.status import json_number

OPTION_KEYS = ("angles_deg", "gravity_m_s2", "harmonics", "tol", "shoot", "stations", "reduce")


@dataclass(frozen=True)
class ResponseRequest(ProductRequest):
    """An archived response scan: ``scene`` with the speeds (``driver.speeds``, increasing, > 0) and the one
    case (``analysis.cases``) set; ``options`` those of :func:`fkev_slepc.api.response.study_response`
    (:data:`OPTION_KEYS`); ``modes`` the cycle-mean frozen frequencies kept per speed. ``periodic``:
    the :class:`~fkev_slepc.periodic.settings.PeriodicSettings` (default ``SCAN``), whose harmonics,
    harmonic_tol, shoot and response_angles_deg the options ``harmonics``, ``tol``, ``shoot`` and
    ``angles_deg`` override when given (:meth:`resolved`, archived whole in ``/response/settings``).
    ``model_for``: ``model_for(scene, cases, plane)`` gives the model of every speed's response (default
    ``Model``: new ones; :func:`archived_response_vs_speed` passes a pool's, the Study its own);
    ``model`` (:class:`~fkev_slepc.sweep.product_run.ProductRequest`) that of the frozen sweep and the stations."""

    options: dict = field(default_factory=dict)
    modes: int = 4
    periodic: PeriodicSettings | None = None
    model_for: object = field(default=None, compare=False, repr=False)

    def resolved(self) -> PeriodicSettings:
        o = self.options
        return (self.periodic or SCAN).with_overrides(harmonics=o.get("harmonics"), harmonic_tol=o.get("tol"),
                                                      shoot=o.get("shoot"), response_angles_deg=o.get("angles_deg"))

    def settings(self) -> dict:
        """The group attributes (JSON of the options as run; a resume redoes every speed when they differ,
        after :func:`refuse_changed_settings` refused any difference of the periodic settings)."""
        ps = self.resolved()
        opts = {**{k: self.options.get(k) for k in OPTION_KEYS}, "harmonics": ps.harmonics or None,
                "tol": ps.harmonic_tol, "shoot": ps.shoot, "angles_deg": list(ps.response_angles_deg)}
        return {"options": json.dumps(opts, sort_keys=True, default=float), "n_modes": int(self.modes),
                "analysed_case": self.case}


def _status(values: dict, ps: PeriodicSettings) -> int:
    from fkev_slepc.periodic.response import DOES_NOT_ATTRACT, response_verdict

    tol, fixed = ps.harmonic_tol, ps.harmonics != 0
    if not fixed and not values.get("response_error", values["harmonic_balance_error"]) <= tol:  # by the method
        return Status.NOT_CONVERGED.code
    grows = response_verdict(values["max_abs_multiplier"], values["multiplier_error"], ps.attract_tol) == DOES_NOT_ATTRACT
    return (Status.UNSTABLE if grows else Status.OK).code


def run_response(request: ResponseRequest, comm=None, notify=None, progress: bool = False) -> Path:
    """Collective over ``comm`` (None: this process alone). Returns the finished archive's path.

    Raises SceneError for bad options (before anything is solved), RunRefused as ``fkev run``,
    SweepInterrupted after Ctrl-C/SIGTERM (the ``.part`` holds the speeds finished so far)."""
    from fkev_slepc.api.response import chosen_stations
    from fkev_slepc.api.response_speeds import checked_speeds, speed_peaks
    from fkev_slepc.model.operators import Model
    from fkev_slepc.periodic.stations import default_stations
    from fkev_slepc.sweep.runner import recoverable_errors

    comm = local(comm)
    t0 = time.monotonic()
    sc, out, ps = request.scene, Path(request.output), request.resolved()
    opts = {k: v for k, v in request.options.items() if k not in ("harmonics", "tol", "shoot", "angles_deg")}
    speeds = checked_speeds(sc, sc.driver.speeds)
    request.run_frozen_sweep(comm, notify, progress)
    if request.resume:  # the archived settings compared whole: a difference refused before the product's work
        refuse_changed_settings(out, P.RESPONSE, ps, comm)
    model = Model(sc, (request.case,)) if request.model is None else request.model
    stations = chosen_stations(sc, model.mechanism, opts.get("stations"))
    stations = default_stations(model.mechanism) if stations is None else stations
    n_modes = min(int(request.modes), model.n_free)
    settings = request.settings()
    names = model.mechanism.link_names
    part, status = open_product(
        out, P.RESPONSE, {P.R_STATION: np.arange(len(stations), dtype="i4"),
                          P.R_MODE: np.arange(1, n_modes + 1, dtype="i4")}, settings, request.resume, comm,
        data={P.STATION_LINK.path: [names[st.link] for st in stations],
              P.STATION_S.path: np.array([st.s for st in stations])},
        same=lambda p: _settings_of(p) == settings, attrs=settings_attrs(P.RESPONSE, ps))
    rows = (P.PEAK_TRANSVERSE, P.PEAK_CHORD, P.PEAK_MOMENT, P.PEAK_STRESS)

    def solve(unit, mask):
        js, jc = unit
        try:
            values, r = speed_peaks(sc, float(speeds[js]), request.case, n_modes, model_for=request.model_for,
                                    settings=ps, **opts)
        except (SceneError, *recoverable_errors()) as exc:
            msg = "; ".join(p.message for p in exc.problems) if isinstance(exc, SceneError) else str(exc)
            return Block(unit, mask, {}, np.array(Status.FAILED.code, np.uint8),
                         [((js, jc), Status.FAILED.code, f"{type(exc).__name__}: {msg}")])
        values["multiplier_error"] = r.multiplier_error
        code = _status(values, ps)
        data = {v.path: np.asarray(values[v.source], float) for v in rows}
        data.update({P.R_MAX_ABS.path: np.array(values["max_abs_multiplier"]),
                     P.R_HARMONICS.path: np.array(values["harmonics"], "i4"),
                     P.R_HB_ERROR.path: np.array(values["harmonic_balance_error"]),
                     P.R_ERROR.path: np.array(values["response_error"]),
                     P.R_SHOOTING_STEPS.path: np.array(values["shooting_steps"], "i4"),
                     P.R_MEAN_FREQUENCY.path: np.asarray(values["mean_frequency_rad_s"], float)})
        what = "harmonic balance" if values["shooting_steps"] == 0 else "shooting"
        errors = [((js, jc), code, f"{what} error {values['response_error']:.2e} > tol "
                   f"{ps.harmonic_tol:g}")] if code == Status.NOT_CONVERGED.code else []
        return Block(unit, mask, data, np.array(code, np.uint8), errors)

    todo = pending(status)
    if notify is not None and comm.rank == 0:
        notify(f"response: {int(todo.sum())} of {todo.size} speed(s) to solve")
    report = (lambda done, total: notify(f"{done}/{total} response speeds")) if progress and notify else None
    solve_pending(part, out, P.RESPONSE, todo, solve, comm, n_unit_axes=2, notify=notify, label="speeds",
                  progress=report)
    return finish(part, out, request.command_line, t0, comm)


def archived_response_vs_speed(scene: Scene, speeds_rad_s, case: str, output, *, modes: int = 4, orders: int = 6,
                               resume: bool = False, force: bool = False, comm=None, solver: str | None = None,
                               command_line: str = "", notify=None, progress: bool = False, names=None,
                               settings=None, model_for=None, **options):
    """:func:`fkev_slepc.api.response_speeds.response_vs_speed` archived in ``output`` over the ranks of ``comm``
    (:func:`run_response`: one speed per unit of work, resumable);
    the same numbers, read back from the archive. ``model_for``: the models' source
    (``Study.response_vs_speed``: the study's pool; default a new pool of ``scene``, one model for the run)."""
    from fkev_slepc.periodic.steady import checked_model
    from fkev_slepc.api.response_speeds import checked_speeds
    from fkev_slepc.sweep.grid import configure

    names = names or {}
    speeds = checked_speeds(scene, speeds_rad_s, names)
    model_for = ModelPool(scene).model_for if model_for is None else model_for
    checked_model(scene, case, options.get("harmonics"), names, reduce=options.get("reduce"),  # before the frozen sweep
                  settings=settings or SCAN, model_for=model_for)
    case = case_name(case)
    sc = configure(scene, speeds=[float(w) for w in speeds], cases=[case])
    out = run_response(ResponseRequest(sc, Path(output), resume, force, solver, command_line,
                                       model=model_for(sc, (case,), "in"), options=options, modes=modes,
                                       periodic=settings, model_for=model_for), comm,
                       notify=notify, progress=progress)
    return read_response(out, orders)


def _settings_of(part) -> dict:
    with h5py.File(part, "r") as f:
        a = f[P.RESPONSE.name].attrs
        return {k: (_text(a[k]) if isinstance(a[k], (str, bytes)) else int(a[k])) for k in ("options", "n_modes",
                                                                                           "analysed_case") if k in a}


def read_response(path, orders: int = 6):
    """The ``/response`` product of an archive (case 0) as a :class:`SpeedResponse`; failed and pending
    speeds are NaN (their status: :func:`read_status`). Verified first (``archive.reader.checked``:
    a damaged archive warns, one that cannot be decoded or is being written raises ArchiveError)."""
    from fkev_slepc.api.response_speeds import SpeedResponse, forced_resonances
    from fkev_slepc.archive.verified import checked

    with h5py.File(checked(path), "r") as f:
        g = f[P.RESPONSE.name]
        labels = tuple(f"{_text(n)} @ {s:g} m" for n, s in zip(f[P.STATION_LINK.path][()], f[P.STATION_S.path][()]))
        speeds = f[P.SPEED][()]
        peaks = [f[v.path][:, 0, :] for v in (P.PEAK_TRANSVERSE, P.PEAK_CHORD, P.PEAK_MOMENT, P.PEAK_STRESS)]
        wbar = f[P.R_MEAN_FREQUENCY.path][:, 0, :]
        mu = f[P.R_MAX_ABS.path][:, 0]
        title, case = _text(f.attrs.get("title", Path(path).stem)), _text(g.attrs["analysed_case"])
        solutions = _solutions(f, g)
    return SpeedResponse(title, case, speeds, labels, *peaks, mu, wbar, tuple(forced_resonances(speeds, wbar, orders)),
                         solutions)


def _solutions(f, g) -> tuple[dict, ...]:
    """Per speed what the archive keeps of :meth:`~fkev_slepc.api.response.ResponseResult.solution`: ``method``,
    ``response_error``, ``tol``, ``converged`` (solved, and the error ≤ tol), ``harmonics``,
    ``harmonic_balance_error``, ``shooting_steps`` (an archive written before these: those it has)."""
    def column(var, default):
        return f[var.path][:, 0] if var.path in f else np.full(f[P.R_STATUS.path].shape[0], default)

    tol = float(json.loads(_text(g.attrs["options"])).get("tol", np.nan))
    steps, err = column(P.R_SHOOTING_STEPS, 0), column(P.R_ERROR, np.nan)
    hb, harm, st = f[P.R_HB_ERROR.path][:, 0], f[P.R_HARMONICS.path][:, 0], f[P.R_STATUS.path][:, 0]
    return tuple({"method": "harmonic balance" if s == 0 else "shooting", "response_error": json_number(e), "tol": json_number(tol),
                  "converged": bool(c in (Status.OK.code, Status.UNSTABLE.code) and e <= tol), "harmonics": int(h),
                  "harmonic_balance_error": json_number(b), "shooting_steps": int(s)}
                 for s, e, b, h, c in zip(steps, err, hb, harm, st))


def read_status(path) -> np.ndarray:
    """Status code of every speed (case 0) of the ``/response`` product."""
    with h5py.File(path, "r") as f:
        return np.asarray(f[P.R_STATUS.path][:, 0], np.uint8)

