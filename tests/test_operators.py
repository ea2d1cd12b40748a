"""Global operators: structure of M, C, K; cases; the per-angle split (docs/theory.md §6, §9-11)."""

import numpy as np
import pytest
import scipy.linalg as la
from builders import bahgat_willmert, frequencies, turcic_midha

from fkev_slepc.model import elements as el
from fkev_slepc.scene.cases import CASE_NAMES, CASES, case_name
from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.model.kinetostatics import axial_polynomials, solve_loads
from fkev_slepc.model.operators import Model
from fkev_slepc.model.qep import GENERAL, GYROSCOPIC, LINEAR, LINEAR_SYMMETRIC


@pytest.fixture(scope="module")
def bw():
    return Model(bahgat_willmert(elements=(2, 3, 3)))


def test_case_aliases_follow_table_3_1():
    assert [case_name(i) for i in range(6)] == list(CASE_NAMES)
    assert case_name(3) == "no_tangential" and case_name("4") == "no_normal"
    assert not CASES["no_tangential"].tangential and CASES["no_tangential"].normal


def test_matrix_structure(bw):
    p = bw.pieces(np.radians(37.0))
    q = bw.qep(p, 800.0, "full", accel=3e4)
    M, C, K = (A.toarray() for A in (q.mass, q.damping, q.stiffness))
    assert np.allclose(M, M.T, rtol=0, atol=1e-15 * abs(M).max()) and la.eigvalsh(M).min() > 0
    assert np.allclose(C, -C.T, rtol=0, atol=1e-15 * abs(C).max())
    tang = (800.0**2 * p.tangential[0] + 3e4 * p.tangential[1])
    T = bw.pattern.matrix(tang).toarray()
    np.testing.assert_allclose(K - K.T, T - T.T, atol=1e-12 * abs(K).max())
    assert np.abs(T - T.T).max() > 0
    assert q.kind == GENERAL
    assert bw.qep(p, 800.0, "no_tangential").kind == GYROSCOPIC
    assert bw.qep(p, 800.0, "no_coriolis").kind == LINEAR
    assert bw.qep(p, 800.0, "structure").kind == LINEAR_SYMMETRIC
    assert bw.qep(p, 0.0, "full", accel=0.0).kind == LINEAR_SYMMETRIC


def test_pattern_matrix_equals_scipy_checked_constructor(bw):
    """Pattern.matrix skips scipy's per-call validation: it must give what the checked
    constructor gives (a scipy storing CSR differently would fail here), and reject bad data."""
    import scipy.sparse as sp

    pat = bw.pattern
    data = np.random.default_rng(3).normal(size=pat.nnz)
    A = pat.matrix(data)
    B = sp.csr_matrix((data, pat.indices, pat.indptr), shape=(pat.n, pat.n))
    assert type(A) is type(B) and A.shape == B.shape and A.nnz == B.nnz
    x = np.random.default_rng(4).normal(size=pat.n)
    np.testing.assert_array_equal(A @ x, B @ x)
    np.testing.assert_array_equal(A.toarray(), B.toarray())
    np.testing.assert_array_equal((A.T @ x), (B.T @ x))
    np.testing.assert_array_equal(abs(A).toarray(), abs(B).toarray())
    np.testing.assert_array_equal((A + A).toarray(), 2 * B.toarray())
    assert pat.matrix(2 * data).data[0] == 2 * data[0] and A.data[0] == data[0]  # no shared data
    with pytest.raises(ValueError, match="entries"):
        pat.matrix(data[:-1])


def test_pieces_equal_direct_assembly(bw):
    """combine(pieces, Ω, α) equals assembling Σ Tᵀ(k_s + 2θ̇… ) T with the actual link rates."""
    theta, omega, alpha = np.radians(123.0), 650.0, -2.5e4
    mech = bw.mechanism
    kin = solve_kinematics(mech, [theta])
    lk, l = mech.elem_link, mech.elem_length
    w = omega * kin.dphi[0, lk][:, None, None]
    wdot = (omega**2 * kin.ddphi[0, lk] + alpha * kin.dphi[0, lk])[:, None, None]
    loads = solve_loads(mech, kin)
    c2, c1 = axial_polynomials(mech, kin, loads, 0)
    m = el.mass_local(mech.elem_rho_a, l)
    ma = el.skew_mass_local(mech.elem_rho_a, l)
    ke = el.structural_local(mech.elem_ea, mech.elem_ei, l) + wdot * ma - w**2 * m
    ke += el.axial_force_local(omega**2 * c2 + alpha * c1, l)
    T = el.rotation(kin.phi[0, lk])
    pat = bw.pattern
    K_direct = pat.matrix(pat.scatter(el.to_global(ke, T))).toarray()
    C_direct = pat.matrix(pat.scatter(el.to_global(2 * w * ma, T))).toarray()
    q = bw.qep(bw.pieces(theta), omega, "full", accel=alpha)
    np.testing.assert_allclose(q.stiffness.toarray(), K_direct, rtol=1e-13, atol=1e-12 * abs(K_direct).max())
    np.testing.assert_allclose(q.damping.toarray(), C_direct, rtol=1e-13, atol=1e-13 * abs(C_direct).max())


def test_all_cases_equal_structure_at_rest(bw):
    ref = frequencies(bw, 45.0, 0.0, "structure", 6).frequency_hz
    for case in CASE_NAMES:
        np.testing.assert_allclose(frequencies(bw, 45.0, 0.0, case, 6).frequency_hz, ref, rtol=1e-12)


def test_structure_independent_of_speed(bw):
    a = frequencies(bw, 200.0, 0.0, "structure", 6).frequency_hz
    b = frequencies(bw, 200.0, 1000.0, "structure", 6).frequency_hz
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("case", ["full", "no_normal", "no_pseudo_normal", "no_tangential"])
def test_reversing_crank_direction_keeps_frequencies(bw, case):
    """Ω → -Ω flips C only: λ → -λ̄ … frequencies unchanged, real parts change sign (§10.3)."""
    a = frequencies(bw, 75.0, 900.0, case, 6)
    b = frequencies(bw, 75.0, -900.0, case, 6)
    np.testing.assert_allclose(a.frequency_hz, b.frequency_hz, rtol=1e-10)
    np.testing.assert_allclose(a.eigenvalue.real, -b.eigenvalue.real, atol=1e-8 * np.abs(a.eigenvalue).max())


def test_real_parts_sum_to_zero_with_coriolis_and_tangential(bw):
    """trace(M⁻¹C) = 0, so Re λ of all 2n eigenvalues sum to zero (§10.3)."""
    from fkev_slepc.solve.dense import DenseEngine

    q = bw.qep(bw.pieces(np.radians(10.0)), 1000.0, "full")
    lam = DenseEngine().solve(q).eigenvalues
    assert abs(lam.real.sum()) <= 1e-9 * np.abs(lam).max()


def test_bahgat_willmert_fundamental_at_10_degrees():
    """docs/theory.md §12: ω₁⁰ = 1778.5 rad/s (283.05 Hz) at θ = 10°, so α = Ω/ω₁⁰ = 0.562 at 1000 rad/s."""
    r = frequencies(Model(bahgat_willmert()), 10.0, 0.0, "structure", 4)
    assert abs(2 * np.pi * r.frequency_hz[0] - 1778.5) < 0.1
    assert round(1000.0 / (2 * np.pi * r.frequency_hz[0]), 3) == 0.562


def test_turcic_midha_divergence_is_flagged_not_reported_as_frequency():
    """The light Turcic–Midha linkage buckles a link at high speed: real pairs, status DIVERGENT."""
    from fkev_slepc.status import Status

    m = Model(turcic_midha(3))
    found = False
    for theta in range(0, 360, 30):
        r = frequencies(m, theta, 3000.0, "full", 3)
        if r.status == Status.DIVERGENT:
            found = True
            assert r.divergent.size and np.all(r.divergent > 0)
            assert np.all(np.isfinite(r.frequency_hz)) and np.all(r.frequency_hz > 0)
    assert found


def test_two_loop_linkage_solves_like_any_other():
    """A Watt-type six-bar (two loops, compound joint) goes through the same engine: the
    structure case is symmetric-definite, the full case has Σ Re λ = 0, and refining the mesh
    converges the fundamental."""
    from builders import six_bar

    from fkev_slepc.solve.dense import DenseEngine

    f = [frequencies(Model(six_bar(n)), 40.0, 400.0, "full", 3).frequency_hz for n in (2, 4, 8)]
    assert abs(f[2][0] / f[1][0] - 1) < 0.1 * abs(f[1][0] / f[0][0] - 1) + 1e-6
    m = Model(six_bar(2))
    q = m.qep(m.pieces(np.radians(40.0)), 400.0, "full")
    lam = DenseEngine().solve(q).eigenvalues
    assert abs(lam.real.sum()) <= 1e-9 * np.abs(lam).max()
    assert frequencies(m, 40.0, 400.0, "structure", 3).status.name == "OK"
