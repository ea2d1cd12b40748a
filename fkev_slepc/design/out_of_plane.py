"""The out-of-plane half of the design check (docs/design.md, "Out of plane"): the lowest
frequency of the out-of-plane problem (bending about the weak axis and torsion, docs/theory.md §19)
over the cycle at the design speed, its margin to the crank orders, and the smallest weak-axis
buckling factor of the links.

The frequency is frozen-time: at every checked crank angle the out-of-plane QEP of the case
(``Model(scene, plane="out")``, the problem of ``fkev point --plane out``) is solved for its
lowest mode with the scene's solver; the lowest of these over the angles, and the angle where it
is reached, are reported. The crank orders n·Ω/2π are compared with that mode's band over the
cycle by the rule of ``fkev margins`` (:func:`fkev_slepc.design.margins.mode_margin`: the margin of
an order outside the band is its distance from the band over the band edge it approaches, 0 for
an order inside). At an angle where the frozen out-of-plane problem is divergent (a real
λ > 0: weak-axis buckling of a compressed link under the kinetostatic axial force, §19.6) it has
no lowest frequency; such angles are listed. A scene without every link's out-of-plane section
data is not checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fkev_slepc.design.margins import ModeMargin, mode_margin
from fkev_slepc.status import json_number

NOT_CHECKED = "not checked (no out-of-plane section)"


@dataclass(frozen=True)
class OutOfPlaneCheck:
    """The lowest out-of-plane frequency over the checked angles at one speed, and its margins."""

    angles_deg: np.ndarray  # the checked crank angles
    f1_hz: np.ndarray  # the lowest out-of-plane frequency at each (NaN: divergent or not converged)
    divergent_deg: tuple[float, ...]  # angles where the frozen out-of-plane problem is divergent
    band: ModeMargin  # f1 over the angles against the crank orders (its ``closest``: None at Ω = 0)
    buckling_sf: float | None  # the smallest weak-axis buckling factor of the links (None: none in compression)
    buckling_link: str | None  # its link

    def as_dict(self) -> dict:
        b = self.band.as_dict()
        return {"checked": True, "n_angles": int(self.angles_deg.size), "f1_min_hz": b["f_min_hz"],
                "angle_min_deg": b["angle_min_deg"], "f1_max_hz": b["f_max_hz"], "angle_max_deg": b["angle_max_deg"],
                "closest_order": b["closest_order"], "margin_percent": b["margin_percent"],
                "closest_angles_deg": b["closest_angles_deg"], "orders_inside": b["orders_inside"],
                "below": b["below"], "above": b["above"], "divergent_angles_deg": list(self.divergent_deg),
                "buckling_sf": self.buckling_sf, "buckling_link": self.buckling_link,
                "f1_hz": [json_number(f) for f in self.f1_hz]}


def out_of_plane_check(scene, speed_rad_s: float, case: str, angles_deg, buckling,
                       model_for=None) -> OutOfPlaneCheck | None:
    """The :class:`OutOfPlaneCheck` of ``scene`` at ``speed_rad_s`` over ``angles_deg`` (deg, angles
    that assemble), ``buckling`` the links' :class:`~fkev_slepc.model.buckling.Buckling`; None
    when the scene has no out-of-plane section (:data:`NOT_CHECKED`). ``model_for(scene, cases, plane)``
    gives the out-of-plane model (default ``Model``: a new one)."""
    from fkev_slepc.model.mechanism import build_mechanism
    from fkev_slepc.model.out_of_plane import has_section
    from fkev_slepc.model.operators import Model
    from fkev_slepc.solve.engines import make_engine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.thresholds import SolveSettings
    from fkev_slepc.status import CONVERGED, Status

    if not has_section(build_mechanism(scene)):
        return None
    a = np.asarray(angles_deg, dtype=float)
    model = (Model if model_for is None else model_for)(scene, (case,), "out")
    stack = model.piece_stack(np.radians(a))
    qeps = [model.qep(model.pieces_at(stack, i), float(speed_rad_s), case) for i in range(a.size)]
    settings = SolveSettings.from_scene(scene)
    engine = make_engine(scene.solver.method, model.n_free, scene.solver.petsc, settings=settings)
    try:
        sols = [postprocess(s, 1, settings.imag_tol, settings.damping_tol) for s in engine.solve_many(qeps, 1)]
    finally:
        engine.close()
    ok = [s.status in CONVERGED and s.status != Status.DIVERGENT for s in sols]
    f1 = np.array([s.frequency_hz[0] if good else np.nan for s, good in zip(sols, ok)], dtype=float)
    divergent = tuple(float(x) for x, s in zip(a, sols) if s.status == Status.DIVERGENT)
    base = abs(float(speed_rad_s)) / (2 * math.pi)
    top = np.nanmax(f1) if np.isfinite(f1).any() else 0.0
    orders = np.arange(1, int(math.floor(top / base)) + 2) if base > 0 else np.arange(0)
    band = mode_margin(1, a, f1, orders, base)
    compressed = [b for b in buckling if b.factor is not None]
    low = min(compressed, key=lambda b: b.factor) if compressed else None
    return OutOfPlaneCheck(a, f1, divergent, band, None if low is None else low.factor,
                           None if low is None else low.link)
