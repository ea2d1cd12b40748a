"""Out-of-plane vibration of planar linkages (docs/theory.md §19): the element against closed
forms, the rotating cantilever against the published flapwise tables, the assembly against an
independent grillage computation, and the cases of Table 3.1 out of plane."""

import numpy as np
import pytest
import scipy.linalg as sla
from builders import bahgat_willmert, cantilever, rect_strip, turcic_midha

from fkev_slepc.model import out_of_plane as oop
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.operators import Model
from fkev_slepc.model.out_of_plane import Section
from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.modes import postprocess

FLAP = {0.0: np.array([3.5160, 22.0345, 61.6972]), 12.0: np.array([13.1702, 37.6031, 79.6145])}
NU = 0.3


def rect_section(scene, E, rho):
    """Out-of-plane data of every element of ``scene`` for a solid rectangle whose in-plane height
    h and out-of-plane width b reproduce the element's A and in-plane I (h = sqrt(12 I / A))."""
    m = build_mechanism(scene)
    A, I = m.elem_ea / E, m.elem_ei / E
    h = np.sqrt(12 * I / A)
    b = A / h
    thin, thick = np.minimum(b, h), np.maximum(b, h)
    J = thin**3 * thick * (1 / 3 - 0.21 * thin / thick * (1 - thin**4 / (12 * thick**4)))
    return Section(E * h * b**3 / 12, E / (2 * (1 + NU)) * J, rho * (I + h * b**3 / 12))


def spectrum(model, theta_deg, omega, case, n):
    q = model.qep(model.pieces(np.radians(theta_deg)), omega, case)
    return postprocess(DenseEngine().solve(q, n), n)


# -- the element, assembled in a straight line (element frame = ground frame) -------------------
def line(n, L, ei, gj, rho_a, rho_ip, force=0.0):
    """M, K (and K_g of a uniform axial force) of n equal elements in a row; DOFs (ψ, β, w) per node."""
    l = np.full(n, L / n)
    ones = np.ones(n)
    parts = (oop.mass(rho_a * ones, rho_ip * ones, l), oop.structural(ei * ones, gj * ones, l),
             oop.axial_force(np.tile([force, 0.0, 0.0], (n, 1)), l))
    out = []
    for k in parts:
        G = np.zeros((3 * n + 3, 3 * n + 3))
        for e in range(n):
            G[3 * e : 3 * e + 6, 3 * e : 3 * e + 6] += k[e]
        out.append(G)
    return out


def eig(M, K, keep):
    return np.sqrt(sla.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True))


def test_element_matrices_are_the_shape_function_integrals():
    """m, k, k_g against Gauss quadrature of the interpolation of §19.2 (w' = -β)."""
    l, rho_a, rho_ip, ei, gj = 0.3, 2.0, 0.7, 5.0, 3.0
    c = np.array([[1.5, -0.4, 0.9]])
    xi, wg = np.polynomial.legendre.leggauss(8)
    xi, wg = (xi + 1) / 2, wg / 2
    H = np.stack([1 - 3 * xi**2 + 2 * xi**3, l * xi * (1 - xi) ** 2, 3 * xi**2 - 2 * xi**3, -l * xi**2 * (1 - xi)])
    Hx = np.stack([-6 * xi + 6 * xi**2, l * (1 - 4 * xi + 3 * xi**2), 6 * xi - 6 * xi**2, l * (3 * xi**2 - 2 * xi)]) / l
    Hxx = np.stack([-6 + 12 * xi, l * (-4 + 6 * xi), 6 - 12 * xi, l * (6 * xi - 2)]) / l**2
    w_of = np.zeros((6, 4))  # w-shape coefficients of (ψ1, β1, w1, ψ2, β2, w2): slope DOF = -β
    w_of[2, 0], w_of[1, 1], w_of[5, 2], w_of[4, 3] = 1, -1, 1, -1
    psi = np.zeros((6, xi.size))
    psi[0], psi[3] = 1 - xi, xi
    Nw, Nwx, Nwxx = w_of @ H, w_of @ Hx, w_of @ Hxx
    quad = lambda a, b, f=1.0: l * np.einsum("g,ig,jg->ij", wg * f, a, b)  # noqa: E731
    F = c[0, 0] + c[0, 1] * xi + c[0, 2] * xi**2
    one = lambda x: np.array([x])  # noqa: E731
    np.testing.assert_allclose(oop.mass(one(rho_a), one(rho_ip), one(l))[0],
                               rho_a * quad(Nw, Nw) + rho_ip * quad(psi, psi), atol=1e-14)
    dpsi = np.zeros((6, xi.size))
    dpsi[0], dpsi[3] = -1 / l, 1 / l
    np.testing.assert_allclose(oop.structural(one(ei), one(gj), one(l))[0],
                               ei * quad(Nwxx, Nwxx) + gj * quad(dpsi, dpsi), rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(oop.axial_force(c, one(l))[0], quad(Nwx, Nwx, F), atol=1e-13)
    B, w = oop.strains(one(ei), one(gj), one(l))
    np.testing.assert_allclose(np.einsum("esi,es,esj->eij", B, w, B)[0], oop.structural(one(ei), one(gj), one(l))[0],
                               rtol=1e-12, atol=1e-10)


def test_torsion_of_a_clamped_free_bar():
    """Linear twist elements with consistent mass: ω_j² = (6c²/h²)(1 - cos θ)/(2 + cos θ),
    θ = (2j - 1)π/(2n), exactly; within h²-accuracy of the continuum (π/2)c/L."""
    L, gj, rho_ip = 0.5, 40.0, 2e-4
    c = np.sqrt(gj / rho_ip)
    errors = []
    for n in (8, 16):
        M, K, _ = line(n, L, 7.0, gj, 1e-3, rho_ip)
        twist = np.arange(3, 3 * n + 3, 3)  # a straight bar: twist decoupled from bending
        bend = np.setdiff1d(np.arange(3 * n + 3), np.r_[0, twist])
        assert not K[np.ix_(twist, bend)].any() and not M[np.ix_(twist, bend)].any()
        got = eig(M, K, twist)[:3]
        h, theta = L / n, (2 * np.arange(1, 4) - 1) * np.pi / (2 * n)
        exact_discrete = np.sqrt(6 * c**2 / h**2 * (1 - np.cos(theta)) / (2 + np.cos(theta)))
        np.testing.assert_allclose(got, exact_discrete, rtol=1e-10)
        errors.append(got[0] / (np.pi / 2 * c / L) - 1)
    assert 0 < errors[1] < 1e-3 and 3.9 < errors[0] / errors[1] < 4.1  # h² convergence from above


@pytest.mark.parametrize("ends, roots", [("clamped", [4.7300408, 7.8532046, 10.9956078]),
                                         ("pinned", [np.pi, 2 * np.pi, 3 * np.pi])])
def test_out_of_plane_bending_closed_forms(ends, roots):
    """Non-rotating clamped-clamped and pinned-pinned (released about the weak axis) bending:
    ω = (βL)² sqrt(EI_out / (ρA L⁴))."""
    n, L, ei, rho_a = 16, 0.4, 3.0, 0.2
    M, K, _ = line(n, L, ei, 1.0, rho_a, 1e-3)
    last = 3 * n
    fixed = [1, 2, last + 1, last + 2] if ends == "clamped" else [2, last + 2]
    free = np.setdiff1d(np.arange(3 * n + 3), fixed + list(range(0, 3 * n + 3, 3)))  # bending DOFs (β, w)
    got = eig(M, K, free)[:3]
    exact = np.array(roots) ** 2 * np.sqrt(ei / (rho_a * L**4))
    np.testing.assert_allclose(got, exact, rtol=2e-4)  # cubic Hermite at 16 elements: from above, ~h⁴
    assert np.all(got >= exact) and got[0] / exact[0] - 1 < 1e-5


def test_compressed_rod_released_about_the_weak_axis():
    """Pinned-pinned out of plane under a compression P: ω₁² = ω₀²(1 - P/P_cr) and divergence
    (a negative eigenvalue of K) beyond P_cr = π² EI_out / L²."""
    n, L, ei, rho_a = 16, 0.3, 2.0, 0.1
    p_cr = np.pi**2 * ei / L**2
    fixed = [2, 3 * n + 2] + list(range(0, 3 * n + 3, 3))  # w at the ends; the (decoupled) twist
    free = np.setdiff1d(np.arange(3 * n + 3), fixed)
    M, K, Kg = line(n, L, ei, 1.0, rho_a, 1e-3, force=-1.0)  # Kg per unit compression
    w0 = eig(M, K, free)[0]
    for ratio in (0.25, 0.5, 0.9):
        w = eig(M, K + ratio * p_cr * Kg, free)[0]
        np.testing.assert_allclose(w**2 / w0**2, 1 - ratio, atol=2e-5)
    lowest = lambda P: sla.eigh((K + P * Kg)[np.ix_(free, free)], M[np.ix_(free, free)],  # noqa: E731
                                eigvals_only=True)[0]
    assert lowest(0.9999 * p_cr) > 0 > lowest(1.0002 * p_cr)


# -- the grillage: independent assembly from textbook matrices --------------------------------
def textbook(l, ei, gj, rho_a, rho_ip, phi):
    """Grillage element in ground DOFs (w, θ_X, θ_Y) per node, from the textbook beam matrices in
    (w, w') and the torsion bar, w' = -θ·e⊥ (right-hand rotation about e⊥ lowers w ahead)."""
    kb = ei / l**3 * np.array([[12, 6 * l, -12, 6 * l], [6 * l, 4 * l**2, -6 * l, 2 * l**2],
                               [-12, -6 * l, 12, -6 * l], [6 * l, 2 * l**2, -6 * l, 4 * l**2]])
    mb = rho_a * l / 420 * np.array([[156, 22 * l, 54, -13 * l], [22 * l, 4 * l**2, 13 * l, -3 * l**2],
                                     [54, 13 * l, 156, -22 * l], [-13 * l, -3 * l**2, -22 * l, 4 * l**2]])
    kt, mt = gj / l * np.array([[1, -1], [-1, 1]]), rho_ip * l / 6 * np.array([[2, 1], [1, 2]])
    c, s = np.cos(phi), np.sin(phi)
    # (w, w') and twist of each node from (w, θ_X, θ_Y): twist = θ·e, w' = -θ·e⊥
    B = np.zeros((6, 6))
    for node in (0, 1):
        o = 3 * node
        B[2 * node, o] = 1.0
        B[2 * node + 1, o + 1 : o + 3] = [s, -c]
        B[4 + node, o + 1 : o + 3] = [c, s]
    K = B.T @ sla.block_diag(kb, kt) @ B
    M = B.T @ sla.block_diag(mb, mt) @ B
    return M, K


def test_l_shaped_grillage_couples_bending_and_torsion():
    """Two members at 90°, rigidly joined, one clamped: the module's elements turned by
    T = blockdiag(R, 1, R, 1) reproduce the textbook grillage, and the joint turns the second
    member's bending into the first one's torsion (the fundamental is not the straight bar's)."""
    l, ei, gj, rho_a, rho_ip = 0.25, 4.0, 3.0, 0.3, 2e-4
    phis = np.array([0.0, np.pi / 2])
    one = np.ones(2)
    T = np.array([oop_rotation(p) for p in phis])
    m_g = np.swapaxes(T, 1, 2) @ oop.mass(rho_a * one, rho_ip * one, l * one) @ T
    k_g = np.swapaxes(T, 1, 2) @ oop.structural(ei * one, gj * one, l * one) @ T
    order = [2, 0, 1]  # the module's (θ_X, θ_Y, w) per node -> textbook (w, θ_X, θ_Y)
    perm = np.array(order + [3 + i for i in order])
    Mc, Kc, Mt, Kt = (np.zeros((9, 9)) for _ in range(4))
    for e in range(2):
        sl = slice(3 * e, 3 * e + 6)
        Mc[sl, sl] += m_g[e][np.ix_(perm, perm)]
        Kc[sl, sl] += k_g[e][np.ix_(perm, perm)]
        Me, Ke = textbook(l, ei, gj, rho_a, rho_ip, phis[e])
        Mt[sl, sl] += Me
        Kt[sl, sl] += Ke
    free = np.arange(3, 9)
    got, want = eig(Mc, Kc, free), eig(Mt, Kt, free)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    straight = eig(*line(2, 2 * l, ei, gj, rho_a, rho_ip)[:2], free)
    assert abs(got[0] / straight[0] - 1) > 0.1  # the L is not the straight bar


def oop_rotation(phi):
    from fkev_slepc.model.elements import rotation

    return rotation(np.array([phi]))[0]


def test_four_bar_grillage_against_independent_assembly():
    """Bahgat–Willmert at rest, out of plane: the Model's spectrum equals a grillage assembled here
    from textbook matrices (pins share w, θ_X, θ_Y; ground pivots and the crank root fix them)."""
    E, rho = 2.07e11, 7760.0
    scene = bahgat_willmert(elements=(1, 2, 2), cases=("structure",))
    sec = rect_section(scene, E, rho)
    model = Model(scene, plane="out", section=sec)
    theta = np.radians(37.0)
    phi = model.kinematics(theta).phi[0]  # crank, coupler, follower
    # nodes: O1=0, A=1, coupler mid=2, B=3, follower mid=4, O2=5; elements (node, node, link)
    elems = [(0, 1, 0), (1, 2, 1), (2, 3, 1), (5, 4, 2), (4, 3, 2)]
    m = build_mechanism(scene)
    M, K = np.zeros((18, 18)), np.zeros((18, 18))
    for e, (a, b, lk) in enumerate(elems):
        Me, Ke = textbook(m.elem_length[e], sec.ei_out[e], sec.gj[e], m.elem_rho_a[e], sec.rho_ip[e], phi[lk])
        idx = np.r_[3 * a : 3 * a + 3, 3 * b : 3 * b + 3]
        M[np.ix_(idx, idx)] += Me
        K[np.ix_(idx, idx)] += Ke
    free = np.r_[3:15]
    want = eig(M, K, free)
    r = spectrum(model, 37.0, 0.0, "structure", 6)
    assert model.n_free == 12
    np.testing.assert_allclose(r.frequency_hz * 2 * np.pi, want[:6], rtol=1e-10)


# -- the rotating link -------------------------------------------------------------------------
@pytest.mark.parametrize("lam", [0.0, 12.0])
def test_rotating_cantilever_flapwise_tables(lam):
    """Flapwise (out-of-plane) bending of a rotating cantilever, 16 elements: ω̄ = ω sqrt(ρAL⁴/EI_out)
    at λ = Ω sqrt(ρAL⁴/EI_out) equals the published values to 1e-4 (the axial-force stiffening of the
    rotation alone: no normal softening acts on w, §19.4)."""
    L, b, t = 1.0, 0.01, 0.002
    props = rect_strip(b, t)
    E, rho, A = props["youngs_modulus"], props["density"], props["area"]
    i_out = b * t**3 / 12
    sec = Section(np.array([E * i_out]), np.array([1e3 * E * i_out]), np.array([rho * (b * t**3 + t * b**3) / 12]))
    scale = np.sqrt(rho * A * L**4 / (E * i_out))
    model = Model(cantilever(L, props, 16, cases=("full",)), plane="out", section=sec)
    got = spectrum(model, 0.0, lam / scale, "full", 3).frequency_hz * 2 * np.pi * scale
    np.testing.assert_allclose(got, FLAP[lam], rtol=1e-4)


def test_propeller_moment_shifts_the_twist_by_omega_squared():
    """A straight rotating cantilever's twist decouples from its bending, and the propeller moment
    (the normal term out of plane, §19.4) adds Ω²(I_yy - I_zz)/I_p to every twist ω² exactly and
    nothing to the bending modes; ``no_normal`` drops it, ``no_pseudo_normal`` keeps only it."""
    L, b, t = 0.5, 0.02, 0.008
    props = rect_strip(b, t)
    E, rho = props["youngs_modulus"], props["density"]
    i_in, i_out = t * b**3 / 12, b * t**3 / 12
    sec = Section(np.array([E * i_out]), np.array([E / 2.6 * 2.5e-9]), np.array([rho * (i_in + i_out)]))
    omega, n = 900.0, 8
    shift = omega**2 * (i_in - i_out) / (i_in + i_out)
    model = Model(cantilever(L, props, 8, cases=("full", "no_normal", "no_pseudo_normal")), plane="out", section=sec)
    w2 = {(c, w): (spectrum(model, 0.0, w, c, n).frequency_hz * 2 * np.pi) ** 2
          for c, w in (("full", omega), ("no_normal", omega), ("no_pseudo_normal", omega), ("full", 0.0))}
    for d in (w2["full", omega] - w2["no_normal", omega], w2["no_pseudo_normal", omega] - w2["full", 0.0]):
        twist = np.abs(d / shift - 1) < 1e-6
        bending = np.abs(d) < 1e-6 * shift
        assert np.all(twist | bending) and 2 <= twist.sum() < n, d / shift


def test_cases_out_of_plane():
    """Out of plane full ≡ no_coriolis ≡ no_tangential (no such terms, §19.6): symmetric K, no C."""
    E, rho = 2.07e11, 7760.0
    scene = bahgat_willmert(elements=(2, 2, 2))
    model = Model(scene, plane="out", section=rect_section(scene, E, rho))
    p = model.pieces(np.radians(10.0))
    assert p.coriolis is None and p.tangential is None
    ref = model.qep(p, 1000.0, "full")
    assert ref.damping is None and ref.kind == "linear_symmetric"
    assert abs(ref.stiffness - ref.stiffness.T).max() <= 1e-14 * abs(ref.stiffness).max()
    for case in ("no_coriolis", "no_tangential"):
        q = model.qep(p, 1000.0, case)
        assert q.damping is None and abs(q.stiffness - ref.stiffness).max() == 0.0
    f = {c: spectrum(model, 10.0, 1000.0, c, 4).frequency_hz for c in ("structure", "full", "no_pseudo_normal")}
    assert not np.allclose(f["full"], f["structure"], rtol=1e-6)
    assert not np.allclose(f["full"], f["no_pseudo_normal"], rtol=1e-6)


@pytest.mark.parametrize("build", [bahgat_willmert, turcic_midha])
def test_slepc_matches_dense_out_of_plane(build):
    """SLEPc ≡ dense QZ to 1e-9 on both thesis linkages out of plane, at rest and at speed."""
    from fkev_slepc.solve.engines import cross_check

    E, rho = (2.07e11, 7760.0) if build is bahgat_willmert else (7.1e10, 2710.0)
    scene = build(cases=("full",))
    model = Model(scene, plane="out", section=rect_section(scene, E, rho))
    p = model.pieces(np.radians(10.0))
    for omega in (0.0, 500.0):
        assert cross_check(model.qep(p, omega, "full"), 4) < 1e-9


def test_in_plane_model_unchanged():
    """plane='in' is the default model to the last bit, and the out-of-plane model of the same
    scene does not disturb it."""
    scene = bahgat_willmert(cases=("full",))
    a = Model(scene)
    Model(scene, plane="out", section=rect_section(scene, 2.07e11, 7760.0))
    b = Model(scene, plane="in")
    pa, pb = a.pieces(0.3), b.pieces(0.3)
    qa, qb = a.qep(pa, 700.0, "full"), b.qep(pb, 700.0, "full")
    for x, y in ((qa.mass, qb.mass), (qa.damping, qb.damping), (qa.stiffness, qb.stiffness)):
        assert np.array_equal(x.data, y.data)


def test_bad_out_of_plane_input_is_named():
    scene = bahgat_willmert(cases=("full",))
    with pytest.raises(ValueError, match="plane must be one of in, out"):
        Model(scene, plane="z")
    with pytest.raises(ValueError, match="section gj: must be finite and > 0 .*-1.0"):
        Model(scene, plane="out", section=Section(np.array([1.0]), np.array([-1.0]), np.array([1.0])))
    with pytest.raises(ValueError, match="out-of-plane section data"):
        Model(scene, plane="out")


def test_compliant_bearings_against_independent_assembly():
    """Bahgat–Willmert at rest with a compliant joint A (crank and coupler share w only; their
    rotations tied by k_t about the crank's axis and k_b across it) and a compliant ground bearing
    O2 (the follower's rotations tied to ground): the Model equals a grillage assembled here with
    the springs (1/2)k_t(Δθ·e)² + (1/2)k_b(Δθ·e⊥)²; very stiff bearings give the rigid joints."""
    E, rho = 2.07e11, 7760.0
    scene = bahgat_willmert(elements=(1, 2, 2), cases=("structure",))
    sec = rect_section(scene, E, rho)
    k = {"A": (300.0, 800.0), "O2": (500.0, 2000.0)}
    model = Model(scene, plane="out", section=sec, bearings=k)
    theta = np.radians(37.0)
    phi = model.kinematics(theta).phi[0]
    m = build_mechanism(scene)
    # nodes: O1=0, A on the crank=1, coupler mid=2, B=3, follower mid=4, O2=5, A on the coupler=6
    elems = [(0, 1, 0), (6, 2, 1), (2, 3, 1), (5, 4, 2), (4, 3, 2)]
    dof = {n: np.arange(3 * n, 3 * n + 3) for n in range(7)}
    dof[6] = np.array([3, 18, 19])  # shares w with node 1, own rotations
    n = 20
    M, K = np.zeros((n, n)), np.zeros((n, n))
    for e, (a, b, lk) in enumerate(elems):
        Me, Ke = textbook(m.elem_length[e], sec.ei_out[e], sec.gj[e], m.elem_rho_a[e], sec.rho_ip[e], phi[lk])
        idx = np.r_[dof[a], dof[b]]
        M[np.ix_(idx, idx)] += Me
        K[np.ix_(idx, idx)] += Ke

    def spring(rot_a, rot_b, kt, kb, angle):
        e, en = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
        D = kt * np.outer(e, e) + kb * np.outer(en, en)
        for ra, rb, sign in ((rot_a, rot_a, 1), (rot_b, rot_b, 1), (rot_a, rot_b, -1), (rot_b, rot_a, -1)):
            if ra is not None and rb is not None:
                K[np.ix_(ra, rb)] += sign * D

    spring(dof[1][1:], dof[6][1:], *k["A"], phi[0])  # in the crank's axes (the joint's first link)
    spring(dof[5][1:], None, *k["O2"], phi[2])  # the follower to ground
    free = np.r_[3:15, 16, 17, 18, 19]  # O1 clamped; O2's w fixed, its rotations on the spring
    want = eig(M, K, free)
    assert model.n_free == free.size
    got = spectrum(model, 37.0, 0.0, "structure", 6).frequency_hz * 2 * np.pi
    np.testing.assert_allclose(got, want[:6], rtol=1e-10)
    rigid = spectrum(Model(scene, plane="out", section=sec), 37.0, 0.0, "structure", 4).frequency_hz
    stiff = spectrum(Model(scene, plane="out", section=sec, bearings={"A": (1e9, 1e9), "O2": (1e9, 1e9)}),
                     37.0, 0.0, "structure", 4).frequency_hz
    np.testing.assert_allclose(stiff, rigid, rtol=1e-5)
    assert np.all(got[:4] / (2 * np.pi) < rigid)  # compliance lowers every frequency
    with pytest.raises(ValueError, match="bearings.A: two stiffnesses .* .got -1"):
        Model(scene, plane="out", section=sec, bearings={"A": -1})
    with pytest.raises(ValueError, match="bearings: unknown joint 'Q'"):
        Model(scene, plane="out", section=sec, bearings={"Q": (1.0, 1.0)})
