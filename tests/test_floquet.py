"""Floquet engine (fkev_slepc/periodic/magnus.py) against known answers.

Mathieu equation y'' + (a - 2q cos 2t) y = 0 (period π): on the transition curves a = a₀(q)
(π-periodic ce₀) and a = b₁(q) (π-antiperiodic se₁) the monodromy's trace is +2 and -2; the
characteristic values come from scipy.special (an independent series method), and the monodromy
is cross-checked by an explicit Runge-Kutta integration (DOP853 at tight tolerance).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import mathieu_a, mathieu_b

from fkev_slepc.periodic import magnus as fq


def periodic_initial_state(mono):
    """x0 of the P-periodic forced response: (I - Φ) x0 = x_p(P) (the shooting condition; the
    product's solve with its resonance test is fkev_slepc/periodic/shooting.py)."""
    if mono.particular is None:
        raise ValueError("periodic_initial_state: the monodromy was computed without a forcing")
    if np.min(np.abs(mono.multipliers - 1.0)) < 1e-12:
        raise ValueError("periodic_initial_state: 1 is a Floquet multiplier (resonant forcing); "
                         "the periodic response is not unique")
    n = mono.phi.shape[0]
    return np.linalg.solve(np.eye(n) - mono.phi, mono.particular)


def mathieu(a, q, damping=0.0):
    def coefficients(t):
        k = t.size
        M = np.ones((k, 1, 1))
        C = np.full((k, 1, 1), damping)
        K = (a - 2.0 * q * np.cos(2.0 * t)).reshape(k, 1, 1)
        return M, C, K

    return coefficients


def dop853_monodromy(a, q, damping=0.0, period=np.pi):
    def rhs(t, y):
        return [y[1], -damping * y[1] - (a - 2.0 * q * np.cos(2.0 * t)) * y[0]]

    cols = [solve_ivp(rhs, (0.0, period), e, method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
            for e in np.eye(2)]
    return np.column_stack(cols)


@pytest.mark.parametrize("q", [1.0, 5.0, 10.0])
@pytest.mark.parametrize("curve, sign", [("a0", 2.0), ("b1", -2.0)])
def test_mathieu_transition_curves(q, curve, sign):
    a = mathieu_a(0, q) if curve == "a0" else mathieu_b(1, q)
    mono = fq.monodromy(fq.second_order(mathieu(a, q)), np.pi, tol=1e-10)
    assert mono.converged and mono.phi_error < 1e-10
    assert abs(np.trace(mono.phi) - sign) < 1e-8
    assert abs(np.linalg.det(mono.phi) - 1.0) < 1e-10  # trace-free generator: det Φ = 1
    ref = dop853_monodromy(a, q)
    assert abs(np.trace(ref) - sign) < 1e-8
    assert np.max(np.abs(mono.phi - ref)) < 1e-8 * max(1.0, np.abs(ref).max())
    # a double multiplier ±1 (a Jordan block): the multiplier estimate is only sqrt-accurate
    assert np.all(np.abs(mono.multipliers - sign / 2.0) < 1e-3)


def test_mathieu_inside_a_tongue_grows():
    # a = 1, q = 0.5 lies inside the first instability tongue (between b₁ and a₁)
    a, q = 1.0, 0.5
    assert mathieu_b(1, q) < a < mathieu_a(1, q)
    mono = fq.monodromy(fq.second_order(mathieu(a, q)), np.pi, order=4, tol=1e-11)
    ref = dop853_monodromy(a, q)
    mu_ref = np.sort(np.abs(np.linalg.eigvals(ref)))
    assert mono.max_abs > 1.0 + 1e-2
    assert abs(mono.max_abs - mu_ref[-1]) < 1e-8
    assert abs(mono.growth_rate - np.log(mu_ref[-1]) / np.pi) < 1e-8
    assert np.allclose(np.exp(mono.exponents * np.pi), mono.multipliers, rtol=1e-12)


def test_magnus_orders_converge_at_their_rate():
    # a fixed-step monodromy: the error ratio on halving the step is 2^p
    gen = fq.second_order(mathieu(2.3, 1.7))
    ref = dop853_monodromy(2.3, 1.7)
    for order in (4, 6):
        e = [np.abs(fq.monodromy(gen, np.pi, order=order, steps=s).phi - ref).max()
             for s in (16, 32)]
        assert 0.6 * 2**order < e[0] / e[1] < 1.6 * 2**order


def test_constant_coefficients_exact_for_any_step():
    # Magnus is exact for constant A: a stiff oscillator (ω P = 3000 rad) in two steps
    w = 1000.0
    A = np.array([[0.0, 1.0], [-w * w, 0.0]])
    mono = fq.monodromy(lambda t: np.broadcast_to(A, (t.size, 2, 2)), 3.0, steps=2)
    exact = np.array([[np.cos(3 * w), np.sin(3 * w) / w], [-w * np.sin(3 * w), np.cos(3 * w)]])
    assert np.max(np.abs(mono.phi - exact)) < 1e-9
    assert np.all(np.abs(np.abs(mono.multipliers) - 1.0) < 1e-12)


def test_particular_solution_and_periodic_response():
    # damped Mathieu oscillator forced at the parametric frequency: shooting gives the periodic
    # response; x_p(P) and the trajectory are checked against DOP853
    a, q, c = 2.0, 0.8, 0.3
    coefficients = mathieu(a, q, damping=c)

    def load(t):
        return np.stack([np.cos(2.0 * t) + 0.5 * np.sin(4.0 * t)], axis=1)

    forcing = fq.second_order_forcing(lambda t: coefficients(t)[0], load)
    gen = fq.second_order(coefficients)
    mono = fq.monodromy(gen, np.pi, forcing=forcing, tol=1e-12)
    assert mono.particular.shape == (2,) and mono.particular_error < 1e-10

    def rhs(t, y):
        return [y[1], -c * y[1] - (a - 2 * q * np.cos(2 * t)) * y[0] + load(np.array([t]))[0, 0]]

    xp = solve_ivp(rhs, (0, np.pi), [0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    assert np.max(np.abs(mono.particular - xp)) < 1e-10
    assert np.max(np.abs(mono.phi - dop853_monodromy(a, q, c))) < 1e-10

    x0 = periodic_initial_state(mono)
    thetas = np.linspace(0.0, np.pi, 7)
    path = fq.trajectory(gen, x0, thetas, forcing=forcing, steps=512)
    assert path.shape == (7, 2)
    assert np.max(np.abs(path[-1] - x0)) < 1e-10  # periodic
    ref = solve_ivp(rhs, (0, np.pi), x0, method="DOP853", t_eval=thetas, rtol=1e-13, atol=1e-14)
    assert np.max(np.abs(path - ref.y.T)) < 1e-10


def test_bad_arguments_are_named():
    gen = fq.second_order(mathieu(1.0, 1.0))
    with pytest.raises(ValueError, match="order"):
        fq.monodromy(gen, np.pi, order=5)
    with pytest.raises(ValueError, match="steps"):
        fq.monodromy(gen, np.pi, steps=7)
    with pytest.raises(ValueError, match="period"):
        fq.monodromy(gen, -1.0)
    with pytest.raises(ValueError, match="forcing"):
        periodic_initial_state(fq.monodromy(gen, np.pi, steps=8))


# --------------------------------------------------------------------------------------------
# The linkage as a periodic system (model/periodic.py, fkev_slepc/periodic/floquet.py)

import scipy.linalg as la  # noqa: E402
from builders import cantilever, rect_strip  # noqa: E402

from fkev_slepc.model.operators import Model  # noqa: E402
from fkev_slepc.model.periodic import periodic_pieces  # noqa: E402
from fkev_slepc.scene import load_scene  # noqa: E402
from fkev_slepc.periodic.floquet import TrigInterpolant, floquet_multipliers, to_dense  # noqa: E402
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem

RUNS = __import__("pathlib").Path(__file__).resolve().parents[1] / "runs"
# in-plane frequencies of a slender rotating blade at λ = 12: sqrt(ω_flap² - λ²) with the
# flapwise values tests/test_rotating_cantilever.py checks (Wright et al. 1982; Hoa 1979)
FLAP_12 = np.array([13.1702, 37.6031, 79.6145])
STRIP = rect_strip(0.005, 0.002)  # L/r = 693
STRIP_SCALE = np.sqrt(STRIP["density"] * STRIP["area"] / (STRIP["youngs_modulus"] * STRIP["second_moment"]))


def _model(name, case="full"):
    return Model(load_scene(RUNS / name), cases=(case,))


def _dense(model, data):
    return to_dense(model.pattern, np.atleast_2d(data))


def _frozen_state_eigenvalues(model, theta, omega, case):
    q = model.qep(model.pieces(theta), omega, case)
    n = model.n_free
    M, C, K = (x.toarray() for x in (q.mass, q.damping, q.stiffness))
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-la.solve(M, K), -la.solve(M, C)]])
    return la.eigvals(A)


@pytest.mark.parametrize("scene", ["turcic-midha-1984.toml", "bahgat-willmert-1976.toml"])
def test_gyroscopic_symmetric_part_is_the_mass_rate(scene):
    """Undamped: sym C = Ω dM/dθ (C₁ = C/Ω), the Lagrangian identity; the frozen C (skew) fails it."""
    model = _model(scene)
    th, h = 0.9, 2e-3
    w = np.array([-1, 9, -45, 0, 45, -9, 1]) / (60 * h)  # 6th-order central difference
    p = periodic_pieces(model, th + h * np.arange(-3, 4), "full")
    dM = _dense(model, w @ p.mass)[0]
    C1 = _dense(model, p.gyro[3])[0]
    scale = np.abs(C1).max()
    assert np.abs(0.5 * (C1 + C1.T) - dM).max() < 1e-8 * scale
    # canonical pieces: C₁ = N₁ - N₁ᵀ + dM/dθ, K₂ = V₂ + dN₁/dθ, V₂ symmetric
    N1, V2 = _dense(model, p.coupling[3])[0], _dense(model, p.potential[3])[0]
    dN = _dense(model, w @ p.coupling)[0]
    K2 = _dense(model, p.speed_stiffness[3])[0]
    assert np.abs(C1 - (N1 - N1.T) - dM).max() < 1e-8 * scale
    assert np.abs(K2 - V2 - dN).max() < 1e-8 * np.abs(K2).max()
    assert np.abs(V2 - V2.T).max() < 1e-12 * np.abs(V2).max()
    # the frozen Coriolis matrix is skew: its symmetric part misses dM/dθ entirely
    G = model.pattern.matrix(model.pieces(th).coriolis).toarray()
    assert np.abs(0.5 * (G + G.T) - dM).max() > 0.5 * np.abs(dM).max()
    # the mass is the frozen one
    assert np.array_equal(p.mass[3], model.pieces(th).mass)


def test_periodic_refuses_crank_acceleration():
    scene = cantilever(1.0, STRIP, 2, accel=10.0)
    with pytest.raises(ValueError, match="driver.acceleration_rad_s2"):
        periodic_pieces(Model(scene), [0.0, 1.0])


def test_lone_rotating_crank_multipliers_are_its_frozen_spectrum():
    """The crank alone is time-invariant in its own frame: every multiplier is exp(sP) of a frozen
    eigenvalue s (P = 2π/Ω), |μ| = 1 undamped; the frozen matrices used as periodic coefficients
    give a spurious growth."""
    omega = 12.0 / STRIP_SCALE  # λ = 12
    model = Model(cantilever(1.0, STRIP, 3))
    res = floquet_multipliers(PeriodicSystem(model, omega, "full"), PeriodicSettings(reduce="none", steps=16384))
    assert res.error < 1e-8
    assert np.max(np.abs(np.abs(res.multipliers) - 1.0)) < 1e-8
    s = _frozen_state_eigenvalues(model, 0.4, omega, "full")
    expected = np.exp(s * 2 * np.pi / omega)
    i, j = fq.match_multipliers(res.multipliers, expected)
    assert np.max(np.abs(res.multipliers[i] - expected[j])) < 1e-8

    # the frozen Model.qep matrices as periodic coefficients (trigonometric interpolant of 64
    # samples): spurious growth
    def frozen(theta):
        qs = [model.qep(model.pieces(t), omega, "full") for t in theta]
        M, C, K = (np.stack([getattr(q, k).toarray() for q in qs]) for k in ("mass", "damping", "stiffness"))
        return M, C / omega, K / omega**2  # d/dt = Ω d/dθ

    samples = fq.second_order(frozen)(2 * np.pi * np.arange(64) / 64)
    wrong = fq.monodromy(TrigInterpolant(0.0, samples), 2 * np.pi, steps=8192)
    assert wrong.error < 1e-3 * wrong.max_abs
    assert wrong.max_abs > 10.0


def test_lone_crank_phases_are_the_published_in_plane_frequencies():
    """16 elements reduced to its 3 lowest co-rotating frozen modes (exact for a lone crank:
    truncation error measured against 6): the multipliers of the in-plane modes are
    exp(±2πi r/λ), r = sqrt(ω_flap² - λ²) with the published flapwise values."""
    lam = 12.0
    res = floquet_multipliers(PeriodicSystem(Model(cantilever(1.0, STRIP, 16)), lam / STRIP_SCALE, "full"),
                              PeriodicSettings(reduce=3, basis_angles=1, monodromy_tol=1e-10))
    assert res.basis == 3 and res.truncation.value < 1e-8
    assert np.max(np.abs(np.abs(res.multipliers) - 1.0)) < 1e-8
    r = np.sqrt(FLAP_12**2 - lam**2)
    for rk in r:
        gap = np.min(np.abs(res.multipliers - np.exp(2j * np.pi * rk / lam)))
        assert gap < 2 * np.pi * rk / lam * 2e-3  # the published values' 1e-3-level accuracy
    freq = np.sort(np.abs(res.exponents.imag))[::2] * STRIP_SCALE  # unwrapped, nondimensional
    np.testing.assert_allclose(freq, r, rtol=2e-3)


@pytest.fixture(scope="module")
def bw_500():
    model = _model("bahgat-willmert-1976.toml")
    return model, floquet_multipliers(PeriodicSystem(model, 500.0, "full", damping=False),
                                      PeriodicSettings(reduce="none", monodromy_tol=1e-9))


def test_bahgat_willmert_undamped_monodromy_is_symplectic(bw_500):
    """Full model (5 elements, 15 DOFs) at 500 rad/s, undamped: det Φ = 1, the multiplier set is
    closed under μ -> 1/μ̄, and every |μ| = 1 (the linkage is Floquet-stable there)."""
    _, res = bw_500
    mu = res.multipliers
    assert res.error < 1e-8
    assert abs(np.linalg.det(res.monodromy.phi) - 1.0) < 1e-8
    i, j = fq.match_multipliers(mu, 1.0 / mu.conj())
    assert np.max(np.abs(mu[i] - 1.0 / mu[j].conj())) < 1e-8
    assert np.max(np.abs(np.abs(mu) - 1.0)) < 1e-8


def _tm_one_element():
    from dataclasses import replace

    base = load_scene(RUNS / "turcic-midha-1984.toml")
    return replace(base, links=tuple(replace(lk, elements=1) for lk in base.links))


def _same_set(a, b, tol):
    i, j = fq.match_multipliers(a, b)
    return np.max(np.abs(a[i] - b[j]) / np.maximum(1.0, np.abs(a[i]))) < tol


@pytest.mark.parametrize("which", ["turcic-midha", "bahgat-willmert"])
def test_speed_scaling_and_reversal(which, bw_500):
    """(E, Ω) -> (s²E, sΩ) leaves the multipliers unchanged; Ω -> -Ω maps them to {1/μ}.
    Turcic–Midha (3 elements, 9 DOFs) at 200 rad/s, where it is unstable (max|μ| ~ 1.5e3)."""
    from dataclasses import replace

    if which == "bahgat-willmert":
        (model, res), omega = bw_500, 500.0
        base = model.scene
    else:
        base, omega = _tm_one_element(), 200.0
        res = floquet_multipliers(PeriodicSystem(Model(base, ("full",)), omega, "full", damping=False),
                                  PeriodicSettings(reduce="none", monodromy_tol=1e-9))
        assert res.max_abs > 100.0
    s = 1.5
    links = tuple(replace(lk, youngs_modulus=lk.youngs_modulus * s * s) for lk in base.links)
    scaled = floquet_multipliers(PeriodicSystem(Model(replace(base, links=links), ("full",)), s * omega, "full", damping=False),
                                 PeriodicSettings(reduce="none", monodromy_tol=1e-9))
    assert _same_set(res.multipliers, scaled.multipliers, 1e-7)
    back = floquet_multipliers(PeriodicSystem(Model(base, ("full",)), -omega, "full", damping=False),
                               PeriodicSettings(reduce="none", monodromy_tol=1e-9))
    assert _same_set(1.0 / res.multipliers, back.multipliers, 1e-7)


def test_slow_crank_keeps_every_multiplier_on_the_unit_circle():
    """Ω ≪ ω₁ (Bahgat–Willmert, ω₁ = 1778 rad/s, Ω = ω₁/10, away from the narrow resonances):
    every |μ| = 1 within 1e-6."""
    res = floquet_multipliers(PeriodicSystem(_model("bahgat-willmert-1976.toml"), 177.8, "full", damping=False),
                              PeriodicSettings(reduce="none", steps=4096))
    assert res.error < 1e-6
    assert np.max(np.abs(np.abs(res.multipliers) - 1.0)) < 1e-6


def test_structural_damping_makes_the_crank_decay():
    """Rayleigh damping on each element's own deformation rate: every |μ| < 1, and a rigidly
    rotating deformed link is not damped (the damping force of q_e = const vanishes)."""
    from dataclasses import replace

    from fkev_slepc.scene.model import Damping

    scene = replace(cantilever(1.0, STRIP, 2), damping=Damping(0.5, 1e-5))
    model = Model(scene)
    omega = 12.0 / STRIP_SCALE
    p = periodic_pieces(model, np.array([0.3]), "full")
    # q_g = Tᵀ(θ) q_e with q_e fixed: q̇_g = Ω dTᵀ/dθ q_e; the damping force C_d q̇ + K_d q is 0
    th, h = 0.3, 1e-6
    q_e = np.random.default_rng(1).standard_normal(model.n_free)
    from fkev_slepc.periodic.reduce import corotated_pairs, rotate_rows

    pairs = corotated_pairs(model.mechanism)
    q = lambda t: rotate_rows(q_e[:, None], pairs, np.full(len(pairs[0]), t))[:, 0]
    qdot = omega * (q(th + h) - q(th - h)) / (2 * h)
    Cd, Kd = _dense(model, p.damping)[0], omega * _dense(model, p.damping_stiffness)[0]
    force = Cd @ qdot + Kd @ q(th)
    assert np.linalg.norm(force) < 1e-7 * np.linalg.norm(Cd @ qdot)
    res = floquet_multipliers(PeriodicSystem(model, omega, "full"), PeriodicSettings(reduce="none", monodromy_tol=1e-9))
    assert res.max_abs < 1.0


def test_corotated_reduction_on_the_whole_space_is_exact():
    """The co-rotating Galerkin projection (fkev_slepc/periodic/reduce.py) with a basis spanning every
    DOF is a change of variables q = Q(θ)V̂η: the multipliers are the full model's (Turcic–Midha,
    1 element per link, 9 DOFs, 200 rad/s)."""
    model = Model(_tm_one_element(), ("full",))
    full = floquet_multipliers(PeriodicSystem(model, 200.0, "full", damping=False),
                               PeriodicSettings(reduce="none", monodromy_tol=1e-10))
    red = floquet_multipliers(PeriodicSystem(model, 200.0, "full", damping=False),
                              PeriodicSettings(reduce=model.n_free - 1, monodromy_tol=1e-10, basis_angles=2), check_truncation=False)
    assert red.basis == model.n_free
    assert _same_set(full.multipliers, red.multipliers, 1e-8)
