"""Periodic-response solvers on closed forms (fkev_slepc/periodic/harmonic_balance.py, fkev_slepc/periodic/shooting.py;
docs/response.md §3): harmonic balance and shooting on the monodromy, each against an exact
periodic solution and against each other, the unstable (|μ| > 1) flag and the resonance refusal."""

import numpy as np
import pytest

from fkev_slepc.periodic.harmonic_balance import (
    MAX_UNKNOWNS, HarmonicResponse, _solve, galerkin_solve, harmonic_balance, harmonics_of,
)
from fkev_slepc.periodic.shooting import ResonanceError, shooting


def fourier_derivative(N: int) -> np.ndarray:
    """Differentiation matrix (N, N) on θ_j = 2πj/N, N odd: D_jk = ½(-1)^(j-k) / sin((j-k)π/N)."""
    if N % 2 == 0 or N < 3:
        raise ValueError(f"N: the collocation needs an odd number of angles >= 3 (got {N})")
    j = np.arange(N)
    d = j[:, None] - j[None, :]
    with np.errstate(divide="ignore"):
        D = 0.5 * (-1.0) ** d / np.sin(d * np.pi / N)
    D[d == 0] = 0.0
    return D


def collocation_solve(coefficients, load, omega: float, N: int) -> HarmonicResponse:
    """The periodic response on N (odd) collocation angles (one dense LU): the equation imposed
    at each θ_j with the Fourier differentiation matrix (aliasing included; the check of the
    Galerkin harmonic balance, fkev_slepc/periodic/harmonic_balance.py)."""
    theta = 2.0 * np.pi * np.arange(N) / N
    M, C, K = (np.asarray(x, dtype=float) for x in coefficients(theta))
    f = np.asarray(load(theta), dtype=float)
    n = M.shape[1]
    assert N * n <= MAX_UNKNOWNS
    D = fourier_derivative(N)
    w = float(omega)
    A = np.einsum("jk,jab->jakb", w * w * (D @ D), M) + np.einsum("jk,jab->jakb", w * D, C)
    A[np.arange(N), :, np.arange(N), :] += K
    y, rcond = _solve(A.reshape(N * n, N * n), f.reshape(-1))
    q = y.reshape(N, n)
    return HarmonicResponse(theta, q, D @ q, harmonics_of(q), float("nan"), rcond)


W = 3.0  # Ω: the coefficients are in the time form, θ = Ωt


def hill(th):
    """A 2-DOF system with periodic M, gyroscopic and damping C, parametric K (time form)."""
    k = th.size
    M, C, K = np.zeros((k, 2, 2)), np.zeros((k, 2, 2)), np.zeros((k, 2, 2))
    M[:, 0, 0], M[:, 1, 1] = 1 + 0.3 * np.cos(th), 2 + 0.5 * np.sin(2 * th)
    M[:, 0, 1] = M[:, 1, 0] = 0.2 * np.cos(th)
    C[:, 0, 1], C[:, 1, 0], C[:, 0, 0] = 0.4 * np.sin(th), -0.4 * np.sin(th), 0.05
    K[:, 0, 0], K[:, 1, 1] = 40 * (1 + 0.2 * np.cos(2 * th)), 90.0
    K[:, 0, 1] = K[:, 1, 0] = -10 + 3 * np.sin(th)
    return M, C, K


def exact(th):
    """q* and its θ-derivatives: the forcing below is made so that q* is the periodic response."""
    q = np.stack([np.cos(th) + 0.3 * np.sin(2 * th), 0.5 + 0.2 * np.cos(3 * th)], -1)
    dq = np.stack([-np.sin(th) + 0.6 * np.cos(2 * th), -0.6 * np.sin(3 * th)], -1)
    ddq = np.stack([-np.cos(th) - 1.2 * np.sin(2 * th), -1.8 * np.cos(3 * th)], -1)
    return q, dq, ddq


def forcing(th):
    M, C, K = hill(th)
    q, dq, ddq = exact(th)
    return (np.einsum("kab,kb->ka", M, W * W * ddq) + np.einsum("kab,kb->ka", C, W * dq)
            + np.einsum("kab,kb->ka", K, q))


def test_harmonic_balance_recovers_the_exact_periodic_solution():
    r = harmonic_balance(hill, forcing, W, tol=1e-12)
    q, dq, _ = exact(r.theta)
    assert np.abs(r.q - q).max() < 1e-12 and np.abs(r.dq - dq).max() < 1e-11
    assert r.error < 1e-12
    th = np.linspace(0, 2 * np.pi, 7)
    assert np.abs(r.at(th) - exact(th)[0]).max() < 1e-12  # the trigonometric interpolant


def test_collocation_recovers_it_too():
    r = collocation_solve(hill, forcing, W, 33)
    assert np.abs(r.q - exact(r.theta)[0]).max() < 1e-12


def test_shooting_recovers_it_and_closes_the_period():
    th = np.linspace(0.0, 2 * np.pi, 9, endpoint=False)
    s = shooting(hill, forcing, W, th, tol=1e-12)
    assert np.abs(s.q - exact(th)[0]).max() < 1e-10
    assert s.closure < 1e-10
    assert s.max_abs_multiplier < 1.0  # damped (C₀₀ = 0.05): the response attracts


def mathieu(a, q, c=0.0):
    """ÿ + c ẏ + (a - 2q cos 2θ) y = 1 + cos θ in θ (Ω = 1)."""
    def coef(th):
        one = np.ones((th.size, 1, 1))
        return one, c * one, (a - 2 * q * np.cos(2 * th))[:, None, None]

    return coef, lambda th: (1 + np.cos(th))[:, None]


@pytest.mark.parametrize("a,q,unstable", [(2.3, 0.5, False), (1.0, 0.3, True)])
def test_forced_mathieu_methods_agree_and_instability_is_flagged(a, q, unstable):
    """Harmonic balance and shooting agree to 1e-9 on a forced Mathieu oscillator; inside the
    first instability tongue (a = 1, q = 0.3) the periodic response exists but |μ| > 1."""
    coef, load = mathieu(a, q)
    r = harmonic_balance(coef, load, 1.0, tol=1e-13)
    s = shooting(coef, load, 1.0, r.theta, tol=1e-12)
    assert np.abs(r.q - s.q).max() <= 1e-9 * np.abs(r.q).max()
    assert (s.max_abs_multiplier > 1 + 1e-3) == unstable


def test_exact_resonance_is_refused():
    """ω = Ω undamped and forced at Ω: μ = e^{±2πi} = 1, (I − Φ) singular."""
    coef = lambda th: (np.ones((th.size, 1, 1)), np.zeros((th.size, 1, 1)), np.ones((th.size, 1, 1)))  # noqa: E731
    with pytest.raises(ResonanceError, match="exact resonance.*singular to working precision"):
        shooting(coef, lambda th: np.cos(th)[:, None], 1.0, np.zeros(1), steps=64)


def test_galerkin_truncation_estimate_decreases():
    coef, load = mathieu(2.3, 0.5, 0.1)
    errs = [harmonic_balance(coef, load, 1.0, harmonics=H).error for H in (4, 8, 16, 32)]
    assert errs[0] > errs[1] > errs[2] > errs[3] and errs[3] < 1e-12  # geometric: 7e-2, 2e-3, 1e-7, ...
    assert galerkin_solve(coef, load, 1.0, 16).q.shape == (33, 1)
