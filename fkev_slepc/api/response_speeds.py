"""Response vs speed (``fkev response --speeds``, ``Study.response_vs_speed``; docs/response.md §5):
the peak deflection, moment and stress of every station over a speed range, with the forced-
resonance speeds where n·Ω meets a cycle-mean frozen frequency ω̄ₖ(Ω) marked, and the Floquet
multipliers (|μ| > 1: the response does not attract) when shooting is asked for."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.api.pool import ModelPool
from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.status import json_list


@dataclass(frozen=True)
class SpeedResponse:
    title: str
    case: str
    speeds: np.ndarray  # (n_s,) rad/s
    station_labels: tuple[str, ...]
    peak_transverse: np.ndarray  # (n_s, n_st) max |v| over the cycle, m
    peak_chord: np.ndarray  # max |v - chord|, m
    peak_moment: np.ndarray  # max |M|, N m
    peak_stress: np.ndarray  # max |σ|, Pa (NaN without c)
    max_abs_multiplier: np.ndarray  # (n_s,) NaN without shooting
    mean_frequencies: np.ndarray  # (n_s, n_modes) cycle-mean frozen frequencies ω̄ₖ, rad/s
    resonances: tuple[dict, ...]  # {"speed_rad_s", "order", "mode", "frequency_rad_s"}
    solutions: tuple[dict, ...] = ()  # per speed: how it was solved and its truncation (ResponseResult.solution)

    def as_dict(self) -> dict:
        return {"scene": self.title, "case": self.case, "speed_rad_s": json_list(self.speeds),
                "stations": [{"station": lab, "peak_transverse_m": json_list(self.peak_transverse[:, k]),
                              "peak_transverse_chord_m": json_list(self.peak_chord[:, k]),
                              "peak_moment_n_m": json_list(self.peak_moment[:, k]),
                              "peak_stress_pa": json_list(self.peak_stress[:, k])}
                             for k, lab in enumerate(self.station_labels)],
                "max_abs_multiplier": json_list(self.max_abs_multiplier),
                "mean_frequencies_rad_s": [json_list(r) for r in self.mean_frequencies],
                "forced_resonances": list(self.resonances), "solution": list(self.solutions)}

    def save(self, path, attrs: dict | None = None):
        """HDF5 with dimension scales (``xarray.open_dataset(path, engine="h5netcdf")``)."""
        from fkev_slepc.archive.labelled import write_labelled

        coords = {"speed_rad_s": (self.speeds, "rad/s", "crank speed"),
                  "station": (list(self.station_labels), "1", "link @ distance from its root"),
                  "mode": (np.arange(1, self.mean_frequencies.shape[1] + 1), "1", "frozen mode, by frequency")}
        dims = ("speed_rad_s", "station")
        variables = {
            "peak_transverse_m": (dims, self.peak_transverse, "m", "max |transverse displacement| over the cycle"),
            "peak_transverse_chord_m": (dims, self.peak_chord, "m", "max |deflection from the chord| over the cycle"),
            "peak_moment_n_m": (dims, self.peak_moment, "N m", "max |bending moment| over the cycle"),
            "peak_stress_pa": (dims, self.peak_stress, "Pa", "max extreme-fibre stress over the cycle"),
            "max_abs_multiplier": (("speed_rad_s",), self.max_abs_multiplier, "1", "max |Floquet multiplier|"),
            "mean_frequency_rad_s": (("speed_rad_s", "mode"), self.mean_frequencies, "rad/s",
                                     "cycle-mean frozen frequency"),
        }
        meta = {"title": self.title, "case": self.case, "forced_resonances": list(self.resonances),
                "solution": list(self.solutions), **(attrs or {})}
        return write_labelled(path, "fkev-response-speeds", coords, variables, meta)

    def plot(self, bands=()):
        from fkev_slepc.plots.response import draw_speed_response

        return draw_speed_response(self, bands)


def forced_resonances(speeds, mean_w, orders: int = 6) -> list[dict]:
    """Speeds where n·Ω = ω̄ₖ(Ω) between two computed speeds (linear interpolation)."""
    out = []
    for k in range(mean_w.shape[1]):
        for n in range(1, orders + 1):
            g = n * speeds - mean_w[:, k]
            for i in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0):
                t = g[i] / (g[i] - g[i + 1])
                s = float(speeds[i] + t * (speeds[i + 1] - speeds[i]))
                out.append({"speed_rad_s": s, "order": n, "mode": k + 1,
                            "frequency_rad_s": float(mean_w[i, k] + t * (mean_w[i + 1, k] - mean_w[i, k]))})
    return sorted(out, key=lambda r: r["speed_rad_s"])


PEAK_FIELDS = ("peak_transverse_m", "peak_transverse_chord_m", "peak_moment_n_m", "peak_stress_pa")


def checked_speeds(scene: Scene, speeds_rad_s, names=None) -> np.ndarray:
    """The speeds as an array, or SceneError naming ``speeds_rad_s``: increasing, finite, > 0."""
    speeds = np.atleast_1d(np.asarray(speeds_rad_s, dtype=float))
    if speeds.size < 1 or not np.isfinite(speeds).all() or np.any(speeds <= 0) or np.any(np.diff(speeds) <= 0):
        raise SceneError(scene.source, [Problem((names or {}).get("speeds_rad_s", "speeds_rad_s"),
                                                f"must be increasing finite speeds > 0 rad/s (got {list(speeds)})")])
    return speeds


def speed_peaks(scene: Scene, speed: float, case: str, modes: int, names=None, model_for=None,
                **options) -> tuple[dict, object]:
    """The response at one speed reduced to what the speed scan keeps: ``(values, result)``,
    values by field (the four station peaks over the cycle (n_station,), ``max_abs_multiplier``,
    ``harmonics``, ``harmonic_balance_error``, ``response_error``, ``shooting_steps``, ``solution``
    (:meth:`~fkev_slepc.api.response.ResponseResult.solution`), ``mean_frequency_rad_s`` (min(modes, n_free),)),
    result the :class:`~fkev_slepc.api.response.ResponseResult` (options as there). ``model_for``:
    ``model_for(scene, cases, plane)`` gives the model of both (default ``Model``: new ones)."""
    from fkev_slepc.api.response import study_response
    from fkev_slepc.model.operators import Model
    from fkev_slepc.periodic.cycle_mean import cycle_mean_frequencies

    r = study_response(scene, float(speed), case, names=names, model_for=model_for, **options)
    sr = r.stations
    peaks = [np.nanmax(np.abs(x), axis=0) for x in (sr.transverse, sr.transverse_chord, sr.moment)]
    peaks.append(np.max(sr.stress, axis=0))
    model = (Model if model_for is None else model_for)(scene, (r.case,), "in")
    wbar = cycle_mean_frequencies(model, float(speed), r.case, min(modes, model.n_free))
    values = dict(zip(PEAK_FIELDS, peaks))
    values.update(max_abs_multiplier=r.max_abs_multiplier, harmonics=r.harmonics,
                  harmonic_balance_error=r.hb_error, response_error=r.error, shooting_steps=r.shooting_steps,
                  solution=r.solution(), mean_frequency_rad_s=wbar)
    return values, r


def station_labels(link_names, stations) -> tuple[str, ...]:
    return tuple(f"{link_names[st.link]} @ {st.s:g} m" for st in stations)


def response_vs_speed(scene: Scene, speeds_rad_s, case: str = "full", *, modes: int = 4, orders: int = 6,
                      names=None, settings=None, model_for=None, **options) -> SpeedResponse:
    """:func:`~fkev_slepc.api.response.study_response` at every speed (options as there; ``settings``
    default :data:`fkev_slepc.periodic.settings.SCAN`, harmonic_tol 1e-6), the station peaks, and the
    forced-resonance speeds; in this process (the archived run over MPI ranks:
    :func:`fkev_slepc.api.response_archive.run_response`). ``model_for``: the models' source
    (``Study.response_vs_speed``: the study's pool; default a new pool of ``scene``, one model for every speed)."""
    from fkev_slepc.periodic.settings import SCAN
    from fkev_slepc.periodic.steady import checked_model

    names = names or {}
    speeds = checked_speeds(scene, speeds_rad_s, names)
    settings = SCAN if settings is None else settings
    model_for = ModelPool(scene).model_for if model_for is None else model_for
    checked_model(scene, case, options.get("harmonics"), names, reduce=options.get("reduce"),  # before the first speed
                  settings=settings, model_for=model_for)
    options = {**options, "settings": settings}
    rows = []
    for w in speeds:
        values, r = speed_peaks(scene, float(w), case, modes, names, model_for, **options)
        rows.append(values)
    peaks = [np.array([row[k] for row in rows]) for k in PEAK_FIELDS]
    wbar = np.array([row["mean_frequency_rad_s"] for row in rows])
    mu = np.array([row["max_abs_multiplier"] for row in rows], dtype=float)
    return SpeedResponse(scene.title, r.case, speeds, station_labels(r.link_names, r.stations.stations), *peaks, mu,
                         wbar, tuple(forced_resonances(speeds, wbar, orders)), tuple(row["solution"] for row in rows))

