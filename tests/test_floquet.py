"""Floquet engine (fkev_slepc/solve/floquet.py) against known answers.

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

from fkev_slepc.solve import floquet as fq


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

    x0 = fq.periodic_initial_state(mono)
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
        fq.periodic_initial_state(fq.monodromy(gen, np.pi, steps=8))
