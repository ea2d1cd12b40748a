"""Signed extreme-fibre stress along whole links over the crank cycle (docs/response.md §4).

The points are both ends of every element of each link's axis beam
(:func:`~fkev_slepc.periodic.stations.element_end_stations`), each with its two faces:
σ₊ at +c and σ₋ at −c along the link's left normal. Per point and face the cycle gives σ_max,
σ_min, the mean σ_m = (σ_max + σ_min)/2 and the alternating part σ_a = (σ_max − σ_min)/2 (the
inputs of the fatigue factors, fkev_slepc/design/fatigue.py); per link the peak |σ|, where
(s, face) and when (crank angle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.periodic.stations import cycle_parts
from fkev_slepc.status import json_list

FACES = ("plus", "minus")  # the faces at +c and −c along the link's left normal


@dataclass(frozen=True)
class LinkStress:
    """σ₊, σ₋ at the element ends of every link over the crank angles."""

    link_names: tuple[str, ...]
    angle_deg: np.ndarray  # (n_θ,)
    point_link: np.ndarray  # (n_pt,) link index of each point
    point_s: np.ndarray  # (n_pt,) m from the link's root
    point_element: np.ndarray  # (n_pt,) element of each point
    sigma: np.ndarray  # (n_θ, n_pt, 2) signed stress of the faces (FACES order), Pa (NaN without c)

    @classmethod
    def from_stations(cls, sr, link_names, angle_deg) -> "LinkStress":
        """From a :class:`~fkev_slepc.periodic.stations.StationResponse` at element ends."""
        st = sr.stations
        return cls(tuple(link_names), np.asarray(angle_deg, float), np.array([p.link for p in st], dtype=int),
                   np.array([p.s for p in st]), np.array([p.element for p in st], dtype=int),
                   np.stack([sr.stress_plus, sr.stress_minus], axis=-1))

    def parts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(σ_max, σ_min, σ_m, σ_a) of every point and face over the cycle, each (n_pt, 2)."""
        return cycle_parts(self.sigma)

    def peak(self, link: int) -> dict | None:
        """The peak |σ| of ``link`` over its points, faces and the cycle: value, s, face and
        crank angle (None without fibre distances). Peaks equal to round-off (1e-12 relative) go to the
        first in (angle, point, face) order, so a symmetric section's two faces give the + face."""
        sel = np.flatnonzero(self.point_link == link)
        mag = np.abs(self.sigma[:, sel])
        if not np.isfinite(mag).any():
            return None
        first = np.flatnonzero(np.nan_to_num(mag, nan=-1.0).ravel() >= np.nanmax(mag) * (1.0 - 1e-12))[0]
        a, k, f = np.unravel_index(first, mag.shape)
        return {"stress_pa": float(mag[a, k, f]), "sigma_pa": float(self.sigma[a, sel[k], f]),
                "s_m": float(self.point_s[sel[k]]), "face": FACES[f], "crank_angle_deg": float(self.angle_deg[a]),
                "point": int(sel[k])}

    def as_dict(self) -> dict:
        """Per link: the peak and, per point, s and the cycle parts of both faces (lists)."""
        parts = dict(zip(("stress_max_pa", "stress_min_pa", "stress_mean_pa", "stress_alternating_pa"), self.parts()))
        out = {}
        for lk, name in enumerate(self.link_names):
            sel = self.point_link == lk
            if not sel.any():
                continue
            out[name] = {"peak": self.peak(lk), "s_m": json_list(self.point_s[sel]),
                         **{key: {face: json_list(x[sel, f]) for f, face in enumerate(FACES)} for key, x in parts.items()}}
        return out
