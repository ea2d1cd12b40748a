"""The ``/response`` product's table (docs/archive.md, docs/response.md §5): the peak steady periodic
response of every station over the crank cycle, per (speed, case) unit (``fkev response --speeds … -o``,
fkev_slepc/api/response_archive.py), in the archive of the frozen sweep of the same speeds."""

from __future__ import annotations

import numpy as np

from fkev_slepc.archive.product_types import CASE, SPEED, STATUS, STRING, Product, Var, error_table

R_STATION, R_MODE = "response/station", "response/mode"
R_UNIT = (SPEED, CASE)
R_ERRORS = error_table("response/errors", ("speed", "case"))
STATION_LINK = Var("response/station_link", (R_STATION,), STRING, "1", "link of the station (scene name)")
STATION_S = Var("response/station_s_m", (R_STATION,), "f8", "m", "distance of the station from its link's root")
_PEAKS = (
    ("peak_transverse_m", "m", "max |transverse elastic displacement| over the cycle (link frame)"),
    ("peak_transverse_chord_m", "m", "max |deflection from the chord through the link's deflected ends| over the cycle"),
    ("peak_moment_n_m", "N m", "max |bending moment EI v''| over the cycle"),
    ("peak_stress_pa", "Pa", "max extreme-fibre stress |N|/A + |M| c/I over the cycle (NaN: no fibre distance)"),
)
PEAK_TRANSVERSE, PEAK_CHORD, PEAK_MOMENT, PEAK_STRESS = (
    Var(f"response/{name}", R_UNIT + (R_STATION,), "f8", units, long, np.nan, required=True, source=name)
    for name, units, long in _PEAKS)
R_MAX_ABS = Var("response/max_abs_multiplier", R_UNIT, "f8", "1", "largest |Floquet multiplier| of the monodromy "
                "(> 1: the periodic response does not attract; NaN without shooting)", np.nan, source="max_abs_multiplier")
R_HARMONICS = Var("response/harmonics", R_UNIT, "i4", "1", "harmonics of the balance", 0, source="harmonics")
R_HB_ERROR = Var("response/harmonic_balance_error", R_UNIT, "f8", "1",
                 "estimated relative truncation error of the harmonic balance", np.nan, source="harmonic_balance_error")
R_ERROR = Var("response/response_error", R_UNIT, "f8", "1", "estimated relative error of the response by the method "
              "that gave it (the harmonic balance's estimate, or the shooting's step doubling)", np.nan,
              source="response_error")
R_SHOOTING_STEPS = Var("response/shooting_steps", R_UNIT, "i4", "1", "Magnus steps of the shooting that gave the "
                       "response where the harmonic balance was abandoned (0: the harmonic balance gave it)", 0,
                       source="shooting_steps")
R_MEAN_FREQUENCY = Var("response/mean_frequency_rad_s", R_UNIT + (R_MODE,), "f8", "rad/s",
                       "cycle-mean frozen frequency (Im lambda of the frozen QEP, damping included, "
                       "angle-weighted over 24 angles of one revolution)", np.nan, required=True, source="mean_frequency_rad_s")
R_STATUS = Var("response/status", R_UNIT, STATUS, "1", "outcome of the speed", 0, required=True, source="status",
               attrs={"description": "ok: the periodic response was solved (and attracts, or was not shot); unstable: "
                                     "solved, some |mu| > 1 beyond its error (it does not attract); not_converged: the "
                                     "response's error estimate (response_error) missed the response group's tol; "
                                     "failed: the solver raised or the speed is an exact resonance (I - Phi singular)"})
RESPONSE = Product(
    name="response",
    unit_dims=R_UNIT,
    point_dims=(),
    status=R_STATUS.path,
    variables=(Var(R_STATION, (R_STATION,), "i4", "1", "station number", scale=True, required=True),
               Var(R_MODE, (R_MODE,), "i4", "1", "frozen mode number, by frequency", scale=True, required=True),
               STATION_LINK, STATION_S, PEAK_TRANSVERSE, PEAK_CHORD, PEAK_MOMENT, PEAK_STRESS, R_MAX_ABS, R_HARMONICS,
               R_HB_ERROR, R_ERROR, R_SHOOTING_STEPS, R_MEAN_FREQUENCY, R_STATUS) + R_ERRORS.rows,
    errors=R_ERRORS,
    groups={"response": "peak steady periodic response of every station over the crank cycle, per (speed, case) of "
                        "the root grid (whose frozen sweep is the same speeds); run settings as attributes",
            "response/errors": "messages of failed and not-converged speeds (one row per speed)",
            "response/settings": "every periodic tolerance of the run as attributes (PeriodicSettings.to_attrs, "
                                 "docs/archive.md \"Periodic settings\"), compared whole on --resume"},
)
