"""The ``/floquet`` product's table (docs/archive.md): Floquet multipliers of one crank revolution per
(speed, case) unit (``fkev floquet``, fkev_slepc/sweep/floquet_run.py), in the archive of the frozen sweep of
the same speeds, and the unstable speed bands found from them (fkev_slepc/periodic/bands.py)."""

from __future__ import annotations

import numpy as np

from fkev_slepc.archive.product_types import CASE, CNAN, SPEED, STATUS, STRING, Product, Var, error_table

F_INDEX, F_BAND, F_SAMPLE = "floquet/multiplier_index", "floquet/bands/band", "floquet/samples/sample"
FLOQUET_ERRORS = error_table("floquet/errors", ("speed", "case"))
MULTIPLIER = Var("floquet/multiplier", (SPEED, CASE, F_INDEX), "c16", "1",
                 "Floquet multiplier mu of one crank revolution, sorted by decreasing |mu|", CNAN, required=True,
                 source="multipliers")
MAX_ABS_MULTIPLIER = Var("floquet/max_abs_multiplier", (SPEED, CASE), "f8", "1",
                         "largest |mu|: amplitude factor per crank revolution of the fastest-growing solution", np.nan,
                         required=True, source="max_abs")
MULTIPLIER_ERROR = Var("floquet/multiplier_error", (SPEED, CASE), "f8", "1",
                       "estimated absolute error of the multipliers' moduli |mu| (monodromy step doubling; reduced model: plus the "
                       "truncation change of max|mu|)", np.nan, source="error")
BASIS_SIZE = Var("floquet/basis_size", (SPEED, CASE), "i4", "1",
                 "vectors of the reduced basis, frozen-mode or link components (0: the full model)", 0, source="basis")
REDUCTION_ROWS = (
    BASIS_SIZE,
    Var("floquet/truncation_max_abs", (SPEED, CASE), "f8", "1", "reduced model: relative change of max|mu| from "
        "the previous basis level (NaN: full model)", np.nan, source="max_abs"),
    Var("floquet/truncation_growth_rate", (SPEED, CASE), "f8", "1/s", "reduced model: change of the largest "
        "Floquet growth rate Re s from the previous basis level", np.nan, source="growth_rate"),
    Var("floquet/truncation_frequency", (SPEED, CASE), "f8", "1", "reduced model: largest relative change of a "
        "retained cycle-mean Floquet frequency from the previous basis level", np.nan, source="frequency"),
    Var("floquet/truncation_converged", (SPEED, CASE), "u1", "1", "reduced model: 1 if both changes were below "
        "the floquet group's reduce_tol twice in a row", 0, source="converged"),
    Var("floquet/covered_rad_s", (SPEED, CASE), "f8", "rad/s", "link-frame component modes (reduce links): highest "
        "retained fixed-interface frequency, the range of modes the verdict covers (NaN: full model or frozen-mode "
        "basis)", np.nan, source="covered"),
)
F_STATUS = Var("floquet/status", (SPEED, CASE), STATUS, "1", "outcome of the speed", 0, required=True,
               source="status", attrs={"description": "ok: max|mu| - 1 <= tol + 10 x multiplier_error (tol: the "
                                                      "floquet group's attribute); unstable above; not_converged: the "
                                                      "monodromy missed its tolerance; failed: the solver raised"})
_BAND = dict(growable=True, chunks=(64,))
BAND_ROWS = (
    Var(F_BAND, (F_BAND,), "i4", "1", "unstable speed band number", scale=True, **_BAND),
    Var("floquet/bands/lower_rad_s", (F_BAND,), "f8", "rad/s", "lower edge of the band", np.nan, source="lower",
        **_BAND),
    Var("floquet/bands/upper_rad_s", (F_BAND,), "f8", "rad/s", "upper edge of the band", np.nan, source="upper",
        **_BAND),
    Var("floquet/bands/lower_open", (F_BAND,), "u1", "1", "1: the band reaches the lowest speed examined",
        source="lower_open", **_BAND),
    Var("floquet/bands/upper_open", (F_BAND,), "u1", "1", "1: the band reaches the highest speed examined",
        source="upper_open", **_BAND),
    Var("floquet/bands/resonance", (F_BAND,), STRING, "1",
        "nearest resonance of the cycle-mean frozen frequencies: 2w_k/n, (w_j+w_k)/n or (w_j-w_k)/n",
        source="resonance", **_BAND),
    Var("floquet/bands/predicted_rad_s", (F_BAND,), "f8", "rad/s", "speed of that resonance", np.nan,
        source="predicted_speed", **_BAND),
    Var("floquet/bands/peak_rad_s", (F_BAND,), "f8", "rad/s", "grid speed of the largest max|mu| in the band",
        np.nan, source="peak_speed", **_BAND),
    Var("floquet/bands/peak_max_abs_multiplier", (F_BAND,), "f8", "1", "max|mu| there", np.nan,
        source="peak_max_abs", **_BAND),
    Var("floquet/bands/suppressing_damping_ratio", (F_BAND,), "f8", "1",
        "modal damping ratio that closes the band at its peak: 2 Re s/(w_j + w_k) (absent before this row existed)",
        np.nan, source="suppressing_damping", **_BAND),
)
_ROW = dict(growable=True, chunks=(64,))
SAMPLE_STATUS = Var("floquet/samples/status", (F_SAMPLE,), STATUS, "1", "outcome of the speed (as floquet/status; "
                    "written last: a row still pending was cut short and is solved again)", 0, source="status", **_ROW)
SAMPLE_ROWS = (  # every monodromy beside the grid, appended as it is solved: a resumed run re-uses them
    Var(F_SAMPLE, (F_SAMPLE,), "i4", "1", "extra speed number, in the order solved", scale=True, **_ROW),
    Var("floquet/samples/speed_rad_s", (F_SAMPLE,), "f8", "rad/s", "crank speed examined beside the grid", np.nan,
        source="speed", **_ROW),
    Var("floquet/samples/purpose", (F_SAMPLE,), STRING, "1",
        "edge: an evaluation of a band edge's refinement; probe: a resonance candidate between stable grid speeds",
        source="purpose", **_ROW),
    Var("floquet/samples/multiplier", (F_SAMPLE, F_INDEX), "c16", "1", "Floquet multipliers, by decreasing |mu|",
        CNAN, source="multipliers", growable=True),
    Var("floquet/samples/max_abs_multiplier", (F_SAMPLE,), "f8", "1", "largest |mu|", np.nan, source="max_abs",
        **_ROW),
    Var("floquet/samples/multiplier_error", (F_SAMPLE,), "f8", "1", "estimated absolute error of the multipliers' moduli |mu|",
        np.nan, source="error", **_ROW),
    SAMPLE_STATUS,
    Var("floquet/samples/message", (F_SAMPLE,), STRING, "1", "the solver's message of a failed speed", source="message",
        **_ROW),
)
FLOQUET = Product(
    name="floquet",
    unit_dims=(SPEED, CASE),
    point_dims=(),
    status=F_STATUS.path,
    variables=(Var(F_INDEX, (F_INDEX,), "i4", "1", "multiplier number, 1-based", scale=True, required=True),
               MULTIPLIER, MAX_ABS_MULTIPLIER, MULTIPLIER_ERROR, F_STATUS) + REDUCTION_ROWS + FLOQUET_ERRORS.rows
              + BAND_ROWS + SAMPLE_ROWS,
    errors=FLOQUET_ERRORS,
    groups={"floquet": "Floquet multipliers of the time-periodic linkage over one crank revolution, per (speed, "
                       "case) of the root grid (whose frozen sweep gives the cycle-mean frequencies of the labels)",
            "floquet/errors": "messages of failed and not-converged speeds (one row per speed)",
            "floquet/bands": "unstable speed bands, edges refined to the floquet group's rtol",
            "floquet/samples": "monodromies solved beside the grid: band-edge refinements and resonance probes",
            "floquet/settings": "every periodic tolerance of the run as attributes (PeriodicSettings.to_attrs, "
                                "docs/archive.md \"Periodic settings\"), compared whole on --resume"},
)
