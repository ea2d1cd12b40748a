"""Accuracy per DOF, the round-off floor and requested accuracy (docs/accuracy.md)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from fkev_slepc.model.operators import Model
from fkev_slepc.solve.acceptance import polished_pair_error
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.engines import cross_check, frequencies
from fkev_slepc.solve.polish import polish_pair
from fkev_slepc.solve.slepc import SlepcEngine

BW = load_scene("runs/bahgat-willmert-1976.toml")


def with_element(scene, element, n):
    scene = dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, element=element))
    return with_elements(scene, n)


def bw_qep(element, n, case="full", angle=10.0, speed=1000.0):
    model = Model(with_element(BW, element, n), cases=(case,))
    return model, model.qep(model.pieces(np.radians(angle)), speed, case)


def observed_rates(element, meshes, case, angle):
    """Observed convergence rate p = log2(|f_n - f_2n| / |f_2n - f_4n|) of f₁…f₄."""
    with SlepcEngine() as engine:
        f = np.array([frequencies(engine, bw_qep(element, n, case, angle)[1], 4) for n in meshes])
    return np.log2(np.abs(f[0] - f[1]) / np.abs(f[1] - f[2]))


@pytest.mark.parametrize("case,angle", [("full", 10.0), ("structure", 120.0), ("no_normal", 250.0)])
def test_linkage_convergence_rate_h4_cubic_h2_thesis(case, angle):
    """Bahgat-Willmert linkage, three meshes each: the cubic-axial element converges like h⁴,
    the thesis element (linear axial) like h² in the modes that stretch the links (a mode that
    hardly stretches them converges faster: the slowest mode sets the error)."""
    cubic = observed_rates("cubic", (8, 16, 32), case, angle)
    thesis = observed_rates("thesis", (32, 64, 128), case, angle)
    assert np.all(cubic >= 3.5), cubic
    assert 1.7 < thesis.min() < 2.6, thesis


def test_cubic_element_model_structure_and_engines_agree():
    """M SPD, K_s symmetric, the Coriolis matrix and m_a skew on the assembled cubic model;
    dense QZ ≡ SLEPc; the thesis scenes still use the thesis element."""
    model, q = bw_qep("cubic", 4)
    assert BW.analysis.element == "thesis" and load_scene("runs/turcic-midha-1984.toml").analysis.element == "thesis"
    assert model.n_free == Model(with_element(BW, "thesis", 4)).n_free + 2 * 12
    M, C = q.mass.toarray(), q.damping.toarray()
    assert np.allclose(M, M.T) and np.linalg.eigvalsh(M).min() > 0
    assert np.allclose(C, -C.T) and np.abs(C).max() > 0
    Ks = q.stiffness.toarray() - q.stiffness_rest.toarray()
    np.testing.assert_allclose(Ks, Ks.T, atol=1e-9 * np.abs(Ks).max())
    assert cross_check(q, 4) < 1e-9
    # the factored K_s equals the assembled one
    x = np.random.default_rng(1).standard_normal((q.n, 2))
    np.testing.assert_allclose(q.staged.apply(x), Ks @ x, rtol=1e-9, atol=1e-9 * np.abs(Ks @ x).max())


def test_polish_recovers_a_pair_and_its_error_exposes_a_wrong_one():
    _, q = bw_qep("cubic", 8)
    sol = DenseEngine().solve(q, 4, want_vectors=True)
    osc = np.flatnonzero(sol.eigenvalues.imag > 0)
    osc = osc[np.argsort(sol.eigenvalues.imag[osc])][:2]
    (l1, l2), (x1, x2) = sol.eigenvalues[osc], sol.vectors[:, osc].T
    lam, x, err = polish_pair(q, l1 * (1 + 1e-4), x1 + 1e-3 * x2)  # a perturbed pair comes back
    assert abs(lam / l1 - 1) < 1e-11 and err < 1e-10
    lu = spla.splu((q.stiffness + l1 * (1 + 1e-6) * q.damping + (l1 * (1 + 1e-6)) ** 2 * q.mass).tocsc())
    assert polished_pair_error(q, l1, x1 + 0.3 * x2, lu.solve) > 1e-2  # a mixed vector is not a pair


@pytest.mark.slow
def test_no_round_off_floor_on_fine_meshes():
    """Thesis element at 1,024 elements per link (9,216 DOFs): unpolished f₁ is off ~1e-5; the
    polished pairs are within 2e-8 of the converged values (Richardson on the cubic element,
    h⁴, 32/64 elements per link; f₄ keeps the thesis element's own h² error of 1.2e-8) and pass
    the pair-error check. In the gyroscopic case no_tangential every real part is 0: the status
    is ok (an unpolished extra eigenvalue would carry a spurious real part)."""
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.status import Status

    model = Model(with_element(BW, "thesis", 1024), cases=("full", "no_tangential"))
    pieces = model.pieces(np.radians(10.0))
    with SlepcEngine() as engine:
        ref = [frequencies(engine, bw_qep("cubic", n)[1], 4) for n in (32, 64)]
        f_inf = ref[1] + (ref[1] - ref[0]) / 15
        sol = engine.solve(model.qep(pieces, 1000.0, "full"), 4)
        gyro = postprocess(engine.solve(model.qep(pieces, 1000.0, "no_tangential"), 4), 4)
    f = np.sort(sol.eigenvalues.imag[sol.eigenvalues.imag > 0])[:4] / (2 * np.pi)
    assert sol.converged
    np.testing.assert_allclose(f, f_inf, rtol=2e-8)
    assert gyro.status == Status.OK and abs(gyro.max_real) < 1e-9 * abs(gyro.eigenvalue[0]), gyro.max_real


def test_scene_element_and_rel_error_are_validated():
    from fkev_slepc.scene import SceneError, parse_scene

    text = BW.source_text
    for bad, msg in (('element = "quintic"', r"analysis.element: must be one of 'thesis', 'cubic', 'timoshenko' \(got 'quintic'\)"),
                     ("rel_error = 0", r"analysis.rel_error: must be > 0"),
                     ("rel_error = 1.5", r"analysis.rel_error: must be < 1")):
        with pytest.raises(SceneError, match=msg):
            parse_scene(text.replace("[analysis]\n", f"[analysis]\n{bad}\n"), "bw.toml")
    good = parse_scene(text.replace("[analysis]\n", '[analysis]\nelement = "cubic"\nrel_error = 1e-6\n'), "bw.toml")
    assert good.analysis.element == "cubic" and good.analysis.rel_error == 1e-6


def test_rel_error_plan_meets_the_tolerance_at_least_cost():
    """The plan measures the rate (cubic ~4, thesis ~2 on the asymptotic meshes), picks the
    cheaper element, and its answer is within the tolerance of the converged frequencies
    (Richardson of the cubic element over 32/64 elements per link)."""
    from fkev_slepc.solve.accuracy import planned_scene

    point = (10.0, 1000.0, "full")
    scene, plan = planned_scene(BW, [point], 4, 1e-5)
    rates = {c.element: c.rate for c in plan.candidates}
    assert 3.5 < rates["cubic"] < 4.5 and 1.7 < rates["thesis"] < 2.6, rates
    assert plan.element == "cubic" and plan.predicted_error <= 1e-5
    assert plan.n_free == min(c.n_free for c in plan.candidates)
    with SlepcEngine() as engine:
        ref = [frequencies(engine, bw_qep("cubic", n)[1], 4) for n in (32, 64)]
        model = Model(scene, cases=("full",))
        f = frequencies(engine, model.qep(model.pieces(np.radians(10.0)), 1000.0, "full"), 4)
    f_inf = ref[1] + (ref[1] - ref[0]) / 15
    err = np.abs(f / f_inf - 1).max()
    assert err <= 1e-5 and err > 1e-8, err  # met, and not by an over-refined mesh
    _, loose = planned_scene(BW, [point], 4, 3e-2)
    assert loose.element == "thesis" and loose.elements <= 4  # a loose tolerance: the cheap thesis mesh


def test_cli_rel_error_reports_and_archives_the_estimate(tmp_path, capsys):
    import h5py

    from fkev_slepc.cli import main

    path = "runs/bahgat-willmert-1976.toml"
    assert main(["point", path, "--angle", "10", "--speed", "1000", "--case", "full", "--rel-error", "1e-4",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["element"] == out["accuracy"]["element"] and 0 < out["rel_error_estimate"] <= 1e-4
    assert out["elements"] == [out["accuracy"]["elements_per_link"]] * 3
    h5 = tmp_path / "bw.h5"
    assert main(["run", path, "--angles", "0,40", "--speeds", "500", "--cases", "full", "--rel-error", "1e-4",
                 "--quiet", "-o", str(h5)]) == 0
    with h5py.File(h5) as f:
        plan = json.loads(f.attrs["accuracy"])
        assert f.attrs["element"] == plan["element"] and 0 < plan["predicted_rel_error"] <= 1e-4
        assert list(f.attrs["elements"]) == [plan["elements_per_link"]] * 3
    assert main(["point", path, "--element", "cubic", "--elements", "2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_free"] == 30
