"""The first-order band atlas (docs/theory.md §18.9, fkev_slepc/periodic/atlas.py) against the
classical closed forms and against monodromies of the same equations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from fkev_slepc.periodic.atlas import band_atlas, fourier_coefficients


def _growth(stiffness, r: int) -> float:
    """max ln|μ|/2π of ẍ + K(t) x = 0 over t in [0, 2π] (Ω = 1), by a tight ODE integration."""
    def f(t, y):
        return np.concatenate([y[r:], -stiffness(t) @ y[:r]])

    phi = np.column_stack([solve_ivp(f, (0.0, 2 * np.pi), e, rtol=1e-11, atol=1e-13).y[:, -1] for e in np.eye(2 * r)])
    return float(np.log(np.abs(np.linalg.eigvals(phi)).max()) / (2 * np.pi))


def test_fourier_coefficients_of_a_cos_and_a_sin():
    t = 2 * np.pi * np.arange(16) / 16
    b = (3.0 * np.cos(t) + 2.0 * np.sin(2 * t))[:, None, None]
    B = fourier_coefficients(b, 3)
    assert B[:, 0, 0] == pytest.approx([1.5, -1.0j, 0.0], abs=1e-14)
    with pytest.raises(ValueError, match="orders: 8 harmonics need more than 16 samples"):
        fourier_coefficients(b, 8)


@pytest.mark.parametrize("eps", [1e-3, 1e-2])
def test_mathieu_first_tongue_is_the_first_order_closed_form(eps):
    """x'' + (δ + ε cos t) x = 0: the first tongue δ = 1/4 ± ε/2 + O(ε²), growth ε/2 at δ = 1/4."""
    B = np.array([[[eps / 2]]], dtype=complex)

    def edge(side):  # the δ at which Ω = 1 is the atlas band's lower (side -1) or upper (+1) edge
        def f(d):
            [b] = band_atlas([np.sqrt(d)], B, 1)
            return (b.lower if side < 0 else b.upper) - 1.0
        return brentq(f, 0.2, 0.3, xtol=1e-15)

    lo, hi = edge(+1), edge(-1)
    assert hi - lo == pytest.approx(eps, rel=2 * eps)  # the width ε of the closed form, to O(ε²)
    assert 0.5 * (lo + hi) == pytest.approx(0.25, abs=eps**2)
    [b] = band_atlas([0.5], B, 1)
    assert (b.kind, b.label, b.order) == ("principal", "2ω̄1/1", 1)
    assert b.centre == 1.0 and b.growth_rate == pytest.approx(eps / 2, rel=1e-14)
    exact = _growth(lambda t: np.array([[0.25 + eps * np.cos(t)]]), 1)
    assert exact == pytest.approx(b.growth_rate, rel=5 * eps)
    # outside the tongue (by twice its half-width in δ) the monodromy is stable
    assert _growth(lambda t: np.array([[0.25 + 2 * eps + eps * np.cos(t)]]), 1) < 1e-7


def test_two_modes_sum_band_and_no_difference_band_for_a_symmetric_coupling():
    """ω = 0.3, 0.7 with a symmetric coupling b cos t: a sum band at ω₁ + ω₂ = 1 (Ω = 1), growth
    √Λ/(2√(ω₁ω₂)), and no first-order difference band (Λ = -|B|² < 0)."""
    w, b = np.array([0.3, 0.7]), 4e-3
    B = np.zeros((1, 2, 2), complex)
    B[0, 0, 1] = B[0, 1, 0] = b / 2
    bands = band_atlas(w, B)
    assert [(x.kind, x.label) for x in bands] == [("sum", "(ω̄1+ω̄2)/1")]
    [s] = bands
    assert s.centre == pytest.approx(1.0, rel=1e-15)
    assert s.growth_rate == pytest.approx((b / 2) / (2 * np.sqrt(0.21)), rel=1e-14)
    K = lambda t: np.diag(w**2) + b * np.cos(t) * np.array([[0.0, 1.0], [1.0, 0.0]])  # noqa: E731
    assert _growth(K, 2) == pytest.approx(s.growth_rate, rel=2e-2)
    # an antisymmetric (circulatory) coupling opens the difference band (ω₂ - ω₁ = 0.4 at Ω = 0.4) instead
    B[0, 1, 0] = -b / 2
    assert [x.kind for x in band_atlas(w, B)] == ["difference"]
