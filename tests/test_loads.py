"""Rigid-body inertia loads (model/loads.py) against closed forms: the consistent centrifugal and
tangential loads of a lone rotating crank, and Newton-Euler of every link of moving linkages
(the consistent loads of a link resultant to -m a_G and, about G, to -J_G φ̈)."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from builders import STEEL, cantilever, six_bar, turcic_midha

from fkev_slepc.model.kinematics import point_local
from fkev_slepc.model.loads import PARTS, element_loads
from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene

RUNS = Path(__file__).resolve().parents[1] / "runs"
THETA = np.radians([0.0, 50.0, 200.0, 333.0])


def _linear_load(q1, q2, h):
    """Consistent nodal loads of a linear line load q1 -> q2 on an element of length h: axial
    (u1, u2) and transverse (v1, m1, v2, m2) (the textbook formulas, not the mass matrix)."""
    axial = h / 6 * np.array([2 * q1 + q2, q1 + 2 * q2])
    trans = np.array([h * (7 * q1 + 3 * q2) / 20, h * h * (3 * q1 + 2 * q2) / 60,
                      h * (3 * q1 + 7 * q2) / 20, -h * h * (2 * q1 + 3 * q2) / 60])
    return axial, trans


def test_lone_crank_centrifugal_and_tangential_loads_are_the_consistent_closed_form():
    """A uniform crank turning about its clamped root: per Ω² the load is the centrifugal
    line load ρAΩ²x along the link, per α the tangential line load -ρAαx across it; their
    consistent nodal vectors (ρA∫Nᵀx dx) rotated by θ into the global DOFs."""
    L, n = 0.4, 5
    model = Model(cantilever(L, STEEL, elements=n))
    mech = model.mechanism
    rho_a, h = STEEL["density"] * STEEL["area"], L / n
    loads = model.load_pieces(THETA)
    assert loads.per_w2.shape == (THETA.size, model.n_free) and loads.ok.all()
    for i, th in enumerate(THETA):
        c, s = np.cos(th), np.sin(th)
        want = {"per_w2": np.zeros((n + 1, 3)), "per_accel": np.zeros((n + 1, 3))}
        for e in range(n):
            x1, x2 = e * h, (e + 1) * h
            ax, _ = _linear_load(rho_a * x1, rho_a * x2, h)  # outward, per Ω²
            _, tr = _linear_load(-rho_a * x1, -rho_a * x2, h)  # against the tangential acceleration, per α
            for k, node in enumerate((e, e + 1)):
                want["per_w2"][node, :2] += ax[k] * np.array([c, s])
                want["per_accel"][node, :2] += tr[2 * k] * np.array([-s, c])
                want["per_accel"][node, 2] += tr[2 * k + 1]
        order = np.argsort(mech.node_s)  # nodes by station from the hub
        for part in want:
            got = np.zeros((n + 1, 3))
            dofs = mech.node_dofs[order]
            got[dofs >= 0] = getattr(loads, part)[i][dofs[dofs >= 0]]
            np.testing.assert_allclose(got[1:], want[part][1:], rtol=1e-12, atol=1e-12 * rho_a * L**2)
    # total centrifugal force on the free nodes + the root's share = ρAΩ²L²/2 = m a_G
    total = loads.per_w2[0].reshape(-1, 3)[:, 0].sum()
    root_share = _linear_load(0.0, rho_a * h, h)[0][0]
    assert abs(total + root_share - rho_a * L**2 / 2) < 1e-12 * rho_a * L**2


def _scenes():
    slider = load_scene(RUNS / "slider-crank.toml")
    return {"turcic-midha-masses": turcic_midha(3), "six-bar": six_bar(2),
            "slider-crank-cubic": replace(slider, analysis=replace(slider.analysis, element="cubic"))}


@pytest.mark.parametrize("name", list(_scenes()))
def test_loads_of_every_link_balance_its_rigid_body_inertia(name):
    """For every link: Σ of the consistent element loads and the particle loads = -m a_G, and
    their moment about G (nodal forces × arms + nodal moments) = -J_G φ̈, per Ω², per α; gravity
    along -Y gives (0, -m g), along -X (-m g, 0), and no moment. m, G, J_G are the mechanism's rigid-body data (every element a
    slender rod, every particle a point mass), computed independently of the mass matrices."""
    model = Model(_scenes()[name])
    mech = model.mechanism
    state = model.angle_state(THETA)
    loads = element_loads(mech, model.stacks, state)
    kin = state.kinematics
    pos = point_local(kin, mech.node_link, mech.node_local)[0]
    axis = mech.node_axis
    normal = np.stack([-axis[:, 1], axis[:, 0]], -1)

    def to_global(f, nodes):  # (.., 2) node-frame translations -> global
        return f[..., :1] * axis[nodes] + f[..., 1:2] * normal[nodes]

    G = point_local(kin, np.arange(mech.n_link), mech.body_centroid)
    for part in PARTS:
        fe, fp = loads.element[part], loads.particle[part]
        force = np.zeros((THETA.size, mech.n_link, 2))
        moment = np.zeros((THETA.size, mech.n_link))
        for k, nodes in enumerate((mech.elem_nodes[:, 0], mech.elem_nodes[:, 1])):
            f = to_global(fe[..., 3 * k : 3 * k + 2], nodes)
            arm = pos[:, nodes] - G[0][:, mech.elem_link]
            np.add.at(force, (slice(None), mech.elem_link), f)
            np.add.at(moment, (slice(None), mech.elem_link), _cross(arm, f) + fe[..., 3 * k + 2])
        f = to_global(fp[..., :2], mech.mass_nodes)
        np.add.at(force, (slice(None), mech.mass_link), f)
        arm = pos[:, mech.mass_nodes] - G[0][:, mech.mass_link]
        np.add.at(moment, (slice(None), mech.mass_link), _cross(arm, f) + fp[..., 2])
        if part.startswith("gravity"):
            frame = [0.0, 1.0] if part == "gravity" else [1.0, 0.0]
            a_G, rate = np.broadcast_to(frame, force.shape), np.zeros(moment.shape)
        else:
            a_G, rate = (G[2], kin.ddphi) if part == "per_w2" else (G[1], kin.dphi)
        m, J = mech.body_mass, mech.body_inertia
        scale = np.abs(m[:, None] * a_G).max()
        np.testing.assert_allclose(force, -m[:, None] * a_G, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(moment, -J * rate, rtol=0, atol=1e-12 * scale * mech.length.max())


def _cross(r, f):
    return r[..., 0] * f[..., 1] - r[..., 1] * f[..., 0]


def test_scatter_vector_is_the_transpose_of_the_element_gather():
    """x · scatter_vector(f) = Σ_e f_e · x[dofs_e] for any x (constrained DOFs dropped), and the
    assembled load pieces are the element and particle loads so scattered."""
    model = Model(turcic_midha(2))
    mech, pat = model.mechanism, model.pattern
    state = model.angle_state(THETA)
    loads = element_loads(mech, model.stacks, state)
    x = np.random.default_rng(2).normal(size=model.n_free)
    xp = np.append(x, 0.0)
    for part in PARTS:
        fe, fp = loads.element[part], loads.particle[part]
        got = pat.scatter_vector(fe) @ x
        want = np.einsum("aed,ed->a", fe, xp[np.where(mech.elem_dofs >= 0, mech.elem_dofs, -1)])
        np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13 * np.abs(fe).max())
        whole = getattr(model.load_pieces(THETA), part)
        want += np.einsum("amd,md->a", fp, xp[np.where(mech.mass_dofs >= 0, mech.mass_dofs, -1)])
        np.testing.assert_allclose(whole @ x, want, rtol=1e-13, atol=1e-13 * np.abs(fe).max())
    lp = model.load_pieces(THETA)
    want = 300.0**2 * lp.per_w2 + 2e3 * lp.per_accel + 9.81 * lp.gravity - 2.0 * lp.gravity_x
    np.testing.assert_allclose(lp.total(300.0, 2e3, 9.81, -2.0), want, rtol=1e-15)
