"""The moving modal basis (fkev_slepc/periodic/moving.py, docs/theory.md §18.10): the lowest r frozen
modes at each crank angle, aligned and closed around the revolution, with its frame-rate terms in
the projection; Floquet multipliers on it converge to the full model's as r grows."""

from __future__ import annotations

import numpy as np
import pytest

from fkev_slepc.model.operators import Model
from fkev_slepc.model.periodic import periodic_pieces
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.periodic.moving import BasisError, MovingBasis, moving_pool
from fkev_slepc.periodic.settings import SettingsError, resolve_reduce
from fkev_slepc.scene import load_scene, with_elements

from clitools import BW


@pytest.fixture(scope="module")
def bw4():
    return Model(with_elements(load_scene(BW), 4))


def test_the_basis_is_closed_smooth_and_orthonormal_at_its_samples(bw4):
    B = MovingBasis.frozen(bw4, 500.0, "full", 8, 64)
    W0 = B.at_angle(0.0)[0]
    assert np.abs(B.at_angle(2 * np.pi)[0] - W0).max() < 1e-12 * np.abs(W0).max()  # closed at round-off
    theta = 2 * np.pi * np.arange(64) / 64
    M = periodic_pieces(bw4, theta[[0, 17]], "full").mass
    for i, k in enumerate((0, 17)):
        W = B.at_angle(theta[k])[0]
        assert np.allclose(W, B.samples[k], atol=1e-12 * np.abs(W).max())  # the interpolant passes the samples
        assert np.allclose(W.T @ (bw4.pattern.matrix(M[i]) @ W), np.eye(8), atol=1e-10)
    # W' and W'' are the derivatives of the interpolant (central differences, h = 1e-4 rad)
    h, t = 1e-4, 1.234
    W, W1, W2 = B.at_angle(t)
    Wp, Wm = B.at_angle(t + h)[0], B.at_angle(t - h)[0]
    assert np.abs((Wp - Wm) / (2 * h) - W1).max() < 1e-6 * np.abs(W1).max()
    assert np.abs((Wp - 2 * W + Wm) / h**2 - W2).max() < 1e-4 * np.abs(W2).max()
    # neighbouring samples are aligned: the M-inner products of each sample with its predecessor are
    # near the identity (no sign flips, no reordering), and the last one with the first too (closed)
    Ms = periodic_pieces(bw4, theta, "full").mass
    for k in range(64):
        P = B.samples[k - 1].T @ (bw4.pattern.matrix(Ms[k]) @ B.samples[k])
        assert np.all(np.diag(P) > 0.9) and np.abs(P - np.diag(np.diag(P))).max() < 0.3, k


def test_a_mode_that_flips_sign_over_the_cycle_is_refused_and_the_pool_moves_the_cutoff(bw4):
    """At r = 4 one frozen mode of this linkage comes back with its sign flipped (holonomy det -1):
    no real logarithm spreads it, so the basis is refused and the pool takes r = 5."""
    with pytest.raises(BasisError, match="r = 4: a frozen mode returns with its sign flipped"):
        MovingBasis.frozen(bw4, 500.0, "full", 4, 64)
    assert moving_pool(bw4, 500.0, "full", 64)(4).r == 5
    with pytest.raises(ValueError, match=r"r: a moving basis needs 1 <= r < 36"):
        MovingBasis.frozen(bw4, 500.0, "full", 36, 64)


def test_reduce_moving_is_a_setting():
    assert resolve_reduce("moving") == "moving" and resolve_reduce("Moving:12") == "moving:12"
    with pytest.raises(ValueError, match="moving:R"):
        resolve_reduce("moving:0")
    from dataclasses import replace
    from fkev_slepc.periodic.settings import DEFAULTS

    with pytest.raises(SettingsError, match="reduce"):
        replace(DEFAULTS, reduce="moving:x")


def test_moving_basis_converges_to_the_full_models_band_at_500_rad_s(bw4):
    """Bahgat-Willmert 4 el/link, 500 rad/s, undamped full: the band (ω̄3-ω̄1)/8 with
    max|μ| - 1 = 4.744e-2 on the full model; the moving basis of r = 8, 16, 32 modes gives it within
    3.6 %, 6e-4 and 1e-6 relative, and the cutoff the run chooses within 1e-3."""
    full = floquet_multipliers(PeriodicSystem(bw4, 500.0, "full"), PeriodicSettings(reduce="none")).max_abs - 1.0
    assert full == pytest.approx(4.744e-2, rel=1e-3)
    red = floquet_multipliers(PeriodicSystem(bw4, 500.0, "full"), PeriodicSettings(reduce="moving"))
    assert red.truncation.converged and red.truncation.max_abs <= 1e-3
    assert red.max_abs - 1.0 == pytest.approx(full, rel=1e-3)
    sizes = [lv[0] for lv in red.truncation.levels]
    assert sizes[0] == 8 and sizes == sorted(sizes)
    err = [abs(lv[1] - 1.0 - full) / full for lv in red.truncation.levels]
    assert err[0] < 0.05 and all(b < a / 10 for a, b in zip(err, err[1:]))  # an order or more per doubling
    # the fixed cutoff reports its truncation against 2R
    r16 = floquet_multipliers(PeriodicSystem(bw4, 500.0, "full"), PeriodicSettings(reduce="moving:16"))
    assert r16.basis == 16 and abs(r16.max_abs - 1.0 - full) / full < 1e-3
    assert r16.truncation.max_abs == pytest.approx(abs(r16.max_abs - red.max_abs) / red.max_abs, rel=0.2)


def test_the_sample_angles_double_until_the_subspace_is_resolved(bw4):
    """r = 16 at 32 angles: the interpolated basis leaves the frozen subspace by 3.4e-2 (M-norm) at the
    midpoints, so the angles double until it is within SUBSPACE_TOL; r = 8 needs no doubling."""
    from fkev_slepc.periodic.moving import SUBSPACE_TOL

    B = MovingBasis.frozen(bw4, 500.0, "full", 16, 32)
    assert B.samples.shape[0] >= 128 and B.subspace_error <= SUBSPACE_TOL
    B8 = MovingBasis.frozen(bw4, 500.0, "full", 8, 64)
    assert B8.samples.shape[0] == 64 and B8.subspace_error <= SUBSPACE_TOL
