"""When the Euler-Bernoulli element is outside its validity, and what the Timoshenko element needs
(docs/theory.md §22.1, §22.6). One place for both rules.

* :func:`slenderness_error` -- how far the Euler-Bernoulli bending frequency of mode n lies above
  Timoshenko's, ω_EB/ω_T - 1, from the simply supported beam's exact dispersion relation (§22.6).
* :func:`slenderness_warnings` -- a warning per link where it exceeds :data:`MAX_EB_ERROR` for
  the modes the scene asks for (n = ``analysis.modes``, a conservative bound), unless the scene
  already uses ``element = "timoshenko"``.
* :func:`timoshenko_problems` -- a Timoshenko scene whose link lacks the shear coefficient or the
  shear modulus, named by its field.
* :func:`in_plane_only` -- the refusal of an analysis that has no Timoshenko form yet (out-of-plane
  bending and torsion; station forces without an operating point, §22 limits).
"""

from __future__ import annotations

import math

from fkev_slepc.scene.model import Problem, Scene

MAX_EB_ERROR = 0.01  # 1 %: the Euler-Bernoulli frequency error above which a link is flagged
DEFAULT_KAPPA, DEFAULT_NU = 5.0 / 6.0, 0.3  # where the scene gives no κ or G (steel-like)
TIMOSHENKO = "timoshenko"
# the analyses with no Timoshenko form yet (:func:`in_plane_only`)
OUT_OF_PLANE_THESIS = "out-of-plane bending and torsion use the thesis element"
STATIONS_WITHOUT_SPEED = ("station forces without an operating point (a crank speed) use the Euler-Bernoulli "
                          "shape functions")


def slenderness_error(link, modes: int) -> float:
    """ω_EB/ω_T - 1 of ``link``'s bending mode n = ``modes`` (its most critical segment), from the
    pinned-pinned dispersion relation (κGAk² − ρAω²)(EIk² + κGA − ρIω²) = (κGAk)², k = nπ/L, its lower
    root (docs/theory.md §22.6); ρ cancels."""
    worst = 0.0
    for s in link.pieces:
        kappa = s.shear_coefficient or DEFAULT_KAPPA
        e_over_g = s.youngs_modulus / s.shear_modulus if s.shear_modulus else 2 * (1 + DEFAULT_NU)
        ei, ga = s.second_moment, kappa * s.area / e_over_g  # E = 1: EI and κGA in units of E
        k2 = (modes * math.pi / link.length) ** 2
        b = s.area * (ei * k2 + ga) + s.second_moment * ga * k2  # A·B, with ρ = 1
        c = ga * ei * k2 * k2
        w2 = 2 * c / (b + math.sqrt(b * b - 4 * s.area * s.second_moment * c))  # lower root, stable form
        worst = max(worst, math.sqrt(ei * k2 * k2 / s.area / w2) - 1.0)
    return worst


def slenderness_warnings(scene: Scene) -> list[str]:
    """The links whose Euler-Bernoulli bending frequencies are off by more than 1 % in the modes
    asked for (none when the scene uses the Timoshenko element)."""
    if scene.analysis.element == TIMOSHENKO:
        return []
    n = scene.analysis.modes
    out = []
    for i, lk in enumerate(scene.links):
        err = slenderness_error(lk, n)
        if err > MAX_EB_ERROR:
            r = min(math.sqrt(s.second_moment / s.area) for s in lk.pieces)
            out.append(f"links[{i}] {lk.name!r}: slenderness L/r = {lk.length / r:.3g} makes the Euler-Bernoulli "
                       f"element's bending frequencies some {100 * err:.3g} % high by mode {n} (pinned-pinned "
                       f"Timoshenko dispersion relation, > "
                       f"{100 * MAX_EB_ERROR:g} %, shear and rotary inertia left out): use "
                       f'[analysis] element = "{TIMOSHENKO}"')
    return out


def timoshenko_problems(scene: Scene, field: str = "analysis.element") -> list[Problem]:
    """Problems of a scene analysed with the Timoshenko element: every link needs κ and G."""
    if scene.analysis.element != TIMOSHENKO:
        return []
    out = []
    for i, lk in enumerate(scene.links):
        for s in lk.pieces:
            if s.shear_coefficient is None:
                out.append(Problem(f"links[{i}].shear_coefficient", f'{field} = "{TIMOSHENKO}" needs the shear '
                                   f"coefficient of link {lk.name!r}: give shear_coefficient, or a section shape "
                                   "with the material's poisson_ratio or shear_modulus_pa"))
            elif s.shear_modulus is None:
                out.append(Problem(f"links[{i}].shear_modulus_pa", f'{field} = "{TIMOSHENKO}" needs the shear '
                                   f"modulus of link {lk.name!r}: give shear_modulus_pa or the material's poisson_ratio"))
            else:
                continue
            break
    return out


def in_plane_only(scene: Scene, analysis: str, field: str = "analysis.element") -> Problem | None:
    """The refusal of ``analysis`` (what uses the thesis element's shape functions instead) for a
    Timoshenko scene, None when the scene's element serves it."""
    if scene.analysis.element != TIMOSHENKO:
        return None
    return Problem(field, f'"{TIMOSHENKO}" is in-plane only for now ({analysis}; docs/theory.md §22)')
