"""The vectorised model layers (docs/engine.md "Vectorised pieces"): angle state and piece
stacks over many crank angles equal the one-angle path, and the one combining function gives
both consumers (Model.qep, Model.stiffness_terms) the same K(Ω)."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from builders import STEEL, bahgat_willmert, four_bar

from fkev_slepc.model import operators
from fkev_slepc.model.operators import AssemblyError, Model
from fkev_slepc.scene import load_scene
from fkev_slepc.scene.model import Damping
from fkev_slepc.scene.cases import CASE_NAMES

RUNS = Path(__file__).resolve().parents[1] / "runs"
FIELDS = ("mass", "structural", "coriolis", "normal", "rayleigh")
PAIRS = ("tangential", "pseudo_normal")
THETA = np.radians([0.0, 37.0, 123.0, 250.0, 311.0])


def _slider(element="thesis"):
    sc = load_scene(RUNS / "slider-crank.toml")
    return replace(sc, analysis=replace(sc.analysis, element=element))


@pytest.fixture(scope="module", params=["bw-damped", "slider-cubic"])
def model(request):
    if request.param == "bw-damped":  # Rayleigh damping: a rayleigh piece, C not skew
        scene = replace(bahgat_willmert(elements=(2, 3, 3)), damping=Damping(3.0, 2e-6))
    else:
        scene = _slider("cubic")
    return Model(scene, cases=CASE_NAMES)


def test_stack_rows_are_the_one_angle_pieces(model):
    """Every row of a stack over many angles is, to the last bit, what pieces(θ) gives alone
    (the per-point consumers and the vectorised ones see the same numbers)."""
    stack = model.piece_stack(THETA)
    assert stack.mass.shape == (THETA.size, model.pattern.nnz) and stack.ok.all()
    x = np.random.default_rng(1).normal(size=(model.n_free, 2))
    for i, th in enumerate(THETA):
        one = model.pieces(th)
        for f in FIELDS:
            a, b = getattr(stack, f), getattr(one, f)
            assert (a is None) == (b is None)
            if a is not None:
                np.testing.assert_array_equal(a[i], b)
        for f in PAIRS:
            for k in (0, 1):
                np.testing.assert_array_equal(getattr(stack, f)[k][i], getattr(one, f)[k])
        np.testing.assert_array_equal(model.pieces_at(stack, i).staged.apply(x), one.staged.apply(x))
        np.testing.assert_array_equal(stack.state.T[i], model.angle_state(th).T[0])


def test_blocks_of_angles_join_to_the_same_stack(model, monkeypatch):
    whole, loads = model.piece_stack(THETA), model.load_pieces(THETA)
    monkeypatch.setattr(operators, "BLOCK_FLOATS", 2 * model.stacks.n_el * model.stacks.n_dof**2)  # 2 angles
    parts = model.piece_stack(THETA)
    for f in ("per_w2", "per_accel", "gravity", "gravity_x"):
        np.testing.assert_array_equal(getattr(model.load_pieces(THETA), f), getattr(loads, f))
    for f in FIELDS + ("theta", "ok"):
        a, b = getattr(whole, f), getattr(parts, f)
        assert (a is None) == (b is None)
        if a is not None:
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(whole.pseudo_normal[1], parts.pseudo_normal[1])
    np.testing.assert_array_equal(whole.state.kinematics.ddphi, parts.state.kinematics.ddphi)
    np.testing.assert_array_equal(whole.state.axial[0], parts.state.axial[0])


def test_one_combination_for_qep_and_stiffness_terms(model):
    """K(Ω) of Model.qep equals K₀ + Ω² K₂ of Model.stiffness_terms, for one angle and for a
    stack (whose K₀, K₂ and symmetry flags are per angle), in every case."""
    stack = model.piece_stack(THETA)
    omega, accel = 700.0, 2.5e4
    for case in CASE_NAMES:
        K0s, K2s, syms = model.stiffness_terms(stack, case, accel)
        assert K0s.shape == K2s.shape == (THETA.size, model.pattern.nnz) and syms.shape == THETA.shape
        for i, th in enumerate(THETA):
            p = model.pieces(th)
            K0, K2, sym = model.stiffness_terms(p, case, accel)
            np.testing.assert_array_equal(K0s[i], K0)
            np.testing.assert_array_equal(K2s[i], K2)
            assert syms[i] == sym
            q = model.qep(p, omega, case, accel)
            K = q.stiffness.data
            np.testing.assert_allclose(K, K0 + omega**2 * K2, rtol=0, atol=1e-13 * np.abs(K).max())
            assert sym == (case in ("structure", "no_tangential"))
            if model.scene.damping.active:
                assert q.kind == "general"
                np.testing.assert_allclose(q.damping.data - stack.rayleigh[i], omega * (
                    stack.coriolis[i] if case not in ("structure", "no_coriolis") else 0.0),
                    rtol=0, atol=1e-14 * np.abs(stack.rayleigh[i]).max())
            else:
                assert q.kind in (("linear_symmetric", "gyroscopic") if sym else ("linear", "general"))


def test_angles_that_cannot_be_assembled_are_masked():
    """A triple rocker cannot reach θ = 180°: its row is NaN and flagged, the others are exact,
    and asking for that angle's pieces is an AssemblyError naming it."""
    m = Model(four_bar((0.2, 0.1, 0.15), 0.25, STEEL, elements=(2, 2, 2)), cases=CASE_NAMES)
    theta = np.radians([30.0, 180.0, 40.0])
    stack = m.piece_stack(theta)
    np.testing.assert_array_equal(stack.ok, [True, False, True])
    assert np.isnan(stack.structural[1]).all() and np.isfinite(stack.structural[[0, 2]]).all()
    np.testing.assert_array_equal(stack.pseudo_normal[0][2], m.pieces(theta[2]).pseudo_normal[0])
    with pytest.raises(AssemblyError, match="180 deg"):
        m.pieces_at(stack, 1)
    with pytest.raises(AssemblyError, match="180 deg"):
        m.pieces(np.pi)
