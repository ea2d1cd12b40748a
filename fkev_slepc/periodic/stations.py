"""Engineering outputs of a periodic response (docs/response.md §4): deflection, bending moment,
axial force and extreme-fibre stress at stations along the links, over the crank cycle.

A station is a point of a link's axis at distance s from the link's first joint (its root).
From the global DOFs q(θ) the element DOFs in the element's own frame are q_e = T(θ) q; the
element's shape functions give there the elastic axial and transverse displacements u, v, the
axial strain u' and the curvature v'', hence

    N = EA u',   M = EI v'',   σ₊ = N/A − M c/I,   σ₋ = N/A + M c/I,   |σ|max = |N|/A + |M| c/I

with the operating point given (speed, gravity) N, V, M instead by the equilibrium of each element
under its rigid-body inertia and gravity loads (:func:`element_forces`, docs/theory.md §7.4),
exact at any station where the shape functions' derivatives are not
(c the extreme-fibre distance of the section, scene/shapes.py; NaN where the scene does not give
it). σ₊ and σ₋ are the signed stresses of the faces at +c and −c along the link's left normal:
with M = EI v'' positive where the link bends concave towards its left normal, the fibre at +c is
shortened, hence the minus sign (docs/response.md §4). Over the cycle every point (station or
element end, and face) has σ_max, σ_min, the mean (σ_max + σ_min)/2 and the alternating part
(σ_max − σ_min)/2 (:func:`cycle_parts`).

N and M are the elastic model's internal forces: in the quasi-static limit of a statically
determinate linkage N tends to the rigid-body kinetostatic axial force, which is reported beside
it (``axial_force_rigid_n``); their difference is the elastic correction of the axial load the
link's joints see.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.element_types import axial_shapes, bending_shapes, dof_scale
from fkev_slepc.model.timoshenko import shapes as timoshenko_shapes
from fkev_slepc.scene.validity import STATIONS_WITHOUT_SPEED, in_plane_only


@dataclass(frozen=True)
class Station:
    link: int
    s: float  # m from the link's root along its axis
    element: int
    xi: float  # element coordinate in [0, 1]


def default_stations(mech) -> list[Station]:
    """Every link's root, midspan and tip on its axis beam."""
    out = []
    for lk in range(mech.n_link):
        out += stations_at(mech, lk, (0.0, 0.5 * mech.length[lk], mech.length[lk]))
    return out


def stations_at(mech, link: int, s_values) -> list[Station]:
    """Stations of ``link`` at distances ``s_values`` (m) from its root along its axis; a
    distance on a node belongs to the element before it (the element after it at s = 0)."""
    axis_beam = mech.beam_link.tolist().index(link)
    sel = np.flatnonzero(mech.elem_beam == axis_beam)
    s0, l = mech.elem_s0[sel], mech.elem_length[sel]
    L = float(s0[-1] + l[-1])
    out = []
    for s in s_values:
        if not -1e-12 * L <= s <= L * (1 + 1e-12):
            raise ValueError(f"station s = {s:g} m is not on link {mech.link_names[link]!r} (0 to {L:g} m)")
        i = int(np.clip(np.searchsorted(s0 + l, s - 1e-12 * L), 0, sel.size - 1))
        out.append(Station(link, float(s), int(sel[i]), float(np.clip((s - s0[i]) / l[i], 0.0, 1.0))))
    return out


def element_end_stations(mech, links=None) -> list[Station]:
    """Both ends of every element of the axis beams of ``links`` (default all): the points of the
    whole-link stress (the moment of the element model jumps at a node, so each end is its own
    point; a ternary link's branch beam is not included)."""
    out = []
    for lk in range(mech.n_link) if links is None else links:
        axis_beam = mech.beam_link.tolist().index(lk)
        for e in np.flatnonzero(mech.elem_beam == axis_beam):
            s0 = float(mech.elem_s0[e])
            out += [Station(lk, s0, int(e), 0.0), Station(lk, s0 + float(mech.elem_length[e]), int(e), 1.0)]
    return out


def element_sections(mech) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Area A, second moment I and fibre distance c (NaN: not given) of every element, from the
    scene's links and segments (a ternary branch has the link's uniform section)."""
    pieces = mech.elem_piece
    c = np.array([np.nan if p.fibre_distance is None else p.fibre_distance for p in pieces], dtype=float)
    return np.array([p.area for p in pieces]), np.array([p.second_moment for p in pieces]), c


def cycle_parts(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(σ_max, σ_min, mean, alternating) over the crank angles (axis 0) of a signed stress.

    Examples
    --------
    >>> [float(x[0]) for x in cycle_parts(np.array([[-1.0], [3.0], [2.0]]))]
    [3.0, -1.0, 1.0, 2.0]
    """
    hi, lo = np.max(sigma, axis=0), np.min(sigma, axis=0)
    return hi, lo, 0.5 * (hi + lo), 0.5 * (hi - lo)


@dataclass(frozen=True)
class StationResponse:
    """Station outputs over the angles: each (n_θ, n_station)."""

    stations: tuple[Station, ...]
    axial: np.ndarray  # u, m (link frame, along the link)
    transverse: np.ndarray  # v, m (link frame, left normal)
    moment: np.ndarray  # M, N m
    axial_force: np.ndarray  # N, N (tension > 0)
    shear: np.ndarray  # V = -dM/ds, N
    stress: np.ndarray  # max |σ| over the section, Pa (NaN without c)
    stress_plus: np.ndarray  # σ₊ = N/A − M c/I, the face at +c along the left normal, Pa (NaN without c)
    stress_minus: np.ndarray  # σ₋ = N/A + M c/I, the face at −c, Pa
    axial_force_rigid: np.ndarray  # rigid-body kinetostatic axial force, N
    # v minus the chord through the link's deflected ends: the deflection a floating frame on
    # the link's ends sees (the slider-crank benchmark's "midpoint transverse deflection"), m
    transverse_chord: np.ndarray


def element_forces(model, state, e, xi, q_phys, speed: float, gravity=(0.0, 0.0)):
    """N, V, M (each (n_θ, n_st)) at element coordinates ``xi`` of elements ``e`` by the equilibrium
    of the free body [0, ξ] of the element (docs/theory.md §7.4): its left-end forces
    f = k_s q_e − f_e (f_e the consistent load of the rigid-body inertia at crank speed ``speed``
    and of ``gravity`` (g_x, g_y), m/s²) and the distributed load p = −ρA a(x) from the left end to
    the station. ``q_phys``: the element DOFs in the element frame (n_θ, n_st, n_dof)."""
    from fkev_slepc.model.loads import rigid_fields

    mech, stacks = model.mechanism, model.stacks
    fields = rigid_fields(mech, stacks, state)
    gx, gy = np.asarray(gravity, float).reshape(2)  # the pieces are of 1 m/s² along -X, -Y
    a = speed**2 * fields["per_w2"][:, e] - gy * fields["gravity"][:, e] - gx * fields["gravity_x"][:, e]
    f = np.einsum("sij,asj->asi", stacks.structural[e], q_phys) + np.einsum("sij,asj->asi", stacks.mass[e], a)
    ra, l = mech.elem_rho_a[e] * mech.elem_length[e], mech.elem_length[e]
    P_u = -ra * (a[..., 0] * (xi - xi**2 / 2) + a[..., 3] * xi**2 / 2)  # ∫₀ˢ p_u dx
    P_v = -ra * (a[..., 1] * (xi - xi**2 / 2) + a[..., 4] * xi**2 / 2)
    PP_v = -ra * l * (a[..., 1] * (xi**2 / 2 - xi**3 / 6) + a[..., 4] * xi**3 / 6)  # ∫₀ˢ ∫₀ˣ p_v
    N = -f[..., 0] - P_u
    V = -f[..., 1] - P_v
    M = -f[..., 2] + f[..., 1] * xi * l + PP_v
    return N, V, M


def station_response(model, theta, q, stations=None, rigid_axial=None, *, speed=None,
                     gravity=(0.0, 0.0)) -> StationResponse:
    """Station outputs of the global response ``q`` (n_θ, n_free) at crank angles ``theta``;
    ``rigid_axial`` (n_θ, n_el, 3) the kinetostatic axial-force polynomials at the same angles.
    With the crank ``speed`` (rad/s) and ``gravity`` (g_x, g_y) of the response, N, V and M come from
    each element's equilibrium (:func:`element_forces`); without, from the shape functions (the
    thesis element's: refused, ValueError, for a Timoshenko model, whose u and v come from its own
    interdependent shapes, docs/theory.md §22)."""
    refusal = None if speed is not None else in_plane_only(model.scene, STATIONS_WITHOUT_SPEED)
    if refusal:
        raise ValueError(str(refusal))
    mech = model.mechanism
    stations = tuple(default_stations(mech) if stations is None else stations)
    links = sorted({st.link for st in stations})
    ends = [e for lk in links for e in stations_at(mech, lk, (0.0, mech.length[lk]))]
    n_st = len(stations)
    stations_all = stations + tuple(ends)
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    state = model.angle_state(theta, with_loads=False)
    e = np.array([st.element for st in stations_all], dtype=int)
    xi = np.array([st.xi for st in stations_all])
    dofs = mech.elem_dofs[e]  # (n_st, d)
    qp = np.concatenate([q, np.zeros((q.shape[0], 1))], axis=1)
    q_el = qp[:, np.where(dofs >= 0, dofs, q.shape[1])]  # (n_θ, n_st, d)
    T = state.T[:, e]  # (n_θ, n_st, d, d)
    n_dof = T.shape[-1]
    l = mech.elem_length[e]
    q_phys = np.einsum("asij,asj->asi", T, q_el)
    q_loc = q_phys * dof_scale(l, n_dof)[None]

    def at(fn, deriv):
        rows = np.stack([fn(np.array([x]), n_dof, deriv)[0] for x in xi])  # (n_st, d)
        return np.einsum("sd,asd->as", rows, q_loc)

    u, v = at(axial_shapes, 0), at(bending_shapes, 0)
    phi = model.stacks.shear_parameter
    if phi is not None:  # Timoshenko: v = (N⁰ + Φ N¹)/(1 + Φ) q (docs/theory.md §22.2)
        pv, ph = timoshenko_shapes(xi)["v"], phi[e][:, None]
        v = np.einsum("sd,asd->as", (pv[:, 0] + ph * pv[:, 1]) / (1 + ph), q_loc)
    v_end = {lk: (v[:, n_st + 2 * i], v[:, n_st + 2 * i + 1]) for i, lk in enumerate(links)}
    chord = np.stack([v[:, k] - (1 - st.s / mech.length[st.link]) * v_end[st.link][0]
                      - st.s / mech.length[st.link] * v_end[st.link][1] for k, st in enumerate(stations)], axis=1)
    keep = slice(0, n_st)
    u, v, q_loc, l, e, xi = u[:, keep], v[:, keep], q_loc[:, keep], l[keep], e[keep], xi[keep]
    if speed is not None:
        N, V, M = element_forces(model, state, e, xi, q_phys[:, keep], float(speed), gravity)
    else:
        du, d2v = at(axial_shapes, 1) / l, at(bending_shapes, 2) / l**2
        d3v = np.einsum("sd,asd->as", np.tile([0, 12, 6, 0, -12, 6, 0, 0][:n_dof], (xi.size, 1)), q_loc) / l**3
        ea, ei = mech.elem_ea[e], mech.elem_ei[e]
        N, M, V = ea * du, ei * d2v, -ei * d3v
    A, I, c = (x[e] for x in element_sections(mech))
    stress = np.abs(N) / A + np.abs(M) * c / I
    plus, minus = N / A - M * c / I, N / A + M * c / I
    rigid = np.full_like(N, np.nan)
    if rigid_axial is not None:
        co = rigid_axial[:, e]
        rigid = co[..., 0] + co[..., 1] * xi + co[..., 2] * xi**2
    return StationResponse(stations, u, v, M, N, V, stress, plus, minus, rigid, chord)
