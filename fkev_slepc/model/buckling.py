"""Weak-axis (out-of-plane) Euler buckling of the links under the kinetostatic axial force
(docs/design.md, "Weak-axis buckling").

A link whose out-of-plane section is known (scene/shapes.py: I_out) has the Euler load

    P_cr = π² E I_out / (K L)²

with K its ``buckling_length_factor`` (1: pinned ends about the weak axis; 0.5 fixed-fixed,
0.7 fixed-pinned, 2 fixed-free) and, for a stepped link, the smallest E I_out of its segments
(conservative). The margin is P_cr / |N_min| with N_min the most compressive rigid-body axial
force over the link's length and the crank cycle (fkev_slepc/model/joint_loads.py); a link never
in compression has no margin (None). Below :data:`WARN_BELOW` it is a warning.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

WARN_BELOW = 3.0  # a weak-axis margin below this is a warning


@dataclass(frozen=True)
class Buckling:
    """The weak-axis Euler margin of one link over the cycle."""

    link: str
    euler_load_n: float  # P_cr, N (NaN: no out-of-plane section)
    length_factor: float  # K
    min_axial_force_n: float  # N_min over the link and the cycle, N (tension > 0)
    s_m: float  # where N_min acts, m from the root
    crank_angle_deg: float  # when
    factor: float | None  # P_cr / |N_min| (None: never in compression or no I_out)

    def warning(self, threshold: float = WARN_BELOW) -> str | None:
        if self.factor is None or self.factor >= threshold:
            return None
        return (f"link {self.link!r}: weak-axis buckling factor {self.factor:.3g} < {threshold:g} (P_cr = "
                f"{self.euler_load_n:.6g} N with K = {self.length_factor:g}, N_min = {self.min_axial_force_n:.6g} N "
                f"at s = {self.s_m:g} m, θ = {self.crank_angle_deg:g}°)")

    def as_dict(self) -> dict:
        finite = np.isfinite(self.euler_load_n)
        return {"euler_load_n": float(self.euler_load_n) if finite else None, "length_factor": self.length_factor,
                "min_axial_force_n": self.min_axial_force_n, "s_m": self.s_m, "crank_angle_deg": self.crank_angle_deg,
                "buckling_sf": self.factor}


def euler_loads(mech) -> np.ndarray:
    """P_cr = π² min(E I_out) / (K L)² of every link (NaN where no segment gives I_out)."""
    out = np.full(mech.n_link, np.nan)
    axis_beam = np.array([mech.beam_link.tolist().index(lk) for lk in range(mech.n_link)])
    axis = mech.elem_beam == axis_beam[mech.elem_link]
    for lk, link in enumerate(mech.scene.links):
        ei = mech.elem_ei_out[(mech.elem_link == lk) & axis]
        if np.isfinite(ei).all():
            out[lk] = np.pi**2 * ei.min() / (link.buckling_length_factor * link.length) ** 2
    return out


def weak_axis_buckling(mech, loads) -> list[Buckling]:
    """The :class:`Buckling` of every link from the kinetostatics ``loads``
    (:class:`~fkev_slepc.model.joint_loads.JointLoads` over the cycle)."""
    p_cr = euler_loads(mech)
    out = []
    for lk, link in enumerate(mech.scene.links):
        s, N = loads.link_axial(lk)
        a, k = np.unravel_index(np.nanargmin(N), N.shape)
        n_min = float(N[a, k])
        factor = float(p_cr[lk] / -n_min) if n_min < 0 and np.isfinite(p_cr[lk]) else None
        out.append(Buckling(link.name, float(p_cr[lk]), link.buckling_length_factor, n_min, float(s[k]),
                            float(loads.crank_angle_deg[a]), factor))
    return out
