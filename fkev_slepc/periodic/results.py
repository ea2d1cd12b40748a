"""What ``Study.floquet`` / ``fkev floquet`` return: :class:`FloquetResults` (read from the archive by
:func:`fkev_slepc.sweep.floquet_run.read_floquet`), with the JSON of ``fkev floquet --json``."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fkev_slepc.periodic.bands import Band, Gap, survives_damping
from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.scene.model import Damping
from fkev_slepc.status import Status, json_list, json_number

INTEGER_ROWS = ("basis_size", "truncation_converged")  # reduction rows given as integers in the JSON


@dataclass(frozen=True)
class FloquetResults:
    """What a Floquet archive holds (the JSON of ``fkev floquet --json``)."""

    path: Path
    title: str
    case: str
    speed_rad_s: np.ndarray
    multipliers: np.ndarray  # (speed, index) complex, NaN padding
    max_abs: np.ndarray
    error: np.ndarray
    status: np.ndarray  # codes
    bands: tuple[Band, ...]
    tol: float
    rtol: float
    frozen_unstable_fraction: np.ndarray  # per speed: share of crank angles frozen-time unstable or divergent
    extras: dict = field(default_factory=dict)  # e.g. the frozen-time critical speeds
    resonance_order: int = 0  # candidates of order n <= this between stable speeds are the gaps
    gaps: tuple[Gap, ...] = ()  # resonance candidates between stable grid speeds (probed or not)
    samples: dict = field(default_factory=dict)  # purpose -> monodromies archived beside the grid
    reduction: dict = field(default_factory=dict)  # /floquet/basis_size, truncation_* name -> per-speed values
    damping: Damping = field(default_factory=Damping)  # the scene's Rayleigh damping, which the monodromies include
    zeta_floor: float = DEFAULTS.zeta_floor  # an undamped scene's reporting floor (PeriodicSettings.zeta_floor)
    modal_zeta: tuple = ()  # (min, max) of the scene damping's ζ(ω̄ₖ) over the frozen modes and grid speeds

    def survives(self, band: Band) -> bool | None:
        """Whether ``band`` stays open under the damping this run answers for (:func:`survives_damping`)."""
        return survives_damping(band, self.damping.active, self.zeta_floor)

    def reduction_dict(self) -> dict:
        """The per-speed reduction rows; a speed solved on the full model (basis size 0) has no
        truncation: its ``truncation_*`` entries are null, not 0 ("not converged")."""
        full = np.asarray(self.reduction.get("basis_size", ()), dtype=float) == 0
        out = {}
        for k, col in self.reduction.items():
            vals = [v if v is None or k not in INTEGER_ROWS else int(v) for v in json_list(col)]
            out[k] = [None if k.startswith("truncation_") and i < full.size and full[i] else v
                      for i, v in enumerate(vals)]
        return out

    def damping_dict(self) -> dict:
        """What damping the verdicts answer for: the scene's own (with its modal ζ range) or, undamped,
        the reporting floor that the bands' ζ* are held against."""
        damped = self.damping.active
        z = [float(v) for v in self.modal_zeta] if damped and len(self.modal_zeta) == 2 else [None, None]
        return {"answers_for": "scene damping" if damped else "undamped scene, reporting floor",
                "mass_proportional_1_s": self.damping.mass_proportional,
                "stiffness_proportional_s": self.damping.stiffness_proportional,
                "zeta_floor": None if damped else self.zeta_floor, "modal_zeta_min": z[0], "modal_zeta_max": z[1]}

    def grid_inside(self, band: Band) -> list[float]:
        """The grid speeds in ``band``, rad/s: all unstable (a band is a run of consecutive unstable
        grid speeds, or a probe's, between refined edges); between them nothing was sampled."""
        w = np.asarray(self.speed_rad_s, dtype=float)
        lo = band.lower if np.isfinite(band.lower) else band.peak_speed
        hi = band.upper if np.isfinite(band.upper) else band.peak_speed
        return [float(v) for v in w[(w >= lo) & (w <= hi)]]

    def inside(self, band: Band) -> int:
        """How many grid speeds lie in ``band`` (1: the band is not resolved by the grid)."""
        return len(self.grid_inside(band))

    def as_dict(self) -> dict:
        num = json_number
        return {
            "scene": self.title, "case": self.case, "archive": str(self.path),
            "speed_rad_s": [float(w) for w in self.speed_rad_s],
            "multipliers": [[[float(z.real), float(z.imag)] for z in row if np.isfinite(z)] for row in self.multipliers],
            "max_abs_multiplier": [num(v) for v in self.max_abs],
            "multiplier_error": [num(v) for v in self.error],
            "status": [Status.from_code(c).value for c in self.status],
            "bands": [{**b.as_dict(), "grid_speeds_inside": self.inside(b), "unstable_grid_speeds_rad_s": self.grid_inside(b),
                       "survives_damping": self.survives(b)} for b in self.bands],
            "damping": self.damping_dict(),
            "bands_surviving_damping": sum(self.survives(b) is not False for b in self.bands),
            "tol": self.tol, "edge_rtol": self.rtol,
            "frozen_time_unstable_fraction": [num(v) for v in self.frozen_unstable_fraction],
            "resonance_order": self.resonance_order, "resonance_gaps": [g.as_dict() for g in self.gaps],
            "samples_beside_grid": dict(self.samples),
            **self.reduction_dict(),
            **self.extras,
        }
