"""Selection, classification and tracking of modes (docs/theory.md §10.3-10.4)."""

import numpy as np

from fkev_slepc.solve.modes import mac, match_modes, postprocess

from fkev_slepc.status import Status
from fkev_slepc.solve.protocol import EigenSolution


def _sol(lam, converged=True):
    lam = np.asarray(lam, dtype=complex)
    return EigenSolution(lam, np.full(lam.size, 1e-14), None, converged, "test")


def test_modes_are_positive_imaginary_parts_sorted_real_pairs_are_divergence():
    r = postprocess(_sol([-1 + 50j, -1 - 50j, 3.0, -3.0, -2 + 10j, -2 - 10j]), 2)
    np.testing.assert_allclose(r.frequency_hz, np.array([10, 50]) / (2 * np.pi))
    assert r.status == Status.DIVERGENT and r.divergent.tolist() == [3.0]
    assert r.max_real == 3.0


def test_stability_is_classified_after_convergence():
    assert postprocess(_sol([1e-3 + 10j, 1e-3 - 10j]), 1).status == Status.UNSTABLE
    assert postprocess(_sol([1e-12 + 10j, 1e-12 - 10j]), 1).status == Status.OK  # ζ = -1e-13 > -damping_tol
    assert postprocess(_sol([1 + 10j, 1 - 10j], converged=False), 1).status == Status.NOT_CONVERGED


def test_match_modes_recovers_a_permutation_of_perturbed_shapes():
    rng = np.random.default_rng(3)
    prev = rng.standard_normal((4, 30, 5)) + 1j * rng.standard_normal((4, 30, 5))
    perms = np.array([rng.permutation(5) for _ in range(4)])
    cur = np.take_along_axis(prev, perms[:, None, :], axis=2) * (2 - 1j)  # scaled, reordered
    cur += 0.05 * rng.standard_normal(cur.shape)
    got = match_modes(prev, cur)
    # cur[l][:, got[l, i]] continues prev[l][:, i]  <=>  perms[l, got[l, i]] == i
    assert np.array_equal(np.take_along_axis(perms, got, axis=1), np.broadcast_to(np.arange(5), (4, 5)))
    m = mac(prev[0], prev[0])
    np.testing.assert_allclose(np.diag(m), 1.0)
    assert np.all(m <= 1.0 + 1e-12)
