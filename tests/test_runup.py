"""The run-up in time (docs/theory.md §21; fkev_slepc/periodic/motion.py, periodic/runup.py,
api/runup.py): against the steady periodic response, Floquet's growth rate, the energy and exact
solution of a constant-coefficient system, the Lagrangian identity of the crank-acceleration piece,
bad input, and resume bit for bit. 1 el/link (9 DOFs) or a 2-element cantilever: seconds each."""

from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.linalg as sla

import fkev_slepc as fk
from fkev_slepc.api.runup import study_runup
from fkev_slepc.model.operators import Model
from fkev_slepc.model.periodic import periodic_pieces
from fkev_slepc.model.pieces import combine
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.periodic.motion import CrankHistory, MotionSystem
from fkev_slepc.periodic.runup import integrate
from fkev_slepc.scene import SceneError

from clitools import fkev, problem_lines

ROOT = Path(__file__).resolve().parents[1]
DAMPED = ROOT / "runs/bahgat-willmert-damped.toml"
UNDAMPED = ROOT / "runs/bahgat-willmert-1976.toml"
CANTILEVER = ROOT / "runs/rotating-cantilever.toml"


def _model(path, elements=1):
    study = fk.load(path, elements=elements)
    return study, Model(study.scene, ("full",))


def test_motion_system_is_the_periodic_system_at_constant_speed():
    """At α = 0 the interpolated (M, C, K, f) are PeriodicSystem's exact coefficients and load."""
    from fkev_slepc.periodic.system import PeriodicSystem

    _, m = _model(DAMPED, 2)
    ms = MotionSystem(m, "full")
    ps = PeriodicSystem(m, 700.0, "full")
    c = ps.coefficients([1.234])
    got = ms.at(1.234, 700.0, 0.0)
    for a, b in zip(got, (c.M[0], c.C[0], c.K[0], ps.load([1.234])[0])):
        assert np.max(np.abs(a - b)) <= 1e-11 * np.max(np.abs(b))
    assert ms.error <= 1e-12


@pytest.mark.parametrize("case", ["full", "no_pseudo_normal", "no_coriolis"])
def test_acceleration_piece_is_the_frozen_one_plus_the_frame_rate(case):
    """K_α = (the frozen stiffness per crank acceleration, model/pieces.py: T₁ + P₁) + Σφ'Tᵀ(−mE)T, the latter
    the Lagrangian coupling N₁ of the structure case (docs/theory.md §21)."""
    study = fk.load(DAMPED, elements=2)
    m = Model(study.scene, (case, "structure"))
    theta = np.array([0.3, 2.0, 4.4])
    ka = periodic_pieces(m, theta, case, accel=True).accel_stiffness
    frame = periodic_pieces(m, theta, "structure").coupling
    frozen = combine(m.piece_stack(theta), 0.0, m.case_terms(case), 1.0, with_damping=False).rest  # α(T₁ + P₁) at α = 1
    assert np.max(np.abs(ka - (frozen + frame))) <= 1e-10 * np.max(np.abs(ka))


def test_ramp_in_link_frames_converges_to_the_ramp_in_global_dofs():
    """Along a ramp, the co-rotated identity basis (an exact change of variables, with its α WᵀMW′ term)
    and the global DOFs converge to one motion at second order."""
    _, m = _model(DAMPED)
    full, frame = MotionSystem(m, "full"), MotionSystem(m, "full", basis=np.eye(m.n_free))
    h = CrankHistory.ramp(0.0, 400.0, 0.05)
    diff = []
    for k in (1024, 2048):
        qa, qb = integrate(full, h, steps_per_revolution=k).last.q, integrate(frame, h, steps_per_revolution=k).last.q
        diff.append(np.max(np.abs(qa - qb)) / np.max(np.abs(qa)))
    assert diff[1] < 1e-4 and 3.0 < diff[0] / diff[1] < 5.0  # measured 2.75e-4, 6.87e-5


def test_constant_speed_settles_on_the_steady_response():
    """Damped scene, 50 rad/s, from the rest deflection: after 6 revolutions the last one at 2048, 4096,
    8192 steps per revolution converges at order 2 (measured 1.95, 2.00) and its Romberg limit equals
    the steady periodic response (fkev response, by shooting to 1e-9) to 1.1e-6 relative (measured)."""
    study, m = _model(DAMPED)
    ms = MotionSystem(m, "full", gravity=study.scene.analysis.gravity_m_s2)
    angles = 360.0 * np.arange(256) / 256
    steady = study.response(50.0, "full", angles_deg=angles, tol=1e-9).q
    scale = np.max(np.abs(steady))
    runs = {k: integrate(ms, CrankHistory.constant(50.0, 6), steps_per_revolution=k).last for k in (2048, 4096, 8192)}
    q = {k: r.q[:-1][:: k // 256] for k, r in runs.items()}
    assert np.allclose(np.exp(1j * runs[2048].theta[:-1][::8]), np.exp(1j * np.radians(angles)))  # the same angles
    err = {k: np.max(np.abs(x - steady)) / scale for k, x in q.items()}
    assert err[8192] < 2e-5  # measured 1.26e-5
    assert abs(np.log2(err[4096] / err[8192]) - 2.0) < 0.05
    r1, r2 = (4 * q[4096] - q[2048]) / 3, (4 * q[8192] - q[4096]) / 3
    assert np.max(np.abs((16 * r2 - r1) / 15 - steady)) / scale < 2e-6


def test_growth_inside_a_band_is_floquets_rate():
    """Undamped, 1 el/link, 1900 rad/s: max|μ| = 5.026 (real), max Re s = 488.26 1/s. The response's
    growth from revolution 10 to 20 at 1024 steps per revolution is that rate to 1e-3 (measured 3.6e-4;
    4.0e-3 at 256 steps, 1.1e-3 at 512)."""
    _, m = _model(UNDAMPED)
    fl = floquet_multipliers(PeriodicSystem(m, 1900.0, "full"))
    rate = float(np.max(fl.exponents.real))
    assert fl.max_abs > 5.0
    r = integrate(MotionSystem(m, "full"), CrankHistory.constant(1900.0, 20), steps_per_revolution=1024)
    norm = np.linalg.norm([e[0] for e in r.end_state], axis=1)
    growth = np.log(norm[19] / norm[9]) / (10 * 2 * np.pi / 1900.0)
    assert abs(growth / rate - 1.0) < 1e-3


def test_lone_rotating_beam_conserves_energy_at_second_order():
    """The undamped rotating cantilever in its link frame (constant M, skew C, symmetric K): TSALPHA2 at
    PETSc's default ρ∞ = 1 keeps H = ½η̇ᵀMη̇ + ½(η−η_s)ᵀK(η−η_s) to 1e-12 (measured 2.5e-14 to 6e-13)
    and its error against the matrix exponential falls at the observed order 2.03 (measured from 1024
    to 2048 steps; 2.33, 2.10 before)."""
    _, m = _model(CANTILEVER, 2)
    n = m.n_free
    ms = MotionSystem(m, "full", damping=False, basis=np.eye(n))
    M, C, K, f = ms.at(0.3, 20.0, 0.0)
    M2, C2, K2, _ = ms.at(2.1, 20.0, 0.0)
    assert np.max(np.abs(K - K2)) <= 1e-14 * np.max(np.abs(K)) and np.max(np.abs(C + C.T)) <= 1e-14 * np.max(np.abs(C))
    qs = np.linalg.solve(K, f)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    err = []
    for k in (51200, 102400, 204800):  # 512, 1024, 2048 steps over 0.01 revolution (ω_max h <= 0.06)
        rev = integrate(ms, CrankHistory.constant(20.0, 0.01), steps_per_revolution=k, start="zero").last
        e, v = rev.eta - qs, rev.eta_dot
        H = 0.5 * np.einsum("ki,ij,kj->k", v, M, v) + 0.5 * np.einsum("ki,ij,kj->k", e, K, e)
        assert np.max(np.abs(H - H[0])) <= 1e-12 * H[0]
        exact = (sla.expm(A * rev.t[-1]) @ np.concatenate([-qs, np.zeros(n)]))[:n] + qs
        err.append(np.max(np.abs(rev.eta[-1] - exact)) / np.max(np.abs(qs)))
    assert abs(np.log2(err[1] / err[2]) - 2.0) < 0.1


def test_bad_input_names_the_flag_before_any_work(tmp_path):
    r = fkev("runup", DAMPED, "--ramp", "0:x", "--duration", "-1", "-o", tmp_path / "r.h5")
    assert r.returncode == 2
    lines = problem_lines(r.stderr)
    assert any(ln.startswith("--ramp:") for ln in lines) and any(ln.startswith("--duration:") for ln in lines)
    assert not (tmp_path / "r.h5").exists()
    r = fkev("runup", DAMPED, "--speed", "0", "--revolutions", "-2", "--reduce", "auto")
    assert {ln.split(":")[0] for ln in problem_lines(r.stderr)} == {"--speed", "--revolutions", "--reduce"}
    with pytest.raises(SceneError, match="ramp"):
        study_runup(fk.load(DAMPED).scene, ramp=(1.0,), duration=1.0)
    with pytest.raises(SceneError, match="speed"):
        study_runup(fk.load(DAMPED).scene, speed=10.0, revolutions=1, ramp=(0.0, 1.0), duration=1.0)


def test_resumed_run_is_bit_identical(tmp_path):
    """Interrupted after a checkpoint and resumed: every number and array of the product equal."""
    scene = fk.load(DAMPED, elements=1).scene
    kw = dict(ramp=(0.0, 300.0), duration=0.05, segment_steps=300)
    whole = study_runup(scene, output=tmp_path / "whole.h5", **kw)

    class Stop(Exception):
        pass

    def stop(t, duration):
        if t > 0.6 * duration:
            raise Stop

    with pytest.raises(Stop):
        study_runup(scene, output=tmp_path / "part.h5", progress=stop, **kw)
    with h5py.File(tmp_path / "part.h5") as f:
        assert not f.attrs["complete"] and 0 < f.attrs["checkpoint_steps"] < whole.steps
    resumed = study_runup(scene, output=tmp_path / "part.h5", resume=True, **kw)
    assert resumed.as_dict() == whole.as_dict()
    with h5py.File(tmp_path / "whole.h5") as f, h5py.File(tmp_path / "part.h5") as g:
        for key in ("time_s", "speed_rad_s", "peak_deflection_m", "checkpoint_q", "checkpoint_q_dot"):
            assert np.array_equal(f[key][()], g[key][()], equal_nan=True)


def test_cli_json_keys(tmp_path):
    import json

    r = fkev("runup", DAMPED, "--elements", "1", "--speed", "300", "--revolutions", "3", "--json", "-q",
             "--plot", tmp_path / "r.png")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert len(d["time_s"]) == len(d["speed_rad_s"]) == 3 and d["speed_rad_s"] == [300.0] * 3
    assert set(d["links"]) == {"crank", "coupler", "follower"}
    assert all(len(v["peak_deflection_m"]) == len(v["peak_stress_pa"]) == 3 for v in d["links"].values())
    assert (tmp_path / "r.png").stat().st_size > 1000
