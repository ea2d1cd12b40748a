"""Element matrices and assembly against closed-form beam theory (docs/theory.md §5, §9)."""

import numpy as np
import pytest
import scipy.linalg as la
from numpy.polynomial.legendre import leggauss

from fkev_slepc.model import elements as el
from fkev_slepc.model.assembly import Pattern

E, RHO, A, I, L = 2.07e11, 7760.0, 1.61e-4, 8.66e-9, 0.5
OMEGA_REF = np.sqrt(E * I / (RHO * A * L**4))  # ω = (βL)²·OMEGA_REF
BETA_CLAMPED_FREE = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613])
BETA_PINNED = np.pi * np.arange(1, 4)


def _shape(xi, l):
    return np.array([
        [1 - xi, 0, 0, xi, 0, 0],
        [0, 1 - 3 * xi**2 + 2 * xi**3, l * xi * (1 - xi) ** 2, 0, 3 * xi**2 - 2 * xi**3, -l * xi**2 * (1 - xi)],
    ])  # fmt: skip


def _dshape_v(xi, l):
    return np.array([0, -6 * xi + 6 * xi**2, l * (1 - 4 * xi + 3 * xi**2), 0, 6 * xi - 6 * xi**2, l * (3 * xi**2 - 2 * xi)])


def test_local_matrices_equal_quadrature_of_shape_functions():
    """m = ρAl∫NᵀN, m_a = ρAl∫NᵀSN, k_g = (1/l)∫F N'ᵀN' reproduced by Gauss quadrature."""
    x, w = leggauss(8)
    x, w = (x + 1) / 2, w / 2
    l, rho_a = np.array([0.37]), np.array([3.1])
    c = np.array([[120.0, -45.0, 30.0]])
    S = np.array([[0, -1], [1, 0]])
    m = sum(wi * _shape(xi, l[0]).T @ _shape(xi, l[0]) for xi, wi in zip(x, w)) * rho_a[0] * l[0]
    ma = sum(wi * _shape(xi, l[0]).T @ S @ _shape(xi, l[0]) for xi, wi in zip(x, w)) * rho_a[0] * l[0]
    F = lambda xi: c[0, 0] + c[0, 1] * xi + c[0, 2] * xi**2  # noqa: E731
    kg = sum(wi * F(xi) * np.outer(_dshape_v(xi, l[0]), _dshape_v(xi, l[0])) for xi, wi in zip(x, w)) / l[0]
    np.testing.assert_allclose(el.mass_local(rho_a, l)[0], m, atol=1e-14)
    np.testing.assert_allclose(el.skew_mass_local(rho_a, l)[0], ma, atol=1e-14)
    np.testing.assert_allclose(el.axial_force_local(c, l)[0], kg, atol=1e-12)


def test_element_symmetries_and_rigid_modes():
    l = np.array([0.2, 0.3])
    m = el.mass_local(np.array([2.0, 3.0]), l)
    ks = el.structural_local(np.array([1e6, 2e6]), np.array([10.0, 20.0]), l)
    ma = el.skew_mass_local(np.array([2.0, 3.0]), l)
    assert np.allclose(m, np.swapaxes(m, 1, 2)) and np.all(la.eigvalsh(m[0]) > 0)
    assert np.allclose(ks, np.swapaxes(ks, 1, 2))
    assert np.allclose(ma, -np.swapaxes(ma, 1, 2))
    # three rigid-body motions of a free element: two translations and a rotation (v = φ·x)
    rigid = np.array([[1, 0, 0, 1, 0, 0], [0, 1, 0, 0, 1, 0], [0, 0, 1, 0, l[0], 1]], float).T
    np.testing.assert_allclose(ks[0] @ rigid, 0, atol=1e-8)
    T = el.rotation(np.array([0.7, -2.0]))
    np.testing.assert_allclose(T @ np.swapaxes(T, 1, 2), np.broadcast_to(np.eye(6), T.shape), atol=1e-15)


def _beam(n, bc, axial=0.0):
    """Straight beam of n elements along x; bc 'clamped-free' or 'pinned'; constant axial force."""
    l = np.full(n, L / n)
    raw = np.arange(3 * (n + 1)).reshape(n + 1, 3)
    fixed = [0, 1, 2] if bc == "clamped-free" else [0, 1, 3 * n + 1]
    keep = np.setdiff1d(np.arange(raw.size), fixed)
    free = -np.ones(raw.size, dtype=int)
    free[keep] = np.arange(keep.size)
    dofs = np.concatenate([free[raw[:-1]], free[raw[1:]]], axis=1)
    pat = Pattern(dofs, keep.size)
    M = pat.matrix(pat.scatter(el.mass_local(np.full(n, RHO * A), l))).toarray()
    K = pat.matrix(pat.scatter(el.structural_local(np.full(n, E * A), np.full(n, E * I), l)))
    if axial:
        c = np.zeros((n, 3))
        c[:, 0] = axial
        K = K + pat.matrix(pat.scatter(el.axial_force_local(c, l)))
    w2 = la.eigh(K.toarray(), M, eigvals_only=True)
    return np.sqrt(w2)


def _bending(omegas, n_expected=3):
    """Bending frequencies (the axial ones of a long slender beam are far above)."""
    return np.sort(omegas)[:n_expected]


@pytest.mark.parametrize("bc,beta", [("clamped-free", BETA_CLAMPED_FREE), ("pinned", BETA_PINNED)])
def test_beam_frequencies_closed_form_and_convergence_rate(bc, beta):
    exact = beta**2 * OMEGA_REF
    w16 = _bending(_beam(16, bc))
    assert np.all(np.abs(w16 / exact - 1) <= 1e-4), w16 / exact - 1
    ns = np.array([4, 8, 16])
    errs = np.array([abs(_bending(_beam(n, bc))[2] / exact[2] - 1) for n in ns])
    slope = np.polyfit(np.log(1 / ns), np.log(errs), 1)[0]
    # cubic Hermite elements: eigenvalue error O(h^4)
    assert 3.6 < slope < 4.4, (errs, slope)


def test_pinned_beam_with_tension_follows_euler_load_formula():
    P_cr = np.pi**2 * E * I / L**2
    w0 = _bending(_beam(32, "pinned"))[0]
    for ratio in (0.3, 1.0, 2.5):
        w = _bending(_beam(32, "pinned", axial=ratio * P_cr))[0]
        assert abs(w**2 / (w0**2 * (1 + ratio)) - 1) < 1e-3


# ----------------------------------------------------------------- the cubic-axial element
from fkev_slepc.model.element_types import ElementType, element_type  # noqa: E402

CUBIC = element_type("cubic")


def test_generic_quadrature_reproduces_the_thesis_closed_forms():
    """The quadrature path that builds the cubic element, run with the thesis's linear axial
    shape functions (6 DOFs), gives the thesis's closed-form matrices; k_s = Bᵀ diag(w) B too."""
    generic = ElementType("generic", 6)
    thesis = element_type("thesis")
    l, rho_a, ea, ei = np.array([0.3, 0.07]), np.array([2.0, 5.0]), np.array([3e7, 1e6]), np.array([40.0, 7.0])
    c = np.array([[10.0, -3.0, 2.0], [-4.0, 1.0, 0.5]])
    for a, b in ((generic.mass(rho_a, l), thesis.mass(rho_a, l)),
                 (generic.skew_mass(rho_a, l), thesis.skew_mass(rho_a, l)),
                 (generic.structural(ea, ei, l), thesis.structural(ea, ei, l)),
                 (generic.axial_force(c, l), thesis.axial_force(c, l))):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
    B, w = thesis.strains(ea, ei, l)
    np.testing.assert_allclose(np.einsum("esi,es,esj->eij", B, w, B), thesis.structural(ea, ei, l), rtol=1e-12)


def test_cubic_element_structure():
    """m SPD, m_a skew, k_s symmetric PSD with exactly the 3 rigid-body modes in its null space,
    k_g symmetric and blind to axial DOFs; all 8×8."""
    l, rho_a = np.array([0.2, 0.45]), np.array([2.0, 3.0])
    m, ma = CUBIC.mass(rho_a, l), CUBIC.skew_mass(rho_a, l)
    ks = CUBIC.structural(np.array([1e6, 2e6]), np.array([10.0, 20.0]), l)
    kg = CUBIC.axial_force(np.array([[5.0, 1.0, -2.0], [3.0, 0.0, 0.0]]), l)
    assert m.shape == ks.shape == ma.shape == kg.shape == (2, 8, 8)
    assert np.allclose(m, np.swapaxes(m, 1, 2)) and np.all(la.eigvalsh(m[0]) > 0) and np.all(la.eigvalsh(m[1]) > 0)
    assert np.allclose(ma, -np.swapaxes(ma, 1, 2))
    assert np.allclose(ks, np.swapaxes(ks, 1, 2)) and np.allclose(kg, np.swapaxes(kg, 1, 2))
    ev = la.eigvalsh(ks[0])
    assert np.sum(np.abs(ev) < 1e-9 * ev.max()) == 3 and ev.min() > -1e-9 * ev.max()
    rigid = np.array([[1, 0, 0, 1, 0, 0, 0, 0], [0, 1, 0, 0, 1, 0, 0, 0], [0, 0, 1, 0, l[0], 1, 0, 0]], float).T
    np.testing.assert_allclose(ks[0] @ rigid, 0, atol=1e-8)
    assert np.all(kg[:, [0, 3, 6, 7], :] == 0)
    T = el.rotation(np.array([0.7, -2.0]), 8)
    np.testing.assert_allclose(T @ np.swapaxes(T, 1, 2), np.broadcast_to(np.eye(8), T.shape), atol=1e-15)


def _bar(n, etype):
    """Axial frequencies of a clamped-free bar of n elements (u DOFs and bubbles only)."""
    l = np.full(n, L / n)
    m, k = etype.mass(np.full(n, RHO * A), l), etype.structural(np.full(n, E * A), np.full(n, E * I), l)
    ax = [0, 3] + list(range(6, etype.n_dof))
    nb = etype.n_dof - 6
    dofs = np.stack([np.arange(n), np.arange(1, n + 1)], axis=1)
    dofs = np.concatenate([dofs, n + 1 + np.arange(n * nb).reshape(n, nb)], axis=1) - 1  # node 0 clamped
    pat = Pattern(dofs, n + n * nb)
    sub = np.ix_(range(n), ax, ax)
    M, K = (pat.matrix(pat.scatter(x[sub])).toarray() for x in (m, k))
    return np.sqrt(la.eigh(K, M, eigvals_only=True)[:3])


def test_axial_frequencies_converge_like_h2_thesis_and_h6_cubic():
    exact = (2 * np.arange(1, 4) - 1) * np.pi / 2 * np.sqrt(E / RHO) / L
    for etype, lo, hi, ns in ((element_type("thesis"), 1.8, 2.2, (8, 16, 32)), (CUBIC, 5.5, 6.5, (2, 4, 8))):
        errs = [abs(_bar(n, etype)[2] / exact[2] - 1) for n in ns]
        slope = np.polyfit(np.log(1 / np.array(ns)), np.log(errs), 1)[0]
        assert lo < slope < hi, (etype.name, errs, slope)


def test_cubic_element_bending_keeps_closed_forms_and_h4():
    """Bending of the cubic element is the thesis's Hermite bending: the axial bubbles decouple
    from a straight beam's transverse modes, so its bending frequencies are identical."""
    for n in (1, 16):
        l = np.full(n, L / n)
        mc, kc = CUBIC.mass(np.full(n, RHO * A), l), CUBIC.structural(np.full(n, E * A), np.full(n, E * I), l)
        np.testing.assert_allclose(mc[:, :6, :6], el.mass_local(np.full(n, RHO * A), l), rtol=1e-12, atol=1e-18)
        np.testing.assert_allclose(kc[:, :6, :6], el.structural_local(np.full(n, E * A), np.full(n, E * I), l),
                                   rtol=1e-12, atol=1e-6)
        assert np.all(mc[:, [1, 2, 4, 5], 6:] == 0) and np.all(kc[:, [1, 2, 4, 5], 6:] == 0)
