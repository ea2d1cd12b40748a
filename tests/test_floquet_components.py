"""The link-frame component-mode (Craig–Bampton) reduction of the linkage monodromy
(fkev_slepc/periodic/components.py, docs/theory.md §18.8).

Known answers: with every fixed-interface mode kept the basis is a change of variables, so the
reduced multipliers are the full model's (Turcic–Midha at 1 element per link and 100 rad/s,
unstable, max|μ| ≈ 25; Bahgat–Willmert at 1 element per link and 700 rad/s, unstable, max|μ| ≈
1.11; the damped Bahgat–Willmert scene); the Galerkin projection of the Lagrangian is Lagrangian
(undamped |μ| = 1 and det Φ = 1 at a stable speed); W', W'' are the exact angle derivatives of W
(6th-order differences); in every link frame the projected frozen mass and stiffness of the
fixed-interface modes are I and diag(ω²) at every crank angle, uncoupled from the boundary.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.model.operators import Model
from fkev_slepc.model.periodic import periodic_pieces
from fkev_slepc.scene import load_scene
from fkev_slepc.periodic.magnus import match_multipliers
from fkev_slepc.periodic.components import Components, boundary_dofs, link_components
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.periodic.truncation import resolve_reduce

RUNS = Path(__file__).resolve().parents[1] / "runs"
TM, BW = RUNS / "turcic-midha-1984.toml", RUNS / "bahgat-willmert-1976.toml"
BW_DAMPED, SLIDER, SIX_BAR = (RUNS / "bahgat-willmert-damped.toml", RUNS / "slider-crank-benchmark.toml",
                              RUNS / "stephenson-six-bar.toml")


def _model(path, elements: int) -> Model:
    sc = load_scene(path)
    return Model(replace(sc, links=tuple(replace(lk, elements=elements) for lk in sc.links)), ("full",))


def _levels(model, omega, damping, keeps):
    comp = link_components(model)
    return [floquet_multipliers(PeriodicSystem(model, omega, "full", damping=damping, basis=comp.basis(k)),
                                PeriodicSettings(reduce="none")) for k in keeps]


def test_levels_approach_the_full_model_and_every_mode_is_the_full_model():
    """Bahgat–Willmert, 1 element per link, 700 rad/s (unstable): the boundary DOFs alone (Guyan)
    miss max|μ| by percents, the levels with modes stay near it, and every fixed-interface mode kept
    (a square, invertible W) is the full model to 1e-8, multiplier by multiplier."""
    model = _model(BW, 1)
    full = floquet_multipliers(PeriodicSystem(model, 700.0, "full", damping=False), PeriodicSettings(reduce="none"))
    comp = link_components(model)
    levels = _levels(model, 700.0, False, (0, 1, int(max(c.size for c in comp.links))))
    assert full.max_abs > 1.1
    assert [r.basis for r in levels] == sorted({r.basis for r in levels}) and levels[-1].basis == model.n_free
    assert levels[0].basis == comp.boundary.size
    err = np.array([abs(r.max_abs - full.max_abs) / full.max_abs for r in levels])
    assert err[-1] < 1e-8 and err[0] > 1e-2 and err[1] < 0.2
    i, j = match_multipliers(full.multipliers, levels[-1].multipliers)
    assert np.max(np.abs(full.multipliers[i] - levels[-1].multipliers[j])) < 1e-8 * full.max_abs


def test_reduce_links_n_measures_its_truncation_and_ends_at_the_full_model():
    """``reduce="links:1"`` on Turcic–Midha (1 element per link, 100 rad/s, unstable, max|μ| ≈ 25):
    its truncation is measured against 2 modes per link, here every mode, whose max|μ| is the full
    model's to 1e-8; the result states the frequency range it covers."""
    model = _model(TM, 1)
    full = floquet_multipliers(PeriodicSystem(model, 100.0, "full", damping=False), PeriodicSettings(reduce="none"))
    res = floquet_multipliers(PeriodicSystem(model, 100.0, "full", damping=False), PeriodicSettings(reduce="links:1"))
    t, comp = res.truncation, link_components(model)
    assert full.max_abs > 20.0
    assert res.basis == comp.basis(1).shape[1] < model.n_free
    assert [s for s, _, _ in t.levels] == [res.basis, model.n_free]
    assert abs(t.levels[1][1] - full.max_abs) < 1e-8 * full.max_abs
    assert t.max_abs == pytest.approx(abs(res.max_abs - full.max_abs) / full.max_abs, rel=0.05) and t.max_abs > 1e-3
    assert 0.0 < res.covered_rad_s == comp.basis(1).covered_rad_s < comp.basis(2).covered_rad_s


def test_undamped_reduced_multipliers_stay_on_the_unit_circle():
    """A strict sub-basis at a Floquet-stable speed (Bahgat–Willmert, 2 elements per link,
    500 rad/s, 1 mode per link): |μ| = 1 to 1e-12, det Φ = 1, the set closed under μ -> 1/μ̄."""
    model = _model(BW, 2)
    res = floquet_multipliers(PeriodicSystem(model, 500.0, "full", damping=False),
                              PeriodicSettings(reduce="links:1"), check_truncation=False)
    assert res.basis < model.n_free
    mu = res.multipliers
    assert np.max(np.abs(np.abs(mu) - 1.0)) < 1e-12
    assert abs(np.linalg.det(res.monodromy.phi) - 1.0) < 1e-10
    i, j = match_multipliers(mu, 1.0 / mu.conj())
    assert np.max(np.abs(mu[i] - 1.0 / mu[j].conj())) < 1e-10


def test_damped_scene_every_mode_is_the_full_model():
    """Rayleigh damping (runs/bahgat-willmert-damped.toml, 1 element per link, 700 rad/s): the
    damped reduced multipliers with every mode kept are the full model's, and |μ| < 1 shrinks
    by damping below the undamped level."""
    model = _model(BW_DAMPED, 1)
    full = floquet_multipliers(PeriodicSystem(model, 700.0, "full"), PeriodicSettings(reduce="none"))
    comp = link_components(model)
    red = floquet_multipliers(PeriodicSystem(model, 700.0, "full", basis=comp.basis(int(max(c.size for c in comp.links)))),
                              PeriodicSettings(reduce="none"))
    assert abs(red.max_abs - full.max_abs) < 1e-8 * full.max_abs
    assert abs(np.linalg.det(full.monodromy.phi)) < 1.0  # damped: volume contracts
    i, j = match_multipliers(full.multipliers, red.multipliers)
    assert np.max(np.abs(full.multipliers[i] - red.multipliers[j])) < 1e-8


def _fd6(f, x, h):
    c = np.array([-1.0, 9.0, -45.0, 0.0, 45.0, -9.0, 1.0]) / 60.0
    c2 = np.array([2.0, -27.0, 270.0, -490.0, 270.0, -27.0, 2.0]) / 180.0
    vals = [f(x + k * h) for k in range(-3, 4)]
    return sum(a * v for a, v in zip(c, vals)) / h, sum(a * v for a, v in zip(c2, vals)) / h**2


@pytest.mark.parametrize("path, elements", [(BW, 4), (SLIDER, 3), (SIX_BAR, 2)])
def test_basis_derivatives_match_finite_differences(path, elements):
    """W' and W'' (chain rule through the link angles) against 6th-order central differences of
    W(θ) in the crank angle: a four-bar, a slider-crank (guide-frame boundary node) and a six-bar
    with a ternary link."""
    model = _model(path, elements)
    basis = link_components(model).basis(3)
    mech = model.mechanism

    def W(theta, k=0):
        kin = solve_kinematics(mech, np.array([theta]))
        return basis.at(kin.phi[0], kin.dphi[0], kin.ddphi[0])[k]

    for theta in (0.4, 2.3):
        d1, d2 = _fd6(W, theta, 1e-2)
        scale = np.max(np.abs(W(theta)))
        assert np.max(np.abs(W(theta, 1) - d1)) < 1e-7 * scale
        assert np.max(np.abs(W(theta, 2) - d2)) < 1e-6 * scale


@pytest.mark.parametrize("path", [BW, SLIDER, SIX_BAR])
def test_link_frame_blocks_are_constant(path):
    """Projected on W(θ), the frozen mass and stiffness of the fixed-interface modes are I and
    diag(ω²) at every crank angle (the link-frame blocks do not turn with the links), and the
    static constraint modes decouple them from the boundary in the stiffness."""
    model = _model(path, 3)
    comp = link_components(model)
    basis = comp.basis(2)
    n_b = comp.boundary.size
    thetas = np.array([0.0, 1.3, 4.0])
    p, kin = periodic_pieces(model, thetas, "structure"), solve_kinematics(model.mechanism, thetas)
    w2 = np.concatenate([c.freq[:k] ** 2 for c, k in zip(comp.links, basis.keep)])
    for i in range(thetas.size):
        W = basis.at(kin.phi[i], kin.dphi[i], kin.ddphi[i])[0]
        M, K = (W.T @ (model.pattern.matrix(x[i]) @ W) for x in (p.mass, p.stiffness))
        assert np.allclose(M[n_b:, n_b:], np.eye(w2.size), atol=1e-10)
        assert np.allclose(K[n_b:, n_b:], np.diag(w2), rtol=0, atol=1e-9 * w2.max())
        assert np.max(np.abs(K[n_b:, :n_b])) < 1e-9 * np.max(np.abs(K))


def test_boundary_partition_and_slepc_modes():
    """Slider-crank: the slider node's free DOF and the joint translations are boundary DOFs;
    boundary plus interiors partition the free DOFs; the fixed-interface modes of SLEPc
    (shift-invert, forced by dense_max=0) are the dense ones."""
    model = _model(SLIDER, 8)
    mech = model.mechanism
    bnd = boundary_dofs(mech)
    slider = mech.node_dofs[(mech.node_dofs[:, :2] < 0).sum(axis=1) == 1]
    assert slider.size and bnd[slider[slider >= 0]].all()
    dense = link_components(model)
    assert dense.boundary.size + sum(c.size for c in dense.links) == model.n_free
    sparse = Components(model, dense_max=0)
    a, b = dense.basis(6), sparse.basis(6)
    for c, d, k in zip(dense.links, sparse.links, a.keep):
        assert np.allclose(d.freq[:k], c.freq[:k], rtol=1e-9)
    assert a.covered_rad_s == pytest.approx(b.covered_rad_s, rel=1e-9)


@pytest.mark.parametrize("value, expected", [("links", "links"), ("LINKS:8", "links:8"), ("links:0", "links:0")])
def test_resolve_links(value, expected):
    assert resolve_reduce(value) == expected


@pytest.mark.parametrize("bad", ["links:", "links:x", "links:-1"])
def test_bad_links_value_is_named(bad):
    with pytest.raises(ValueError, match="reduce"):
        floquet_multipliers(PeriodicSystem(_model(TM, 1), 100.0, "full"), PeriodicSettings(reduce=bad))


def test_fkev_floquet_reduce_links_archives_the_covered_range(tmp_path):
    """``fkev floquet --reduce links:1`` (Bahgat–Willmert, 1 element per link, 700 rad/s): the
    archive holds the basis size, the truncation and the covered fixed-interface frequency of the
    in-process result, and the report's model line states the range; a bad value names the flag."""
    import h5py

    from clitools import fkev
    from fkev_slepc.cli.floquet import lines
    from fkev_slepc.sweep.floquet_run import read_floquet

    out = tmp_path / "links.h5"
    r = fkev("floquet", BW, "--elements", "1", "--speeds", "700", "--angles", "0:360:90", "--no-critical",
             "--reduce", "links:1", "-q", "-o", out)
    ref = floquet_multipliers(PeriodicSystem(_model(BW, 1), 700.0, "full"), PeriodicSettings(reduce="links:1"))
    # 1 mode per link against 2 changes max|μ| by 0.1: not converged, so no verdict (exit 3, issue 27 item 1)
    assert not ref.truncation.converged and r.returncode == 3, r.stderr
    with h5py.File(out, "r") as f:
        assert f["floquet/basis_size"][0, 0] == ref.basis
        assert f["floquet/covered_rad_s"][0, 0] == pytest.approx(ref.covered_rad_s, rel=1e-12)
        assert f["floquet/max_abs_multiplier"][0, 0] == pytest.approx(ref.max_abs, rel=1e-9)
    o = read_floquet(out).as_dict()
    assert any(t.startswith(f"  model: 1 of 1 grid speed on a link component-mode basis (fixed-interface modes up "
                            f"to {ref.covered_rad_s:.4g} rad/s) of {ref.basis} vectors") for t in lines(o)), lines(o)
    r = fkev("floquet", BW, "--speeds", "700", "--reduce", "links:two", "-o", tmp_path / "bad.h5")
    assert r.returncode == 2 and "--reduce" in r.stderr


def test_default_picks_link_components_where_their_levels_are_much_cheaper():
    """reduce="default" per speed (docs/engine.md): the full model below AUTO_MIN_STEPS
    (Turcic–Midha, 1 element per link, 100 rad/s); the frozen-mode sequence where the link level of
    8 modes per link is the whole space (Turcic–Midha, 3 elements per link, 60 rad/s: 27 of 27);
    the link components where that level needs at most a quarter of the full model's steps
    (Bahgat–Willmert, 16 elements per link, 500 rad/s: 14,361 against 762,340)."""
    from fkev_slepc.periodic.floquet import default_reduction, full_min_steps
    from fkev_slepc.periodic.truncation import LINKS_STEP_RATIO

    assert default_reduction(_model(TM, 1), 100.0) is None
    assert default_reduction(_model(TM, 3), 60.0) == "auto"
    fine = _model(BW, 16)
    assert default_reduction(fine, 500.0) == "links"
    level = full_min_steps(fine, 500.0, basis=link_components(fine).basis(8))
    assert LINKS_STEP_RATIO * level <= full_min_steps(fine, 500.0)


def test_frozen_frequencies_converge_level_by_level_from_above():
    """The levels are nested (boundary plus the first k modes of each link), so the Ritz values of
    the frozen structure on W(θ) decrease level by level (Cauchy interlacing) to the full model's
    frequencies, reached on the whole space; Bahgat–Willmert, 4 elements per link, at two angles."""
    import scipy.linalg as la

    model = _model(BW, 4)
    comp = link_components(model)
    thetas = np.array([0.7, 3.9])
    p, kin = periodic_pieces(model, thetas, "structure"), solve_kinematics(model.mechanism, thetas)
    for i in range(thetas.size):
        K, M = (model.pattern.matrix(x[i]).toarray() for x in (p.stiffness, p.mass))
        full = np.sqrt(la.eigh(K, M, eigvals_only=True)[:4])
        ritz = []
        for k in (1, 2, 4, 8, int(max(c.size for c in comp.links))):
            W = comp.basis(k).at(kin.phi[i], kin.dphi[i], kin.ddphi[i])[0]
            ritz.append(np.sqrt(la.eigh(W.T @ K @ W, W.T @ M @ W, eigvals_only=True)[:4]))
        ritz = np.array(ritz)
        assert np.all(np.diff(ritz, axis=0) <= 1e-9 * full)  # never up
        assert np.all(ritz >= full * (1 - 1e-9))  # always above the full model
        assert np.allclose(ritz[-1], full, rtol=1e-9) and np.all(ritz[0] > full * (1 + 1e-4))
        assert np.max(np.abs(ritz[3] - full) / full) < np.max(np.abs(ritz[0] - full) / full)
