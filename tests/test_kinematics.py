"""Rigid-body kinematics and kinetostatics (docs/theory.md §3, §7) against first principles."""

import numpy as np
import pytest
from balance import newton_euler_residual, power_residual
from builders import bahgat_willmert, six_bar, turcic_midha
from linkage_cases import linkage_mechanisms

from fkev_slepc.model.kinematics import point_local, solve_kinematics
from fkev_slepc.model.kinetostatics import solve_loads
from fkev_slepc.model.mechanism import build_mechanism

THETA = np.radians(np.arange(0.0, 360.0, 7.5))


BUILDERS = {"bahgat_willmert": bahgat_willmert, "turcic_midha": turcic_midha, "six_bar": six_bar}
# the four-bars and six-bar of tests/builders.py, and the slider-cranks and Stephenson six-bar of
# runs/ (tests/linkage_cases.py): every kinematics and balance test runs on all of them
MECHANISMS = {**{name: (lambda b=b: build_mechanism(b())) for name, b in BUILDERS.items()}, **linkage_mechanisms()}


@pytest.fixture(params=list(MECHANISMS))
def mech(request):
    return MECHANISMS[request.param]()


def test_loop_closure(mech):
    """Every link point sits on its joint, a ground pivot where it is, a slider on its guide;
    to 1e-12 of the longest link."""
    kin = solve_kinematics(mech, THETA)
    assert kin.ok.all()
    worst = 0.0
    for jj, here in enumerate(mech.attach):
        for lk, k in here:
            p = point_local(kin, [lk], mech.link_points[lk, k][None])[0][:, 0]
            worst = max(worst, np.abs(p - kin.pos[:, jj]).max())
        joint = mech.scene.joints[jj]
        if not np.isnan(mech.joint_guide[jj, 0]):  # a slider: on its guide line
            n = np.array([-mech.joint_guide[jj, 1], mech.joint_guide[jj, 0]])
            worst = max(worst, np.abs((kin.pos[:, jj] - mech.joint_guide_point[jj]) @ n).max())
        elif joint.ground is not None:  # a ground pivot: where the scene puts it
            worst = max(worst, np.abs(kin.pos[:, jj] - np.array(joint.ground)).max())
    assert worst < 1e-12 * mech.length.max()


def test_thesis_assembly_branch():
    """B lies to the left of the ray A->O2 (docs/theory.md §3, RBK: γ ≥ 0): above ground at θ = 0."""
    mech = build_mechanism(bahgat_willmert())
    kin = solve_kinematics(mech, [0.0])
    assert kin.pos[0, 2, 1] > 0


def test_derivatives_equal_finite_differences(mech):
    h = 1e-5
    k0, kp, km = (solve_kinematics(mech, THETA + d) for d in (0.0, h, -h))
    unwrap = lambda a: np.angle(np.exp(1j * a))  # noqa: E731
    np.testing.assert_allclose(unwrap(kp.phi - km.phi) / (2 * h), k0.dphi, atol=1e-7)
    np.testing.assert_allclose(unwrap(kp.phi - 2 * k0.phi + km.phi) / h**2, k0.ddphi, atol=2e-4 * np.abs(k0.ddphi).max())
    for x, dx, ddx, xp, xm in ((k0.pos, k0.dpos, k0.ddpos, kp.pos, km.pos),
                               (k0.root, k0.droot, k0.ddroot, kp.root, km.root)):
        np.testing.assert_allclose((xp - xm) / (2 * h), dx, atol=1e-9)
        np.testing.assert_allclose((xp - 2 * x + xm) / h**2, ddx, atol=1e-5 * max(1.0, np.abs(ddx).max()))


def test_impossible_angles_are_flagged():
    # crank longer than allowed by the other links: cannot close near θ = 180°
    from builders import STEEL, four_bar

    mech = build_mechanism(four_bar((0.3, 0.2, 0.2), 0.254, STEEL))
    kin = solve_kinematics(mech, np.radians([0.0, 180.0]))
    assert kin.ok.tolist() == [True, False]


@pytest.mark.parametrize("omega,alpha", [(500.0, 0.0), (300.0, 4e4), (0.0, -2e5)])
def test_newton_euler_of_every_link(mech, omega, alpha):
    """ΣF = m a_G and ΣM = J θ̈ for every link (lumped masses on their carrying link), from the
    elements and particles one by one (tests/balance.py)."""
    assert newton_euler_residual(mech, THETA, omega, alpha) <= 1e-9


def test_driving_power_equals_rate_of_kinetic_energy(mech):
    """T·Ω = dE_k/dt at constant crank speed (no gravity, no dissipation)."""
    power, dE = power_residual(mech, THETA)
    np.testing.assert_allclose(power, dE, rtol=1e-6, atol=1e-6 * np.abs(power).max())


def test_axial_force_balances_at_both_ends(mech):
    """N(0) from integrating the tip load along the link equals the root pin force along the link."""
    from fkev_slepc.model.kinetostatics import axial_polynomials

    kin = solve_kinematics(mech, THETA[:5])
    loads = solve_loads(mech, kin)
    for ang in range(5):
        c_w2, _ = axial_polynomials(mech, kin, loads, ang)
        for lk in range(mech.n_link):
            first = np.flatnonzero(mech.elem_link == lk)[0]
            n_root = c_w2[first, 0]  # F(ξ=0) of the root element
            e = np.array([np.cos(kin.phi[ang, lk]), np.sin(kin.phi[ang, lk])])
            f_root = loads.end_force[0][ang, lk, 0]
            assert abs(n_root + f_root @ e) <= 1e-9 * (abs(n_root) + 1.0)
