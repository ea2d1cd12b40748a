"""``Study.runup``: the linkage along a prescribed crank history, integrated in time (PETSc TS), with
the per-revolution envelope of every link's deflection and stress (docs/theory.md §21, docs/runup.md).

The physics is in fkev_slepc/periodic/motion.py (the system) and fkev_slepc/periodic/runup.py (the
integration); this module checks the arguments before any work, gathers the envelopes, and writes
the HDF5 product whose checkpoints continue an interrupted run (``resume``) bit for bit.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.scene.validity import STATIONS_WITHOUT_SPEED, in_plane_only

SEGMENT_STEPS = 4096  # steps between checkpoints (each segment a fresh TS from the last state)
MIN_STEPS_PER_REVOLUTION = 8


@dataclass
class RunupResult:
    """Per crank revolution (its end): time, speed and every link's peak |deflection| and |σ|."""

    title: str
    scene_text: str
    case: str
    arguments: dict
    link_names: tuple[str, ...]
    time_s: list = field(default_factory=list)
    speed_rad_s: list = field(default_factory=list)
    peak_stress_pa: list = field(default_factory=list)  # per revolution (n_link,)
    peak_deflection_m: list = field(default_factory=list)
    steps: int = 0
    ts_type: str = "alpha2"
    interp_error: float = float("nan")
    coordinates: int = 0  # unknowns integrated (the model's DOFs or the reduced basis)
    last: object = None  # periodic.runup.Revolution: the last revolution's samples
    end_state: list = field(default_factory=list)  # (η, η̇) at each revolution's end (this session's revolutions)
    complete: bool = False

    def as_dict(self) -> dict:
        from fkev_slepc.status import json_number

        S, D = np.array(self.peak_stress_pa).reshape(-1, len(self.link_names)), \
            np.array(self.peak_deflection_m).reshape(-1, len(self.link_names))
        return {"scene": self.title, "case": self.case, **self.arguments, "steps": self.steps, "ts_type": self.ts_type,
                "interpolation_error": json_number(self.interp_error), "coordinates": self.coordinates,
                "complete": self.complete,
                "time_s": [float(x) for x in self.time_s], "speed_rad_s": [float(x) for x in self.speed_rad_s],
                "links": {name: {"peak_stress_pa": [json_number(x) for x in S[:, j]],
                                 "peak_deflection_m": [json_number(x) for x in D[:, j]]}
                          for j, name in enumerate(self.link_names)}}

    def plot(self, path=None, **options):
        """Envelope vs speed per link (fkev_slepc/plots/runup.py)."""
        from fkev_slepc.plots.runup import draw_runup

        return draw_runup(self, path, **options)


def checked_history(speed=None, revolutions=None, ramp=None, duration=None, names=None):
    """The CrankHistory of the arguments, or the Problems (naming ``names``' flags) of every bad one:
    either ``speed`` and ``revolutions`` (a constant speed ≠ 0, revolutions > 0) or ``ramp`` (w0, w1)
    and ``duration`` > 0 (not both speeds 0)."""
    from fkev_slepc.periodic.motion import CrankHistory

    names = names or {}
    nm = lambda k: names.get(k, k)  # noqa: E731
    bad = []
    fin = lambda x: isinstance(x, (int, float, np.floating, np.integer)) and not isinstance(x, bool) and np.isfinite(x)  # noqa: E731
    if (speed is None) == (ramp is None):
        bad.append(Problem(nm("speed"), f"give either {nm('speed')} with {nm('revolutions')} or {nm('ramp')} with "
                           f"{nm('duration')}"))
        return None, bad
    if speed is not None:
        if not fin(speed) or speed == 0:
            bad.append(Problem(nm("speed"), f"must be a finite crank speed ≠ 0, rad/s (got {speed!r})"))
        if revolutions is None or not fin(revolutions) or revolutions <= 0:
            bad.append(Problem(nm("revolutions"), f"must be a number of revolutions > 0 (got {revolutions!r})"))
        if duration is not None:
            bad.append(Problem(nm("duration"), f"goes with {nm('ramp')}, not with {nm('speed')}"))
        return (None if bad else CrankHistory.constant(float(speed), float(revolutions))), bad
    w = tuple(ramp) if isinstance(ramp, (tuple, list)) else ()
    if len(w) != 2 or not all(fin(x) for x in w) or w[0] == w[1] == 0:
        bad.append(Problem(nm("ramp"), f"must be two finite crank speeds W0:W1, rad/s, not both 0 (got {ramp!r})"))
    if duration is None or not fin(duration) or duration <= 0:
        bad.append(Problem(nm("duration"), f"must be a time > 0, s (got {duration!r})"))
    if revolutions is not None:
        bad.append(Problem(nm("revolutions"), f"goes with {nm('speed')}, not with {nm('ramp')}"))
    return (None if bad else CrankHistory.ramp(float(w[0]), float(w[1]), float(duration))), bad


def parse_ramp(text: str, flag: str = "--ramp"):
    """(W0, W1) of ``W0:W1``, or ValueError naming ``flag``."""
    parts = str(text).split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        return float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"{flag}: must be W0:W1, two crank speeds in rad/s (got {text!r})") from None


def checked_runup(scene: Scene, history_args: dict, case, reduce, steps_per_revolution, start, names=None):
    """(history, case name, resolved reduce) or one SceneError naming every bad argument, before any work."""
    from fkev_slepc.model.operating_point import full_turn_problems
    from fkev_slepc.periodic.limits import size_problems
    from fkev_slepc.periodic.motion import runup_reduction
    from fkev_slepc.periodic.runup import STARTS
    from fkev_slepc.scene.cases import case_name

    names = names or {}
    history, bad = checked_history(**history_args, names=names)
    try:
        case = case_name(case)
    except ValueError as err:
        bad.append(Problem(names.get("case", "case"), str(err)))
    try:
        reduce = runup_reduction(reduce)
    except ValueError as err:
        bad.append(Problem(names.get("reduce", "reduce"), str(err)))
    spr = steps_per_revolution
    if isinstance(spr, bool) or not isinstance(spr, (int, np.integer)) or spr < MIN_STEPS_PER_REVOLUTION:
        bad.append(Problem(names.get("steps_per_revolution", "steps_per_revolution"),
                           f"must be a whole number >= {MIN_STEPS_PER_REVOLUTION} (got {spr!r})"))
    if start not in STARTS:
        bad.append(Problem(names.get("start", "start"), f"must be one of {', '.join(STARTS)} (got {start!r})"))
    refusal = in_plane_only(scene, "the run-up's stress envelope: " + STATIONS_WITHOUT_SPEED)
    if refusal:
        bad.append(refusal)
    if scene.driver.acceleration != 0.0:
        bad.append(Problem("driver.acceleration_rad_s2", "the run-up prescribes its own crank history; the "
                           f"scene's frozen crank acceleration must be 0 (got {scene.driver.acceleration:g} rad/s²)"))
    bad += full_turn_problems(scene)
    bad += size_problems(scene, True, names=names)  # the periodic commands' one set of limits (as fkev runup's preflight)
    if bad:
        raise SceneError(scene.source, bad)
    return history, case, reduce


class _Envelope:
    """Per revolution: time and speed at its end and each link's peak |u, v| and |σ| over its samples
    (element ends of the link's axis beam; σ by the shape functions, periodic/stations.py)."""

    def __init__(self, model, history, result: RunupResult):
        from fkev_slepc.periodic.stations import element_end_stations

        self.model, self.history, self.result = model, history, result
        self.stations = element_end_stations(model.mechanism)
        self.link = np.array([s.link for s in self.stations])

    def __call__(self, rev) -> None:
        from fkev_slepc.periodic.stations import station_response

        sr = station_response(self.model, rev.theta, rev.q, self.stations)
        defl, stress = np.hypot(sr.axial, sr.transverse), sr.stress
        n_link = len(self.result.link_names)
        peak = lambda x: [float(np.nanmax(np.abs(x[:, self.link == j]))) if np.isfinite(x[:, self.link == j]).any()  # noqa: E731
                          else float("nan") for j in range(n_link)]
        r = self.result
        r.time_s.append(float(rev.t[-1]))
        r.speed_rad_s.append(float(self.history.speed(rev.t[-1])))
        r.peak_deflection_m.append(peak(defl))
        r.peak_stress_pa.append(peak(stress))
        r.last = rev
        r.end_state.append((rev.eta[-1].copy(), rev.eta_dot[-1].copy()))


def study_runup(scene: Scene, *, speed=None, revolutions=None, ramp=None, duration=None, case="full", reduce=None,
                start: str = "static", steps_per_revolution: int = 256, gravity_m_s2=None, damping: bool = True,
                output=None, resume: bool = False, segment_steps: int = SEGMENT_STEPS, progress=None, names=None,
                settings=None, model_for=None, tol: float = 1e-12) -> RunupResult:
    """The run-up of ``scene`` (docs/runup.md): a constant ``speed`` (rad/s) for ``revolutions`` or a
    linear ``ramp`` (W0, W1) over ``duration`` (s), from the rest deflection (``start`` static) or zero;
    ``reduce`` none, links, links:N, N or moving:R (the Floquet map's bases, at the largest speed of the
    history where they depend on it); ``output`` an HDF5 file rewritten at every checkpoint (every
    ``segment_steps`` steps), ``resume`` continues it; ``progress(t, duration)`` after every step."""
    from fkev_slepc.model.operators import Model
    from fkev_slepc.periodic.motion import MotionSystem, runup_basis
    from fkev_slepc.periodic.runup import Integration

    history, case, red = checked_runup(scene, dict(speed=speed, revolutions=revolutions, ramp=ramp, duration=duration),
                                       case, reduce, steps_per_revolution, start, names)
    gravity = np.asarray(scene.analysis.gravity_m_s2 if gravity_m_s2 is None else gravity_m_s2, float)
    model = (Model if model_for is None else model_for)(scene, (case,), "in")
    w_ref = max(abs(history.w0), abs(history.w1))
    basis = runup_basis(model, red, case, w_ref, settings or DEFAULTS)
    system = MotionSystem(model, case, damping=damping, gravity=gravity, basis=basis, tol=tol)
    args = {"history": "constant" if history.constant_speed else "ramp", "w0_rad_s": history.w0,
            "w1_rad_s": history.w1, "duration_s": history.duration, "reduce": "none" if red is None else str(red),
            "start": start, "steps_per_revolution": int(steps_per_revolution), "damping": bool(damping),
            "gravity_m_s2": gravity.tolist(), "segment_steps": int(segment_steps)}
    result = RunupResult(scene.title, scene.source_text, case, args, tuple(model.mechanism.link_names),
                         interp_error=system.error, coordinates=system.n)
    run = Integration(system, history, steps_per_revolution=int(steps_per_revolution), start=start,
                      on_revolution=_Envelope(model, history, result), progress=progress)
    if output is not None and resume and Path(output).exists():
        from fkev_slepc.archive.runup_store import read_checkpoint

        read_checkpoint(output, result, run)
    save = None
    if output is not None:
        from fkev_slepc.archive.runup_store import write_runup

        save = lambda r: write_runup(output, result, r)  # noqa: E731
    out = run.run(int(segment_steps), after_segment=save)
    result.steps, result.ts_type, result.complete = out.steps, out.ts_type, True
    if save is not None:
        save(run)
    return result
