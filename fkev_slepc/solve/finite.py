"""Problems whose numbers do not fit in double precision: refused by every engine as a point
failure (``failed``, with the reason), never a traceback; ``fkev check`` refuses such scenes first.

A scene may hold finite values whose operators are not: a crank speed of 1e155 rad/s (Ω² = 1e310),
an area of 1e300 m² (EA/l), a density of 1e-300 kg/m³ (ω² = K_ii/M_ii ~ 1e313). The QEP is
refused when any matrix entry is not finite or reaches :data:`MAX_ENTRY`, or when the
stiffness-to-mass scale max K_ii/M_ii, of the order of the largest |λ|², reaches :data:`MAX_LAMBDA_SQUARED` (products like λ²Mx and
the companion pencil of the dense engine then overflow).
"""

from __future__ import annotations

import numpy as np
from fkev_slepc.model.operators import AssemblyError, Model
from fkev_slepc.scene import Problem

# λ² up to this size leaves room for the products λ²·‖M‖·‖x‖, λ⁴ (quadratic roots) and the
# scaling of the dense engine (1e300 would already overflow λ⁴ = 1e600 in np.roots' companion).
MAX_LAMBDA_SQUARED = 1e150
# Matrix entries up to this size: norms of products (sums of squares, the pair error) stay finite.
MAX_ENTRY = 1e100


class NonFiniteProblem(FloatingPointError):
    """A QEP whose operators (or whose eigenvalues) overflow double precision; a point failure."""


def operator_problem(qep) -> str:
    """'' or why ``qep`` (sparse or dense) cannot be solved in double precision."""
    names = (("M", qep.mass), ("C", qep.damping), ("K", qep.stiffness))
    for name, A in names:
        if A is None:
            continue
        data = A.data if hasattr(A, "indptr") else np.asarray(A)
        bad = np.count_nonzero(~np.isfinite(data))
        if bad:
            return (f"{name} has {bad} non-finite entries (inf/NaN): the operators overflow double precision "
                    "(a crank speed, density, modulus or section too large or too small)")
        big = float(np.abs(data).max()) if data.size else 0.0
        if not big < MAX_ENTRY:
            return (f"{name} has entries up to {big:.3g} (>= {MAX_ENTRY:g}): products of the operators overflow "
                    "double precision (a crank speed, density, modulus or section too large)")
    m, k = np.abs(qep.mass.diagonal()), np.abs(qep.stiffness.diagonal())
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = np.where(m > 0, k / np.where(m > 0, m, 1.0), 0.0)
    worst = float(ratio.max()) if ratio.size else 0.0
    if not worst < MAX_LAMBDA_SQUARED:
        return (f"stiffness/mass scale max K_ii/M_ii = {worst:.3g} 1/s² (>= {MAX_LAMBDA_SQUARED:g}): the eigenvalues "
                "overflow double precision (a density, modulus or section too large or too small)")
    return ""


def require_finite(qep) -> None:
    """Raise :class:`NonFiniteProblem` when :func:`operator_problem` finds one."""
    why = operator_problem(qep)
    if why:
        raise NonFiniteProblem(why)


def overflow_problems(scene, model=None) -> list:
    """Problems (``scene.Problem``) of a scene whose operators overflow: the QEP of every case at
    the first crank angle of the scene's that assembles and the largest crank speed, judged by
    :func:`operator_problem` (none where no angle assembles: the command's own assembly check names
    those). A problem of the ``structure`` case (no speed in it) names the links, else the crank speeds.
    ``model``: an in-plane model of ``scene`` assembling the terms of every case (default a new one)."""
    cases = tuple(scene.analysis.cases)
    speeds = np.abs(np.asarray(scene.driver.speeds, dtype=float))
    top = float(speeds.max()) if speeds.size else 0.0
    with np.errstate(all="ignore"):  # the overflow is the finding, not a warning
        if model is None:
            model = Model(scene, cases=tuple(dict.fromkeys(("structure", *cases))))
        pieces = _assembled_pieces(model, scene.analysis.crank_angles_deg)
        if pieces is None:
            return []
        still = operator_problem(model.qep(pieces, 0.0, "structure"))
        if still:
            return [Problem("links", f"{still} (the structure at rest, no crank speed involved)")]
        out = []
        for case in cases:
            why = operator_problem(model.qep(pieces, top, case))
            if why:
                out.append(Problem("driver.speeds", f"case {case} at {top:g} rad/s: {why}"))
                break  # one line: the speed is the cause for every case it breaks
    return out


def _assembled_pieces(model, angles_deg):
    """The model's pieces at the first of ``angles_deg`` at which the linkage assembles, else None."""
    for a in angles_deg:
        try:
            return model.pieces(np.radians(a))
        except AssemblyError:
            continue
    return None
