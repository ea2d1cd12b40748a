"""Rigid-body kinematics (docs/theory.md §3, docs/linkages.md), vectorised over crank angles.

Everything is returned per unit crank speed: with crank angle θ, speed Ω = θ̇ and acceleration
α = θ̈, a link angle obeys φ̇ = φ'Ω and φ̈ = φ''Ω² + φ'α, and a point p obeys ṗ = p'Ω,
p̈ = p''Ω² + p'α, where ' is d/dθ. That split is what lets the operators be assembled once per
angle and combined per speed.

Joints are located in the order planned by :mod:`fkev_slepc.model.joint_order`: the driver (clamped
at its ground pivot, direction θ), then RRR dyads and RRP (slider) dyads in closed form; each
placed link is a rigid body whose other joint points follow from its pose. For the four-bar's
dyad at B this is the RBK routine of the thesis (γ ≥ 0 is the ``left`` branch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.mechanism import Mechanism, build_mechanism
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


# Below this transmission angle a point is reported as near a toggle (fkev check, point, run):
# link speeds grow like 1/sin(μ), and so do the Coriolis, normal and tangential terms. Measured
# (scripts/stress.py toggle, docs/numerical-stability.md): a non-Grashof four-bar at 100 rad/s,
# full case, turns divergent between μ = 18.3° (max Re λ 0.3 1/s) and 13.6° (1419 1/s); the
# thesis linkages stay above 26.8°.
TRANSMISSION_WARN_DEG = 20.0


def perp(u: np.ndarray) -> np.ndarray:
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


def unit_vector(angle: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def rotate(phi: np.ndarray, r: np.ndarray) -> np.ndarray:
    """R(φ) r for angles (..., ) and link-frame vectors broadcastable to (..., 2)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * r[..., 0] - s * r[..., 1], s * r[..., 0] + c * r[..., 1]], axis=-1)


def _solve2(c1: np.ndarray, c2: np.ndarray, det: np.ndarray, rhs: np.ndarray):
    """Solve [c1 c2] [x; y] = rhs by Cramer's rule, vectorised over angles (NaN where det = 0)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (rhs[:, 0] * c2[:, 1] - rhs[:, 1] * c2[:, 0]) / det
        y = (c1[:, 0] * rhs[:, 1] - c1[:, 1] * rhs[:, 0]) / det
    return x, y


def _det(c1, c2):
    return c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]


class _State:
    """Joint and link arrays being filled in, step by step."""

    def __init__(self, mech: Mechanism, n: int):
        nj, nl = len(mech.joint_names), mech.n_link
        self.mech = mech
        self.pos = np.full((n, nj, 2), np.nan)
        self.dpos = np.zeros((n, nj, 2))
        self.ddpos = np.zeros((n, nj, 2))
        self.phi = np.full((n, nl), np.nan)
        self.dphi = np.zeros((n, nl))
        self.ddphi = np.zeros((n, nl))
        self.root = np.full((n, nl, 2), np.nan)
        self.droot = np.zeros((n, nl, 2))
        self.ddroot = np.zeros((n, nl, 2))

    def place(self, lk: int, j: int, r_j, phi, dphi, ddphi) -> None:
        """Link ``lk`` with its link-frame point ``r_j`` at joint ``j`` (located): its root and
        every other joint on it follow from the rigid-body pose."""
        self.phi[:, lk], self.dphi[:, lk], self.ddphi[:, lk] = phi, dphi, ddphi
        w, dw = dphi[:, None], ddphi[:, None]
        a = rotate(phi, -np.asarray(r_j, dtype=float))  # root - joint
        self.root[:, lk] = self.pos[:, j] + a
        self.droot[:, lk] = self.dpos[:, j] + w * perp(a)
        self.ddroot[:, lk] = self.ddpos[:, j] + dw * perp(a) - w**2 * a
        for jj, lk2, k in ((jj, l2, k) for jj, lst in enumerate(self.mech.attach) for (l2, k) in lst):
            if lk2 == lk and jj != j:
                p, dp, ddp = rigid_point(self.root[:, lk], self.droot[:, lk], self.ddroot[:, lk],
                                         phi, dphi, ddphi, self.mech.link_points[lk, k])
                if np.isnan(self.pos[:, jj]).all():
                    self.pos[:, jj], self.dpos[:, jj], self.ddpos[:, jj] = p, dp, ddp


def rigid_point(root, droot, ddroot, phi, dphi, ddphi, r):
    """Position, d/dθ, d²/dθ² of link-frame point(s) ``r`` on a rigid link (broadcasting)."""
    a = rotate(phi, np.asarray(r, dtype=float))
    w, dw = dphi[..., None], ddphi[..., None]
    return root + a, droot + w * perp(a), ddroot + dw * perp(a) - w**2 * a


def _rrr(st: _State, step) -> np.ndarray:
    """Locate joint J of an RRR dyad; returns where it closes and its transmission angle."""
    arm_a, arm_b = step.arms
    da, db = np.asarray(arm_a.d), np.asarray(arm_b.d)
    La, Lb = np.hypot(*da), np.hypot(*db)
    P, dP, ddP = st.pos[:, arm_a.p], st.dpos[:, arm_a.p], st.ddpos[:, arm_a.p]
    Q, dQ, ddQ = st.pos[:, arm_b.p], st.dpos[:, arm_b.p], st.ddpos[:, arm_b.p]
    dq = Q - P
    dist = np.hypot(dq[:, 0], dq[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_g = (La**2 + dist**2 - Lb**2) / (2 * La * dist)
    good = np.abs(cos_g) <= 1.0
    psi_a = np.arctan2(dq[:, 1], dq[:, 0]) + step.sign * np.arccos(np.clip(cos_g, -1, 1))
    ua = unit_vector(psi_a)
    J = P + La * ua
    vb = J - Q
    psi_b = np.arctan2(vb[:, 1], vb[:, 0])
    ub = unit_vector(psi_b)
    # [La ua⊥, -Lb ub⊥] [ψa'; ψb'] = Q' - P'   (loop closure differentiated once, twice)
    c1, c2 = La * perp(ua), -Lb * perp(ub)
    det = _det(c1, c2)
    good &= np.abs(det) > 1e-12 * La * Lb  # toggle (dead-centre) positions are singular
    wa, wb = _solve2(c1, c2, det, dQ - dP)
    rhs2 = ddQ - ddP + La * wa[:, None] ** 2 * ua - Lb * wb[:, None] ** 2 * ub
    dwa, dwb = _solve2(c1, c2, det, rhs2)
    j = step.joint
    st.pos[:, j] = J
    with np.errstate(invalid="ignore", over="ignore"):
        st.dpos[:, j] = dP + La * (wa[:, None] * perp(ua))
        st.ddpos[:, j] = ddP + La * (dwa[:, None] * perp(ua) - wa[:, None] ** 2 * ua)
        for arm, d, psi, w, dw in ((arm_a, da, psi_a, wa, dwa), (arm_b, db, psi_b, wb, dwb)):
            r_j = np.asarray(arm.r_p) + d
            st.place(arm.link, j, r_j, psi - np.arctan2(d[1], d[0]), w, dw)
        mu = np.arccos(np.clip(np.abs(np.sum(ua * ub, axis=-1)), 0.0, 1.0))  # angle between the links
    return good, mu


def _rrp(st: _State, step) -> np.ndarray:
    """Locate the slider J of an RRP dyad on its guide G0 + λt; returns where it closes and its
    transmission angle."""
    (arm,) = step.arms
    mech, j = st.mech, step.joint
    d = np.asarray(arm.d)
    La = np.hypot(*d)
    t, G0 = mech.joint_guide[j], mech.joint_guide_point[j]
    P, dP, ddP = st.pos[:, arm.p], st.dpos[:, arm.p], st.ddpos[:, arm.p]
    w = P - G0
    tw = w @ t
    disc = tw**2 - (w**2).sum(axis=1) + La**2
    good = disc >= 0
    lam = tw + step.sign * np.sqrt(np.maximum(disc, 0.0))
    J = G0 + lam[:, None] * t
    v = J - P
    psi = np.arctan2(v[:, 1], v[:, 0])
    u = unit_vector(psi)
    # P + La u(ψ) = G0 + λ t: [La u⊥, -t] [ψ'; λ'] = -P', and with + La ψ'² u for ψ'', λ''
    c1, c2 = La * perp(u), np.broadcast_to(-t, u.shape)
    det = _det(c1, c2)
    good &= np.abs(det) > 1e-12 * La  # the arm normal to the guide: the slider's limit
    wpsi, dlam = _solve2(c1, c2, det, -dP)
    dwpsi, ddlam = _solve2(c1, c2, det, -ddP + La * wpsi[:, None] ** 2 * u)
    with np.errstate(invalid="ignore", over="ignore"):
        st.pos[:, j], st.dpos[:, j], st.ddpos[:, j] = J, dlam[:, None] * t, ddlam[:, None] * t
        st.place(arm.link, j, np.asarray(arm.r_p) + d, psi - np.arctan2(d[1], d[0]), wpsi, dwpsi)
        # the link along the guide is ideal (π/2), normal to it a toggle (0)
        mu = np.arccos(np.clip(np.abs(u @ perp(t)), 0.0, 1.0))
    return good, mu


def solve_kinematics(mech: Mechanism, theta) -> Kinematics:
    """Positions, d/dθ and d²/dθ² of every joint and link angle at crank angles ``theta`` (rad)."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    n = theta.size
    st = _State(mech, n)
    ground = ~np.isnan(mech.joint_ground[:, 0])
    st.pos[:, ground] = mech.joint_ground[ground]
    ok = np.ones(n, dtype=bool)
    mu = np.full(n, np.nan)
    d = mech.driver
    st.place(d, mech.link_root_joint[d], (0.0, 0.0), theta, np.ones(n), np.zeros(n))
    for step in mech.steps:  # NaN where a dyad cannot close; those angles are masked below
        good, mu_step = _rrr(st, step) if len(step.arms) == 2 else _rrp(st, step)
        ok &= good
        with np.errstate(invalid="ignore"):
            mu = np.fmin(mu, mu_step)

    phi = np.mod(st.phi + np.pi, 2 * np.pi) - np.pi
    arrays = (phi, st.dphi, st.ddphi, st.pos, st.dpos, st.ddpos, st.root, st.droot, st.ddroot, mu)
    for arr in arrays:
        arr[~ok] = np.nan
    return Kinematics(theta, ok, *arrays)


def point_local(kin: Kinematics, link: np.ndarray, r: np.ndarray):
    """Position, d/dθ, d²/dθ² of link-frame points ``r`` (n_pt, 2) on links ``link`` (n_pt,):
    arrays (n_ang, n_pt, 2)."""
    link = np.asarray(link, dtype=int)
    return rigid_point(kin.root[:, link], kin.droot[:, link], kin.ddroot[:, link],
                       kin.phi[:, link], kin.dphi[:, link], kin.ddphi[:, link], np.asarray(r, dtype=float))


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
    if len(mech.steps) != 1 or len(mech.steps[0].arms) != 2 or mech.n_link != 3:
        return None
    (a, b), d = mech.steps[0].arms, mech.driver
    g = mech.joint_ground
    root = mech.link_root_joint[d]
    if np.isnan(g[root, 0]) or a.p != mech.link_tip_joint[d] or np.isnan(g[b.p, 0]):
        return None
    lengths = {"crank": mech.length[d], "coupler": float(np.hypot(*a.d)), "follower": float(np.hypot(*b.d)),
               "ground": float(np.hypot(*(g[b.p] - g[root])))}
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
