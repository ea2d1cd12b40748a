"""Out-of-plane Floquet coefficients (docs/theory.md §19.9): the exact periodic coefficients of
the out-of-plane problem on the engines of fkev_slepc/periodic/floquet.py."""

import numpy as np
import scipy.linalg as la
from builders import bahgat_willmert, cantilever, rect_strip
from test_out_of_plane import rect_section

from fkev_slepc.model.operators import Model
from fkev_slepc.model.out_of_plane import Section
from fkev_slepc.model.periodic import periodic_pieces
from fkev_slepc.periodic import magnus as fq
from fkev_slepc.periodic.interpolant import TrigInterpolant, to_dense
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem


def _crank():
    """A one-element clamped strip with a slow twist (a test section: only the identities matter)."""
    L, b, t = 1.0, 0.01, 0.002
    props = rect_strip(b, t)
    E, rho, A = props["youngs_modulus"], props["density"], props["area"]
    i_out = b * t**3 / 12
    sec = Section(np.array([E * i_out]), np.array([5 * E * i_out]), np.array([0.05 * rho * A]))
    scale = np.sqrt(rho * A * L**4 / (E * i_out))
    return Model(cantilever(L, props, 1, cases=("full",)), plane="out", section=sec), 12.0 / scale


def test_lone_crank_out_of_plane_multipliers_are_its_frozen_spectrum():
    """In its own frame the lone crank's out-of-plane equations have constant coefficients: every
    multiplier is exp(sP) of a frozen eigenvalue s (P = 2π/Ω), |μ| = 1; the frozen matrices used
    as periodic coefficients (without the frame-rate terms of §19.9) give a spurious growth."""
    model, omega = _crank()
    res = floquet_multipliers(PeriodicSystem(model, omega, "full"),
                              PeriodicSettings(reduce="none", monodromy_tol=1e-11))
    assert res.error < 1e-9
    assert np.max(np.abs(np.abs(res.multipliers) - 1.0)) < 1e-9
    q = model.qep(model.pieces(0.4), omega, "full")
    w = np.sqrt(la.eigh(q.stiffness.toarray(), q.mass.toarray(), eigvals_only=True))
    expected = np.exp(np.r_[1j * w, -1j * w] * 2 * np.pi / omega)
    i, j = fq.match_multipliers(res.multipliers, expected)
    assert np.max(np.abs(res.multipliers[i] - expected[j])) < 1e-8

    def frozen(theta):
        qs = [model.qep(model.pieces(t), omega, "full") for t in theta]
        M, K = (np.stack([getattr(x, k).toarray() for x in qs]) for k in ("mass", "stiffness"))
        return M, np.zeros_like(M), K / omega**2  # d/dt = Ω d/dθ

    wrong = fq.monodromy(TrigInterpolant(0.0, fq.second_order(frozen)(2 * np.pi * np.arange(32) / 32)),
                         2 * np.pi, steps=2048)
    assert wrong.max_abs > 1.5


def test_out_of_plane_gyroscopic_part_is_the_mass_rate():
    """Every case is Lagrangian out of plane: sym C₁ = dM/dθ (6th-order difference) and
    C₁ = N₁ - N₁ᵀ + dM/dθ, K₂ = V₂ + dN₁/dθ, on Bahgat–Willmert."""
    scene = bahgat_willmert(cases=("full", "no_coriolis"))
    model = Model(scene, plane="out", section=rect_section(scene, 2.07e11, 7760.0))
    th, h = 0.7, 1e-3
    pts = th + h * np.arange(-3, 4)
    w = np.array([-1, 9, -45, 0, 45, -9, 1]) / (60 * h)
    for case in ("full", "no_coriolis"):
        p = periodic_pieces(model, pts, case)
        assert p.lagrangian
        d = lambda a: np.tensordot(w, to_dense(model.pattern, a), 1)  # noqa: E731
        C1, M = to_dense(model.pattern, p.gyro[3:4])[0], d(p.mass)
        N1 = to_dense(model.pattern, p.coupling[3:4])[0]
        scale = np.abs(C1).max()
        assert np.abs(0.5 * (C1 + C1.T) - M).max() < 1e-8 * scale
        assert np.abs(C1 - (N1 - N1.T + M)).max() < 1e-8 * scale
        K2, V2 = (to_dense(model.pattern, a[3:4])[0] for a in (p.speed_stiffness, p.potential))
        assert np.abs(K2 - (V2 + d(p.coupling))).max() < 1e-7 * np.abs(K2).max()


def test_bahgat_willmert_out_of_plane_monodromy_is_symplectic():
    """Undamped out of plane (3 elements, 300 rad/s): det Φ = 1 and the multiplier set is closed
    under μ -> 1/μ̄ (§18.6), whatever the verdict."""
    scene = bahgat_willmert(elements=(1, 1, 1), cases=("full",))
    model = Model(scene, plane="out", section=rect_section(scene, 2.07e11, 7760.0))
    res = floquet_multipliers(PeriodicSystem(model, 300.0, "full", damping=False),
                              PeriodicSettings(reduce="none", monodromy_tol=1e-4))
    mu = res.multipliers
    assert abs(np.linalg.det(res.monodromy.phi) - 1.0) < 1e-8
    i, j = fq.match_multipliers(mu, 1.0 / mu.conj())
    assert np.max(np.abs(mu[i] - 1.0 / mu[j].conj())) < 1e-8


def test_fkev_floquet_plane_out(tmp_path):
    """``fkev floquet --plane out``: the out-of-plane frozen sweep and monodromies in one archive
    (``<stem>-out-floquet.h5``, root attribute plane), the same multipliers as
    ``floquet_multipliers`` on ``Model(scene, plane="out")``; no frozen flutter out of plane."""
    import json
    from pathlib import Path

    from clitools import fkev
    from fkev_slepc import open as open_archive
    from fkev_slepc.scene import load_scene

    root = Path(__file__).resolve().parents[1]
    text = (root / "runs/bahgat-willmert-1976.toml").read_text().replace(
        "[link_defaults]\n", "[link_defaults]\nsecond_moment_out_of_plane_m4 = 5.42e-10\n"
        "torsion_constant_m4 = 1.826e-9\nshear_modulus_pa = 7.96e10\n", 1)
    scene = tmp_path / "bw.toml"
    scene.write_text(text)
    r = fkev("floquet", scene, "--plane", "out", "--speeds", "300", "--angles", "0,180", "--elements", "1",
             "--reduce", "none", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["frozen_time_critical"]["flutter_speed_rad_s"] is None
    archive = tmp_path / "out" / "bw-out-floquet.h5"
    assert open_archive(archive).plane == "out"
    from fkev_slepc.scene.edit import replace_values

    sc = replace_values(load_scene(scene), {f"links[{i}].elements": 1 for i in range(3)})
    want = np.max(np.abs(floquet_multipliers(PeriodicSystem(Model(sc, ("full",), plane="out"), 300.0, "full"),
                                             PeriodicSettings(reduce="none", monodromy_tol=1e-10)).multipliers))
    assert out["speed_rad_s"] == [300.0] and abs(out["max_abs_multiplier"][0] - want) < 1e-8


def test_work_limit_estimated_on_the_plane_run():
    """``work_problems(..., plane="out")`` estimates the Magnus steps on the out-of-plane model
    (the one ``fkev floquet --plane out`` runs), not the in-plane one (issue #34)."""
    import re
    from pathlib import Path

    from fkev_slepc.api.floquet import API_NAMES, work_problems
    from fkev_slepc.api.pool import ModelPool
    from fkev_slepc.periodic.floquet import full_min_steps
    from fkev_slepc.scene import load_scene
    from fkev_slepc.scene.edit import replace_values

    root = Path(__file__).resolve().parents[1]
    sc = load_scene(root / "runs/flat-rod-slider-crank.toml")
    sc = replace_values(sc, {f"links[{i}].elements": 1 for i in range(len(sc.links))})
    low = float(np.min(sc.driver.speeds))

    def estimate(plane):
        (p,) = work_problems(sc, "full", None, API_NAMES, ModelPool(sc), max_steps=0, plane=plane)
        return float(re.search(r"about (\S+) Magnus steps", p.message).group(1))

    out = float(full_min_steps(Model(sc, ("full",), plane="out"), low, "full"))
    inp = float(full_min_steps(Model(sc, ("full",), plane="in"), low, "full"))
    assert out != inp
    assert estimate("out") == float(f"{out:.3g}") and estimate("in") == float(f"{inp:.3g}")
