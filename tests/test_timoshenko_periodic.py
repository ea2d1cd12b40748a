"""The Timoshenko element (docs/theory.md §22) in the periodic stage (issue 42 item 2): Floquet, the
steady response and the shooting cross-check on links modelled with shear and rotary inertia, against
known answers: a lone rotating Timoshenko beam is constant in its own frame (its monodromy is the
exponential of its frozen generator, its response one static solve with the rotating bar's closed-form
stretch), and on a four-bar of stocky links the harmonic balance and the shooting on the monodromy
(two independent methods on the same PeriodicSystem) give the same periodic response."""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg as la

from builders import four_bar
from clitools import ROOT
from fkev_slepc.api.response import study_response
from fkev_slepc.model.operators import Model
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.solve.accuracy import with_element

E, NU, RHO = 2.07e11, 0.3, 7760.0
G = E / (2 * (1 + NU))


def _lone_timoshenko_beam(elements: int, slenderness: float = 10.0):
    """runs/rotating-cantilever.toml as a stocky Timoshenko strip: L/r = ``slenderness``, κ = 5/6."""
    base = with_element(with_elements(load_scene(ROOT / "runs" / "rotating-cantilever.toml"), elements), "timoshenko")
    lk = base.links[0]
    lk = dataclasses.replace(lk, second_moment=lk.area * (lk.length / slenderness) ** 2, shear_modulus=G,
                             shear_coefficient=5.0 / 6.0)
    return dataclasses.replace(base, links=(lk,)), lk


def _speed(lk, lam: float) -> float:
    """Ω of the nondimensional speed λ = Ω sqrt(ρAL⁴/EI)."""
    return lam / np.sqrt(lk.density * lk.area * lk.length**4 / (lk.youngs_modulus * lk.second_moment))


def test_lone_rotating_timoshenko_beam_monodromy_is_the_exponential_of_its_frozen_generator():
    """Constant in its frame, the beam's monodromy over one revolution (R(2π) = I) is exp(A T), T = 2π/Ω:
    every Floquet multiplier is exp(λ T) of a frozen eigenvalue λ of the same model's QEP (Coriolis,
    centrifugal and shear terms alike), to 1e-9, and undamped |μ| = 1 to 1e-10 below the first
    divergence speed."""
    scene, lk = _lone_timoshenko_beam(8)
    w = _speed(lk, 2.0)
    model = Model(scene, cases=("full",))
    res = floquet_multipliers(PeriodicSystem(model, w, "full"), PeriodicSettings(reduce="none"))
    assert res.monodromy.steps == 1  # one exponential (periodic/system.py link_frame)
    mu = np.asarray(res.multipliers)
    assert np.max(np.abs(np.abs(mu) - 1.0)) < 1e-10
    q = model.qep(model.pieces(0.0), w, "full")
    n = model.n_free
    Mq, Cq, Kq = (x.toarray() for x in (q.mass, q.damping, q.stiffness))
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-la.solve(Mq, Kq), -la.solve(Mq, Cq)]])
    want = np.exp(la.eigvals(A) * 2.0 * np.pi / w)
    gap = np.array([np.min(np.abs(mu - x)) for x in want])
    assert gap.max() < 1e-9, gap.max()
    assert mu.size == want.size == 2 * n


def test_lone_rotating_timoshenko_beam_response_is_the_rotating_bar_stretch():
    """The steady response of the lone beam is one static solve (harmonics 0 and 1 of the frame rotation
    in global DOFs): its tip stretch is tan(kL)/k − L, k = Ω sqrt(ρ/E), to the element's h² axial
    accuracy (its axial field is the thesis element's: the same error, measured 1.32e-5 at 16 and
    3.31e-6 at 32 elements, kL = 0.2), with no transverse response, whatever the shear."""
    errors = []
    for n in (16, 32):
        scene, lk = _lone_timoshenko_beam(n)
        thesis = study_response(with_element(scene, "thesis"), _speed(lk, 2.0), "full", [0.0, 90.0, 200.0])
        w = _speed(lk, 2.0)
        k = w * np.sqrt(lk.density / lk.youngs_modulus)
        r = study_response(scene, w, "full", [0.0, 90.0, 200.0])
        assert r.harmonics == 1 and r.hb_error < 1e-13
        tip = r.stations.axial[:, -1]
        errors.append(np.abs(tip / (np.tan(k * lk.length) / k - lk.length) - 1).max())
        assert np.abs(r.stations.transverse).max() < 1e-12 * np.abs(tip).max()
        np.testing.assert_allclose(tip, thesis.stations.axial[:, -1], rtol=1e-10)
    assert errors[1] < 5e-6 and 3.5 < errors[0] / errors[1] < 4.5, errors  # h²


def test_harmonic_balance_and_shooting_agree_on_a_stocky_timoshenko_four_bar():
    """A four-bar of stocky links (L/r 9–50, 2 elements each) on the Timoshenko element at 160 rad/s,
    undamped: the harmonic balance and the shooting on the system's own monodromy (two independent
    methods on one PeriodicSystem) give the same periodic deflection (measured 5.6e-11 of its peak;
    asserted 1e-8), the shot trajectory closes and the multipliers are neutral; the shear-flexible
    linkage deflects more than the Euler–Bernoulli one (same mesh, same loads)."""
    props = dict(youngs_modulus=E, density=RHO, area=4e-4, second_moment=4e-4 * 0.02**2 / 12, shear_modulus=G,
                 shear_coefficient=5.0 / 6.0)
    sc = four_bar((0.05, 0.2794, 0.2667), 0.254, props, (2, 2, 2), speeds=(160.0,), angles=(30.0,))
    angles = np.arange(0.0, 360.0, 30.0)
    r = study_response(with_element(sc, "timoshenko"), 160.0, "full", angles, shoot=True)
    assert r.hb_error < 1e-8 and r.methods_difference < 1e-8, (r.hb_error, r.methods_difference)
    assert r.closure < 1e-8 and abs(r.max_abs_multiplier - 1.0) < 1e-6
    cubic = study_response(with_element(sc, "cubic"), 160.0, "full", angles)
    assert np.abs(r.stations.transverse).max() > 1.001 * np.abs(cubic.stations.transverse).max()
