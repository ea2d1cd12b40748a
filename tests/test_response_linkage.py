"""The steady periodic response of linkages (fkev_slepc/periodic/response.py, api/response.py, fkev response;
docs/response.md §3-4) against closed forms, invariances and the second method. Lean meshes:
one element per link where the physics allows it."""

import json
from dataclasses import replace

import numpy as np
import pytest
from clitools import ROOT
from clitools import fkev as run_fkev

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.scene.model import Damping
from fkev_slepc.solve.accuracy import with_element
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.periodic.harmonic_balance import harmonic_balance
from fkev_slepc.periodic.shooting import shooting

RUNS = ROOT / "runs"
E, RHO, L = 2.07e11, 7760.0, 1.0  # runs/rotating-cantilever.toml


def bar_tip(element, n, case, kL):
    """Tip (axial, transverse) displacement in the bar's own frame over the cycle."""
    sc = with_element(with_elements(load_scene(RUNS / "rotating-cantilever.toml"), n), element)
    model = Model(sc, cases=(case,))
    w = kL / L * np.sqrt(E / RHO)
    r = harmonic_balance(PeriodicSystem(model, w, case).mck, PeriodicSystem(model, w, case).load, w,
                         harmonics=4)
    mech = model.mechanism
    d = mech.node_dofs[np.argmax(mech.node_s)]
    U, V, th = r.q[:, d[0]], r.q[:, d[1]], r.theta
    return np.cos(th) * U + np.sin(th) * V, -np.sin(th) * U + np.cos(th) * V


@pytest.mark.parametrize("element,n,tol", [("cubic", 16, 1e-5), ("cubic", 64, 1e-6), ("thesis", 64, 2e-5)])
def test_rotating_bar_stretch(element, n, tol):
    """Clamped-free bar at constant Ω under its own inertia: u(L) = tan(kL)/k - L, k = Ω sqrt(ρ/E),
    at kL = 50/70 (measured: cubic 1.5e-13 at 16 and 2.8e-13 at 64 elements; the thesis element's
    linear axial field converges like h², 2.1e-4 at 16 and 1.3e-5 at 64), no transverse response."""
    kL = 50 / 70
    u, v = bar_tip(element, n, "full", kL)
    exact = np.tan(kL) / (kL / L) - L
    assert np.abs(u / exact - 1).max() < tol
    if n == 16:
        assert np.abs(v).max() < 1e-12 * L


def test_rotating_bar_thesis_element_h2_and_the_normal_term():
    kL, exact = 50 / 70, np.tan(50 / 70) / (50 / 70) - L
    e16, e64 = (np.abs(bar_tip("thesis", n, "full", kL)[0] / exact - 1).max() for n in (16, 64))
    assert 14 < e16 / e64 < 18  # h²
    u_nn, _ = bar_tip("cubic", 16, "no_normal", kL)
    assert abs(u_nn.mean() / exact - 1) > 0.2  # without the normal (centrifugal softening) term: 20.5 % short


def bw(elements=1, **kw):
    sc = with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), elements)
    return replace(sc, links=tuple(replace(lk, **kw) for lk in sc.links)) if kw else sc


def hb_q(scene, w, H=24, case="full"):
    s = PeriodicSystem(Model(scene, cases=(case,)), w, case)
    return harmonic_balance(s.mck, s.load, w, harmonics=H).q


def test_speed_modulus_invariance_and_density_identity():
    """Without gravity or damping, (E, Ω) -> (s²E, sΩ) leaves q(θ) unchanged (every term of the
    equation in θ scales by s²); doubling ρ at fixed Ω gives the response of the original density
    at √2 Ω (the loads, M and the speed terms scale with ρ: ρ -> 2ρ equals E -> E/2, then the
    invariance with s = √2)."""
    base = bw()
    q = hb_q(base, 300.0)
    s = 1.7
    q_s = hb_q(bw(youngs_modulus=s**2 * base.links[0].youngs_modulus), s * 300.0)
    assert np.abs(q_s - q).max() <= 1e-10 * np.abs(q).max()
    q_2rho = hb_q(bw(density=2 * base.links[0].density), 300.0)
    q_fast = hb_q(base, np.sqrt(2) * 300.0)
    assert np.abs(q_2rho - q_fast).max() <= 1e-10 * np.abs(q_fast).max()


def test_static_limit():
    """At small Ω the response tends to the quasi-static K(θ)⁻¹f(θ); the difference falls like
    Ω² (measured: 1.5e-3 at 10 rad/s, 3.9e-4 at 5 rad/s, ratio 4.01; ω₁ ≈ 2300 rad/s, the
    coefficient is that of (kΩ/ω₁)² for the load's harmonics k up to ~10)."""
    sc = load_scene(RUNS / "bahgat-willmert-1976.toml")
    model = Model(sc, cases=("full",))
    diffs = []
    for w in (10.0, 5.0):
        s = PeriodicSystem(model, w, "full")
        r = harmonic_balance(s.mck, s.load, w, harmonics=64)
        _, _, K = s.mck(r.theta)
        static = np.linalg.solve(K, s.load(r.theta)[..., None])[..., 0]
        diffs.append(np.abs(r.q - static).max() / np.abs(static).max())
    assert diffs[0] < 2e-3 and 3.8 < diffs[0] / diffs[1] < 4.2


@pytest.mark.parametrize("path,w,beta,H,steps,tol_dq", [
    ("bahgat-willmert-1976.toml", 300.0, 1e-5, 96, 4096, 1e-8),
    ("turcic-midha-1984.toml", 40.0, 1e-4, 64, 24576, 3e-8),
])
def test_shooting_equals_harmonic_balance_on_the_thesis_linkages(path, w, beta, H, steps, tol_dq):
    """The periodic state at θ = 0 by shooting on the monodromy and by harmonic balance (one
    element per link, light Rayleigh damping β so that both converge within the test budget).
    Measured (q, q'): Bahgat-Willmert 9.8e-11, 2.4e-10; Turcic-Midha 5.6e-9, 2.0e-8, there the
    shooting's own limit at 24,576 Magnus steps (4.4e-8, 1.2e-7 at 16,384: order 6). The
    trajectory closes: ‖x(2π) - x(0)‖ < 1e-10 ‖x(0)‖ (measured 7e-14, 5e-14)."""
    sc = replace(with_elements(load_scene(RUNS / path), 1), damping=Damping(0.0, beta))
    s = PeriodicSystem(Model(sc, cases=("full",)), w, "full")
    hb = harmonic_balance(s.mck, s.load, w, harmonics=H)
    sh = shooting(s.mck, s.load, w, np.zeros(1), steps=steps)
    scale = np.abs(hb.q).max()
    assert np.abs(sh.q[0] - hb.q[0]).max() <= 1e-8 * scale
    assert np.abs(sh.dq[0] - hb.dq[0]).max() <= tol_dq * np.abs(hb.dq).max()
    assert sh.closure < 1e-10 and sh.max_abs_multiplier < 1.0


def test_the_response_shoots_on_the_generator_floquet_takes():
    """``--shooting`` (periodic_response with shoot) takes the PeriodicSystem's own scaled generator,
    the one Floquet takes (issue 34: it built a second one of (Ω²M, ΩC, K)): Bahgat-Willmert, one
    element per link, β = 1e-5, 300 rad/s, its multipliers are Floquet's within their stated errors
    (measured 4.6e-15: the same generator and steps), the periodic trajectory closes."""
    from fkev_slepc.periodic.floquet import floquet_multipliers
    from fkev_slepc.periodic.magnus import match_multipliers
    from fkev_slepc.periodic.response import periodic_response
    from fkev_slepc.periodic.settings import PeriodicSettings

    sc = replace(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), 1), damping=Damping(0.0, 1e-5))
    s = PeriodicSystem(Model(sc, cases=("full",)), 300.0, "full")
    sh = periodic_response(s, 300.0, harmonics=16, shoot=True, shooting_tol=1e-9).shoot
    fq = floquet_multipliers(s, PeriodicSettings(reduce="none", monodromy_tol=1e-10))
    i, j = match_multipliers(sh.multipliers, fq.multipliers)
    assert np.abs(sh.multipliers[i] - fq.multipliers[j]).max() <= fq.error + sh.error
    assert sh.closure < 1e-10 and sh.max_abs_multiplier < 1.0


def test_cli_response_json(tmp_path):
    import xarray as xr

    out = tmp_path / "r.h5"
    r = run_fkev("response", RUNS / "slider-crank-benchmark.toml", "--speed", "150", "--elements", "1",
                 "--no-shooting", "--angles", "0:350:10", "--json", "-o", out)  # H doubled to --tol (12 missed it: exit 3)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert len(d["crank_angle_deg"]) == 36 and len(d["stations"]) == 6
    st = d["stations"][4]
    assert (st["link"], st["s_m"]) == ("rod", 0.15)
    for key in ("axial_m", "transverse_m", "moment_n_m", "axial_force_n", "stress_pa"):
        assert len(st[key]) == 36
    ds = xr.open_dataset(out, engine="h5netcdf")
    np.testing.assert_allclose(ds["transverse_m"].values[:, 4], st["transverse_m"], rtol=1e-12, atol=1e-15)
    bad = run_fkev("response", RUNS / "slider-crank-benchmark.toml", "--station", "rod:0.5", "--no-shooting")
    assert bad.returncode == 2 and "--station" in bad.stderr and "not on link 'rod'" in bad.stderr
