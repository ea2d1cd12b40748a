"""Rotating cantilever (one driven link, clamped at the hub): in-plane (chordwise) frequencies.

With λ = Ω·sqrt(ρAL⁴/EI), the in-plane frequencies of a slender blade are sqrt(ω_flap² - λ²),
where ω_flap are the published flapwise values (Wright et al. 1982; Hoa 1979): the in-plane
motion sees the same centrifugal stiffening minus the normal (centripetal) softening term.
"""

import numpy as np
import pytest
from builders import cantilever, rect_strip

from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.model.operators import Model

FLAP = {0.0: np.array([3.5160, 22.0345, 61.6972]), 12.0: np.array([13.1702, 37.6031, 79.6145])}


def _nondim(L, width, lam, case, elements=16):
    props = rect_strip(width, 0.002)
    scale = np.sqrt(props["density"] * props["area"] * L**4 / (props["youngs_modulus"] * props["second_moment"]))
    model = Model(cantilever(L, props, elements, cases=(case,)))
    q = model.qep(model.pieces(0.0), lam / scale, case)
    r = postprocess(DenseEngine().solve(q, 3), 3)
    return r.frequency_hz * 2 * np.pi * scale


@pytest.mark.parametrize("lam", [0.0, 12.0])
def test_slender_blade_matches_published_values(lam):
    L, width = 1.0, 0.005  # r = width/sqrt(12): L/r = 693
    expected = np.sqrt(FLAP[lam] ** 2 - lam**2)
    got = _nondim(L, width, lam, "full")
    np.testing.assert_allclose(got, expected, rtol=1e-3)


def test_coriolis_coupling_lowers_stubby_blade_and_vanishes_when_slender():
    """The Coriolis coupling of bending with axial motion lowers the in-plane fundamental by a
    fraction that falls as (r/L)², i.e. as the ratio of bending to axial stiffness."""
    lam = 12.0
    slender = np.array([50.0, 100.0, 200.0, 400.0])
    gaps = []
    for s in slender:
        width = np.sqrt(12.0) / s  # L = 1 m, r = width/sqrt(12)
        full = _nondim(1.0, width, lam, "full")
        no_cor = _nondim(1.0, width, lam, "no_coriolis")
        gaps.append((no_cor[0] - full[0]) / no_cor[0])
    gaps = np.array(gaps)
    assert gaps[0] > 0.02  # visible for L/r = 50 (about 4 %)
    assert np.all(np.diff(gaps) < 0)
    slope = np.polyfit(np.log(slender), np.log(gaps), 1)[0]
    assert -2.2 < slope < -1.8, (gaps, slope)
