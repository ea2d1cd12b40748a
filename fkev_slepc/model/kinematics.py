"""Rigid-body kinematics (docs/theory.md §3), vectorised over crank angles.

Everything is returned per unit crank speed: with crank angle θ, speed Ω = θ̇ and acceleration
α = θ̈, a link angle obeys φ̇ = φ'Ω and φ̈ = φ''Ω² + φ'α, and a point p obeys ṗ = p'Ω,
p̈ = p''Ω² + p'α, where ' is d/dθ. That split is what lets the operators be assembled once per
angle and combined per speed.

Joints are located in the order planned by :mod:`mechanism`: the driver (clamped at its ground
pivot, direction θ), then RRR dyads in closed form. For the four-bar's dyad at B this is the RBK
routine of the thesis (γ ≥ 0 is the ``left`` branch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.mechanism import Mechanism
from fkev_slepc.scene import Problem, Scene, SceneError


@dataclass(frozen=True)
class Kinematics:
    theta: np.ndarray  # (n_ang,) crank angle, rad
    ok: np.ndarray  # (n_ang,) False where the linkage cannot be assembled
    phi: np.ndarray  # (n_ang, n_link) link angles (root -> tip), rad
    dphi: np.ndarray  # dφ/dθ
    ddphi: np.ndarray  # d²φ/dθ²
    pos: np.ndarray  # (n_ang, n_joint, 2) joint positions, m
    dpos: np.ndarray
    ddpos: np.ndarray
    root: np.ndarray  # (n_ang, n_link, 2) link root positions, and derivatives
    droot: np.ndarray
    ddroot: np.ndarray
    # (n_ang,) smallest transmission angle over the dyads, folded to [0, π/2] (rad; π/2 is ideal,
    # 0 a toggle position); NaN for a linkage without dyads
    transmission: np.ndarray | None = None


# Below this transmission angle a point is reported as near a toggle (fkev point, fkev run):
# link speeds grow like 1/sin(μ), so do the Coriolis, normal and tangential terms; measured
# on a crank-rocker approaching its toggle (scripts/stress.py toggle, docs/numerical-stability.md)
# the full case's divergence rates pass 1e3 1/s at about this angle.
TRANSMISSION_WARN_DEG = 10.0


def _perp(u: np.ndarray) -> np.ndarray:
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


def _unit(angle: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def _solve2(c1: np.ndarray, c2: np.ndarray, det: np.ndarray, rhs: np.ndarray):
    """Solve [c1 c2] [x; y] = rhs by Cramer's rule, vectorised over angles (NaN where det = 0)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (rhs[:, 0] * c2[:, 1] - rhs[:, 1] * c2[:, 0]) / det
        y = (c1[:, 0] * rhs[:, 1] - c1[:, 1] * rhs[:, 0]) / det
    return x, y


def solve_kinematics(mech: Mechanism, theta) -> Kinematics:
    """Positions, d/dθ and d²/dθ² of every joint and link angle at crank angles ``theta`` (rad)."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    n, nj, nl = theta.size, len(mech.joint_names), mech.n_link
    pos = np.full((n, nj, 2), np.nan)
    dpos = np.zeros((n, nj, 2))
    ddpos = np.zeros((n, nj, 2))
    phi = np.full((n, nl), np.nan)
    dphi = np.zeros((n, nl))
    ddphi = np.zeros((n, nl))
    ok = np.ones(n, dtype=bool)
    mu = np.full(n, np.nan)
    ground = ~np.isnan(mech.joint_ground[:, 0])
    pos[:, ground] = mech.joint_ground[ground]

    d = mech.driver
    phi[:, d], dphi[:, d] = theta, 1.0
    if mech.link_tip_joint[d] >= 0:
        L, e = mech.length[d], _unit(theta)
        r = pos[:, mech.link_root_joint[d]]
        t = mech.link_tip_joint[d]
        pos[:, t] = r + L * e
        dpos[:, t] = L * _perp(e)
        ddpos[:, t] = -L * e

    for st in mech.dyads:  # NaN where a dyad cannot close; those angles are masked below
        La, Lb = mech.length[st.link_a], mech.length[st.link_b]
        P, dP, ddP = pos[:, st.p], dpos[:, st.p], ddpos[:, st.p]
        Q, dQ, ddQ = pos[:, st.q], dpos[:, st.q], ddpos[:, st.q]
        dq = Q - P
        dist = np.hypot(dq[:, 0], dq[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            cos_g = (La**2 + dist**2 - Lb**2) / (2 * La * dist)
        good = np.abs(cos_g) <= 1.0
        psi_a = np.arctan2(dq[:, 1], dq[:, 0]) + st.sign * np.arccos(np.clip(cos_g, -1, 1))
        ua = _unit(psi_a)
        J = P + La * ua
        vb = J - Q
        psi_b = np.arctan2(vb[:, 1], vb[:, 0])
        ub = _unit(psi_b)
        # [La ua⊥, -Lb ub⊥] [ψa'; ψb'] = Q' - P'   (loop closure differentiated once, twice)
        c1, c2 = La * _perp(ua), -Lb * _perp(ub)
        det = c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]
        good &= np.abs(det) > 1e-12 * La * Lb  # toggle (dead-centre) positions are singular

        da, db = _solve2(c1, c2, det, dQ - dP)
        rhs2 = ddQ - ddP + La * da[:, None] ** 2 * ua - Lb * db[:, None] ** 2 * ub
        dda, ddb = _solve2(c1, c2, det, rhs2)
        pos[:, st.joint] = J
        with np.errstate(invalid="ignore", over="ignore"):
            dpos[:, st.joint] = dP + La * (da[:, None] * _perp(ua))
            ddpos[:, st.joint] = ddP + La * (dda[:, None] * _perp(ua) - da[:, None] ** 2 * ua)
        # A link's own angle runs root -> tip: flip by π when its root is at the dyad joint.
        phi[:, st.link_a] = psi_a + (0.0 if st.a_tip_at_joint else np.pi)
        phi[:, st.link_b] = psi_b + (0.0 if st.b_tip_at_joint else np.pi)
        dphi[:, st.link_a], ddphi[:, st.link_a] = da, dda
        dphi[:, st.link_b], ddphi[:, st.link_b] = db, ddb
        ok &= good
        with np.errstate(invalid="ignore"):
            mu = np.fmin(mu, np.arccos(np.clip(np.abs(np.sum(ua * ub, axis=-1)), 0.0, 1.0)))

    phi = np.mod(phi + np.pi, 2 * np.pi) - np.pi
    rj = mech.link_root_joint
    root, droot, ddroot = pos[:, rj], dpos[:, rj], ddpos[:, rj]
    bad = ~ok
    for arr in (phi, dphi, ddphi, pos, dpos, ddpos, root, droot, ddroot, mu):
        arr[bad] = np.nan
    return Kinematics(theta, ok, phi, dphi, ddphi, pos, dpos, ddpos, root, droot, ddroot, mu)


def point_on_link(kin: Kinematics, mech: Mechanism, link: np.ndarray, s: np.ndarray):
    """Position, d/dθ, d²/dθ² of points at stations ``s`` on links ``link``: arrays (n_ang, n_pt, 2)."""
    e = _unit(kin.phi[:, link])
    ep = _perp(e)
    dphi, ddphi = kin.dphi[:, link, None], kin.ddphi[:, link, None]
    s = np.asarray(s, dtype=float)[None, :, None]
    p = kin.root[:, link] + s * e
    dp = kin.droot[:, link] + s * dphi * ep
    ddp = kin.ddroot[:, link] + s * (ddphi * ep - dphi**2 * e)
    return p, dp, ddp


def assembly_ranges(mech: Mechanism, step_deg: float = 0.25) -> list[tuple[float, float]]:
    """Crank-angle intervals [a°, b°] over one revolution where the linkage cannot be assembled.

    Scanned every ``step_deg`` and each end refined by bisection to 1e-9°; an interval across
    0° is given as [a°, b°] with a < 0. Intervals narrower than the scan step can be missed
    (isolated dead centres); :func:`assembly_problems` still checks every requested angle.
    """
    grid = np.arange(0.0, 360.0, step_deg)
    bad = ~solve_kinematics(mech, np.radians(grid)).ok
    if not bad.any():
        return []
    if bad.all():
        return [(0.0, 360.0)]
    start = int(np.flatnonzero(~bad)[0])  # walk the circle from an assemblable angle
    walk = grid[start] + step_deg * np.arange(grid.size + 1)  # unwrapped, back to the start
    flags = bad[(np.arange(grid.size + 1) + start) % grid.size]
    edges = np.flatnonzero(np.diff(flags.astype(int)))  # ok->bad at i: bad from walk[i + 1]
    out = []
    for i_on, i_off in zip(edges[::2], edges[1::2]):
        lo = _edge(mech, walk[i_on], walk[i_on + 1])
        hi = _edge(mech, walk[i_off + 1], walk[i_off])
        shift = 360.0 * np.floor(hi / 360.0)
        out.append((float(lo - shift), float(hi - shift)))
    return out


def _edge(mech: Mechanism, ok_deg: float, bad_deg: float) -> float:
    """The boundary between an assemblable and a non-assemblable angle, by bisection (degrees)."""
    for _ in range(40):
        mid = 0.5 * (ok_deg + bad_deg)
        if solve_kinematics(mech, [np.radians(mid)]).ok[0]:
            ok_deg = mid
        else:
            bad_deg = mid
    return 0.5 * (ok_deg + bad_deg)


def grashof_class(mech: Mechanism) -> str | None:
    """Grashof class of a four-bar (driver with a ground pivot, one dyad to a ground joint), else None.

    s + l < p + q (s, l the shortest and longest of ground, crank, coupler, follower): the
    shortest link turns fully: crank-rocker (the crank), double-crank (the ground), double-rocker
    (the coupler); s + l = p + q: change-point (it passes through toggle positions);
    s + l > p + q: non-Grashof triple-rocker (the crank cannot turn fully).
    """
    if len(mech.dyads) != 1:
        return None
    st, d = mech.dyads[0], mech.driver
    g = mech.joint_ground
    root = mech.link_root_joint[d]
    if np.isnan(g[root, 0]) or st.p != mech.link_tip_joint[d] or np.isnan(g[st.q, 0]):
        return None
    L = mech.length
    lengths = {"crank": L[d], "coupler": L[st.link_a], "follower": L[st.link_b],
               "ground": float(np.hypot(*(g[st.q] - g[root])))}
    vals = sorted(lengths.values())
    s_l, p_q = vals[0] + vals[3], vals[1] + vals[2]
    if np.isclose(s_l, p_q, rtol=1e-12):
        return "change-point (Grashof s + l = p + q)"
    if s_l > p_q:
        return "non-Grashof triple-rocker (s + l > p + q)"
    shortest = min(lengths, key=lengths.get)
    return {"crank": "Grashof crank-rocker", "ground": "Grashof double-crank",
            "coupler": "Grashof double-rocker", "follower": "Grashof rocker-crank"}[shortest]


def assembly_problems(scene: Scene) -> list[Problem]:
    """Problems of the requested crank angles at which the linkage cannot be assembled:
    one per interval (``cannot be assembled for θ in [a°, b°]``), with the Grashof class."""
    from fkev_slepc.model.mechanism import build_mechanism

    try:
        mech = build_mechanism(scene)
    except SceneError as err:
        return err.problems
    angles = np.asarray(scene.analysis.crank_angles_deg, dtype=float)
    kin = solve_kinematics(mech, np.radians(angles))
    if kin.ok.all():
        return []
    cls = grashof_class(mech)
    tail = f"; {cls}" if cls else ""
    bad = angles[~kin.ok]
    wrapped = np.mod(bad, 360.0)
    problems, covered = [], np.zeros(bad.size, bool)
    for lo, hi in assembly_ranges(mech):
        inside = ((wrapped >= lo) & (wrapped <= hi)) | ((wrapped - 360.0 >= lo) & (wrapped - 360.0 <= hi))
        if inside.any():
            covered |= inside
            where = (f"at θ = {_deg(0.5 * (lo + hi))}° (a dead-centre position)" if hi - lo < 1e-3
                     else f"for θ in [{_deg(lo)}°, {_deg(hi)}°]")
            first = int(np.flatnonzero(~kin.ok)[np.argmax(inside)])  # index of its first requested angle
            problems.append(Problem(f"analysis.crank_angles_deg[{first}]", f"the linkage cannot be assembled {where} "
                                    f"({int(inside.sum())} requested angle(s)){tail}"))
    for i, a in zip(np.flatnonzero(~kin.ok)[~covered], bad[~covered]):  # dead centres the scan stepped over
        problems.append(Problem(f"analysis.crank_angles_deg[{i}]",
                                f"the linkage cannot be assembled at θ = {a:g}° (a dead-centre position){tail}"))
    return problems


def _deg(x: float) -> str:
    return f"{x:.2f}".replace("-0.00", "0.00")
