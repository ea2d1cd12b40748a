"""What a designer checks by eye before trusting a model: each link's mass, slenderness and a
hand estimate of its first bending frequency, and warnings for values no real link has (a unit
slip: millimetres typed into ``length_m``, MPa into ``youngs_modulus_pa``, t/mm³ as kg/m³).

The estimate is the pinned-pinned Euler-Bernoulli beam, f₁ = (π / 2L²) sqrt(EI / ρA), with the
length-weighted EI and ρA of a stepped link and no lumped masses: a scale to compare the
computed frequencies with (a link in a linkage is neither pinned-pinned nor alone), not a result.
A link with out-of-plane section data (docs/theory.md §19.3) gets the same estimates of its other
half (§19.5): the pinned-pinned bending about the weak axis, f₁,out = (π / 2L²) sqrt(EI_out / ρA),
and the first St-Venant torsion mode with both ends held against twist, f_t = (1 / 2L)
sqrt(GJ / ρI_p) (the twist obeys the wave equation GJ ψ'' = ρI_p ψ̈, the axial bar's with GJ for
EA and ρI_p for ρA), with length-weighted EI_out, GJ and ρI_p.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fkev_slepc.scene.model import Link, Scene

# Plausible ranges for structural links; outside them a value is almost surely a unit slip.
YOUNGS_PA = (1e7, 1.5e12)  # soft polymers ~1e8-1e9, aluminium 7e10, steel 2.1e11, tungsten carbide 7e11
DENSITY_KG_M3 = (100.0, 25000.0)  # foams ~100, woods 400-900, steel 7850, osmium 22,590
MAX_LENGTH_M = 50.0
SLENDERNESS = (2.0, 10000.0)  # L/r: below, no beam at all (shear dominates); above, a wire (a 1 m x 1 mm strip is 3,464)


@dataclass(frozen=True)
class LinkSummary:
    name: str
    length_m: float
    mass_kg: float  # the axis beam and a ternary link's branch; lumped masses not included
    slenderness: float  # L / r, r = sqrt(I/A) the radius of gyration (the smallest of the segments)
    pinned_frequency_hz: float  # (π / 2L²) sqrt(EI/ρA)
    warnings: tuple[str, ...]
    pinned_frequency_out_hz: float | None = None  # (π / 2L²) sqrt(EI_out/ρA); None: no I_out
    torsion_frequency_hz: float | None = None  # (1 / 2L) sqrt(GJ/ρI_p); None: no J, G or I_p


def _weighted(pieces, value, length: float) -> float | None:
    """The length-weighted mean of ``value(segment)`` over ``pieces`` (None if any is None)."""
    values = [value(s) for s in pieces]
    if any(v is None for v in values):
        return None
    return math.fsum(v * s.length for v, s in zip(values, pieces)) / length


def out_of_plane_frequencies(link: Link) -> tuple[float | None, float | None]:
    """(f₁,out, f_t) of a link, Hz (module docstring; docs/theory.md §19.5), None where its section
    lacks the data."""
    L = link.length
    rho_a = _weighted(link.pieces, lambda s: s.density * s.area, L)
    ei_out = _weighted(link.pieces, lambda s: None if s.second_moment_out is None else
                       s.youngs_modulus * s.second_moment_out, L)
    gj = _weighted(link.pieces, lambda s: None if s.shear_modulus is None or s.torsion_constant is None else
                   s.shear_modulus * s.torsion_constant, L)
    rho_ip = _weighted(link.pieces, lambda s: None if s.polar_moment is None else s.density * s.polar_moment, L)
    f_out = None if ei_out is None else math.pi / (2 * L * L) * math.sqrt(ei_out / rho_a)
    f_t = None if gj is None or rho_ip is None else math.sqrt(gj / rho_ip) / (2 * L)
    return f_out, f_t


def summarize(link: Link, index: int) -> LinkSummary:
    """The link's :class:`LinkSummary`, with a warning per implausible value."""
    pieces = link.pieces
    L = link.length
    mass = math.fsum(s.density * s.area * s.length for s in pieces)
    if link.third is not None:  # a ternary link's branch beam, of the uniform section, to its third point
        mass += link.density * link.area * abs(link.third[1])
    r = min(math.sqrt(s.second_moment / s.area) for s in pieces)
    ei = math.fsum(s.youngs_modulus * s.second_moment * s.length for s in pieces) / L
    rho_a = math.fsum(s.density * s.area * s.length for s in pieces) / L
    f_pp = math.pi / (2 * L * L) * math.sqrt(ei / rho_a)
    where = f"links[{index}] {link.name!r}"
    warn = []
    for s in {(p.youngs_modulus, p.density) for p in pieces}:
        E, rho = s
        if not YOUNGS_PA[0] <= E <= YOUNGS_PA[1]:
            warn.append(f"{where}: youngs_modulus_pa = {E:g} Pa is no structural material ({YOUNGS_PA[0]:g}-"
                        f"{YOUNGS_PA[1]:g} Pa; steel 2.1e11): a unit slip (GPa, MPa = N/mm²)?")
        if not DENSITY_KG_M3[0] <= rho <= DENSITY_KG_M3[1]:
            warn.append(f"{where}: density_kg_m3 = {rho:g} kg/m³ is no structural material ({DENSITY_KG_M3[0]:g}-"
                        f"{DENSITY_KG_M3[1]:g} kg/m³; steel 7850): a unit slip (g/cm³, t/mm³)?")
    if L > MAX_LENGTH_M:
        warn.append(f"{where}: length_m = {L:g} m, a link longer than {MAX_LENGTH_M:g} m: millimetres typed as metres?")
    if not SLENDERNESS[0] <= L / r <= SLENDERNESS[1]:
        kind = "a wire, not a link" if L / r > SLENDERNESS[1] else "too stocky for Euler-Bernoulli beams"
        warn.append(f"{where}: slenderness L/r = {L / r:.3g} (r = sqrt(I/A) = {r:.3g} m) is {kind} "
                    f"({SLENDERNESS[0]:g}-{SLENDERNESS[1]:g}): length, area_m2 and second_moment_m4 in one unit system?")
    return LinkSummary(link.name, L, mass, L / r, f_pp, tuple(warn), *out_of_plane_frequencies(link))


def summarize_scene(scene: Scene) -> list[LinkSummary]:
    return [summarize(lk, i) for i, lk in enumerate(scene.links)]


MAX_ZETA = 1.0  # Rayleigh damping over-critical at a link's first bending frequency: no structure (steel 0.001-0.05)


def damping_warnings(scene: Scene, rows: list[LinkSummary]) -> list[str]:
    """A warning when the scene's Rayleigh damping C = αM + βK gives a damping ratio
    ζ(ω) = α/(2ω) + βω/2 above :data:`MAX_ZETA` at a link's pinned-pinned first bending frequency
    ω = 2π f₁ (``rows``: :func:`summarize_scene`): over-critical, a unit slip (β in ms typed as s?)."""
    alpha, beta = scene.damping.mass_proportional, scene.damping.stiffness_proportional
    if not (alpha or beta):
        return []
    out = []
    for s in rows:
        w = 2.0 * math.pi * s.pinned_frequency_hz
        zeta = float(scene.damping.ratio(w)) if w > 0 and math.isfinite(w) else math.inf
        if not zeta <= MAX_ZETA:
            out.append(f"damping: mass_proportional_1_s = {alpha:g} 1/s, stiffness_proportional_s = {beta:g} s give "
                       f"ζ = {zeta:.3g} at the first bending frequency {s.pinned_frequency_hz:.4g} Hz of link "
                       f"{s.name!r} (over-critical, > {MAX_ZETA:g}): a unit slip?")
            break
    return out
