"""The drive's rigid steady cycle (docs/theory.md §20, issue 37): J(θ) against the kinetic energy of
the links computed element by element, J′ against differences, the load torque against virtual
work, the limits of a stiff motor and of a huge flywheel against the constant-speed kinetostatics,
δ against the energy method and against a time integration by scipy, the power balance at every
angle against fkev loads, the flywheel for a requested δ, the [drive] errors and ``fkev drive``."""

import json
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import fkev_slepc as fk
from clitools import fkev, problem_lines
from fkev_slepc.api.drive import study_drive
from fkev_slepc.archive.verify import verify
from fkev_slepc.model.drive_cycle import DriveProblem, flywheel_for
from fkev_slepc.model.drive_inertia import linkage_inertia
from fkev_slepc.model.joint_loads import joint_loads
from fkev_slepc.model.kinematics import point_local, solve_kinematics
from fkev_slepc.model.kinetostatics import solve_loads
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.process_loads import process_kinetostatics
from fkev_slepc.scene import SceneError, load_scene, parse_scene

ROOT = Path(__file__).resolve().parents[1]
DRIVE_SCENE = ROOT / "runs/packaging-slider-crank-drive.toml"
FULL_TURN = ["packaging-slider-crank.toml", "slider-crank.toml", "bahgat-willmert-1976.toml", "turcic-midha-1984.toml",
             "stephenson-six-bar.toml", "six-bar-two-loop.toml", "flat-rod-slider-crank.toml"]
GRAVITY = (0.0, -9.81)


def with_drive(text: str, **keys) -> str:
    """A scene text with its [drive] replaced by ``keys``."""
    body = text.split("\n[drive]")[0]
    return body + "\n[drive]\n" + "".join(f"{k} = {v!r}\n" for k, v in keys.items())


@pytest.fixture(scope="module")
def scene():
    return load_scene(DRIVE_SCENE)


@pytest.fixture(scope="module")
def heavy():
    """The drive scene with gravity and a lighter flywheel (δ ≈ 0.15): every term matters."""
    text = DRIVE_SCENE.read_text().replace("flywheel_inertia_kg_m2 = 0.03", "flywheel_inertia_kg_m2 = 0.002")
    text = text.replace("[analysis]\n", "[analysis]\ngravity_m_s2 = [0.0, -9.81]\n")
    return parse_scene(text, "heavy.toml")


def kinetic_energy(mech, theta):
    """2T/θ̇² element by element: a uniform rod with end velocities v_a, v_b has T = m/6 (v_a² + v_a·v_b + v_b²);
    a particle ½ m v² + ½ I φ̇² (θ̇ = 1, velocities from the kinematics' first derivatives)."""
    kin = solve_kinematics(mech, theta)
    ends = mech.node_local[mech.elem_nodes]  # (n_el, 2 ends, 2)
    va = point_local(kin, mech.elem_link, ends[:, 0])[1]
    vb = point_local(kin, mech.elem_link, ends[:, 1])[1]
    m = mech.elem_rho_a * mech.elem_length
    rods = (m / 6.0 * ((va * va).sum(-1) + (va * vb).sum(-1) + (vb * vb).sum(-1))).sum(-1)
    # (no separate spin term: a rigid rod's velocity is linear along it, its rotation is in v_b − v_a)
    vp = point_local(kin, mech.mass_link, mech.mass_local)[1]
    parts = (0.5 * mech.mass_value * (vp * vp).sum(-1) + 0.5 * mech.mass_inertia * kin.dphi[:, mech.mass_link] ** 2).sum(-1)
    return 2.0 * (rods + parts)


@pytest.mark.parametrize("name", FULL_TURN)
def test_inertia_is_twice_the_kinetic_energy(name):
    mech = build_mechanism(load_scene(ROOT / "runs" / name))
    theta = np.radians(np.arange(0.0, 360.0, 7.5))
    li = linkage_inertia(mech, theta)
    twice = kinetic_energy(mech, theta)
    assert np.max(np.abs(li.inertia - twice)) <= 1e-12 * twice.max()
    # and the kinetostatics of fkev loads: per-α torque J_L, per-Ω² torque ½J_L′ (§20.2)
    loads = solve_loads(mech, solve_kinematics(mech, theta))
    assert np.max(np.abs(loads.torque[1] - li.inertia)) <= 1e-12 * twice.max()
    assert np.max(np.abs(loads.torque[0] - 0.5 * li.inertia_slope)) <= 1e-11 * np.abs(li.inertia_slope).max()


@pytest.mark.parametrize("name", FULL_TURN[:4])
def test_inertia_slope_is_the_derivative(name):
    mech = build_mechanism(load_scene(ROOT / "runs" / name))
    theta, h = np.radians(np.arange(3.0, 360.0, 11.0)), 1e-3
    J = lambda t: linkage_inertia(mech, t).inertia  # noqa: E731
    d1 = (J(theta + h) - J(theta - h)) / (2 * h)
    d2 = (J(theta + 2 * h) - J(theta - 2 * h)) / (4 * h)
    richardson = (4 * d1 - d2) / 3  # error O(h⁴) ~ 1e-12
    slope = linkage_inertia(mech, theta).inertia_slope
    assert np.max(np.abs(slope - richardson)) <= 1e-9 * np.abs(slope).max()


def test_load_torque_is_minus_the_virtual_work(heavy):
    mech = build_mechanism(heavy)
    theta = np.radians(np.arange(0.0, 360.0, 2.5))
    kin = solve_kinematics(mech, theta)
    _, dG, _ = point_local(kin, np.arange(mech.n_link), mech.body_centroid)
    work = process_kinetostatics(mech, kin).power_per_speed + (mech.body_mass * (dG @ np.array(GRAVITY))).sum(-1)
    li = linkage_inertia(mech, theta, GRAVITY)
    assert np.max(np.abs(li.load_torque + work)) <= 1e-12 * np.abs(work).max()
    assert np.max(np.abs(li.load_torque - joint_loads(mech, theta, 0.0, 0.0, GRAVITY).torque)) == 0.0


def constant_speed_torque(mech, cycle, speed, gravity=(0.0, 0.0)):
    return joint_loads(mech, cycle.theta, speed, 0.0, gravity).torque


def test_stiff_motor_turns_the_crank_at_its_no_load_speed(scene):
    """Slope 1e9 N m s: ω = ω_0/n − O(T/(n²k)) everywhere, and the crank sees the loads of constant speed."""
    w0 = 150.0
    drive = replace(scene.drive, speeds=(0.0, w0), torques=(1e9 * w0, 0.0))
    mech = build_mechanism(scene)
    cycle = DriveProblem(mech).solve(drive)
    n = drive.gear_ratio
    assert cycle.fluctuation < 1e-8
    assert np.max(np.abs(cycle.speed / (w0 / n) - 1.0)) < 1e-8
    tau = constant_speed_torque(mech, cycle, w0 / n)
    assert np.max(np.abs(cycle.crank_torque - tau)) <= 1e-8 * np.abs(tau).max()


def test_huge_flywheel_keeps_the_speed_constant(scene):
    mech = build_mechanism(scene)
    drive = replace(scene.drive, flywheel_inertia=1e8)
    problem = DriveProblem(mech)
    cycle = problem.solve(drive)
    assert cycle.fluctuation < 1e-8
    assert abs(cycle.mean_speed / cycle.reference_speed - 1.0) < 1e-8
    assert np.max(np.abs(cycle.speed / cycle.reference_speed - 1.0)) < 1e-8
    tau = constant_speed_torque(mech, cycle, cycle.reference_speed)
    assert np.max(np.abs(cycle.crank_torque - tau)) <= 1e-8 * np.abs(tau).max()
    # the motor then gives the mean load torque, constant (§20.3)
    mean_load = problem.mean(problem.link.load_torque)
    assert np.max(np.abs(drive.gear_ratio * cycle.motor_torque / mean_load - 1.0)) < 1e-8


def test_fluctuation_tends_to_the_energy_method(scene):
    """|δ/δ_E − 1| = O(δ): it falls with δ, 10x per 10x of flywheel."""
    problem = DriveProblem(build_mechanism(scene))
    errors = []
    for flywheel in (1.0, 10.0, 100.0):
        c = problem.solve(replace(scene.drive, flywheel_inertia=flywheel))
        errors.append(abs(c.fluctuation / c.energy_estimate - 1.0))
        assert errors[-1] < 10.0 * c.fluctuation
    assert errors[1] < 0.2 * errors[0] and errors[2] < 0.2 * errors[1]


def kinetostatic_rhs(mech, drive, gravity):
    """The rigid equation from fkev loads alone: α = (n T_m − τ(ω, 0)) / (J_d + J_L), J_L = the per-α torque."""
    n, Jd = drive.gear_ratio, drive.inertia

    def rhs(t, y):
        kin = solve_kinematics(mech, np.atleast_1d(y[0]))
        parts = solve_loads(mech, kin).torque
        loads = joint_loads(mech, kin.theta, 0.0, 0.0, gravity, kin=kin).torque[0]
        tau0 = parts[0][0] * y[1] ** 2 + loads
        return [y[1], (n * float(drive.motor_torque(n * y[1])) - tau0) / (Jd + parts[1][0])]

    return rhs


def test_steady_cycle_against_time_integration(heavy):
    mech = build_mechanism(heavy)
    cycle = DriveProblem(mech, GRAVITY).solve(heavy.drive)
    assert cycle.fluctuation > 0.1  # a strongly fluctuating case
    rhs = kinetostatic_rhs(mech, heavy.drive, GRAVITY)
    turn = lambda t, y: y[0] - 2 * np.pi  # noqa: E731
    turn.terminal = True
    extreme = lambda t, y: rhs(t, y)[1]  # noqa: E731  (α = 0)
    sol = solve_ivp(rhs, (0.0, 2 * cycle.period), [0.0, cycle.speed[0]], method="DOP853", rtol=1e-12, atol=1e-12,
                    dense_output=True, events=(turn, extreme))
    period = sol.t_events[0][0]
    assert abs(period / cycle.period - 1.0) < 1e-10
    assert abs(sol.y_events[0][0][1] / cycle.speed[0] - 1.0) < 1e-10  # periodic: back to its start
    y = sol.sol(cycle.time)
    assert np.max(np.abs(y[0] - cycle.theta)) < 1e-9
    assert np.max(np.abs(y[1] - cycle.speed)) < 1e-9 * cycle.mean_speed
    w = sol.y_events[1][:, 1]
    delta = (w.max() - w.min()) / (2 * np.pi / period)
    assert abs(cycle.fluctuation / delta - 1.0) < 1e-8


def test_driving_torque_balances_the_energy_rate_and_process_power(heavy):
    mech = build_mechanism(heavy)
    c = DriveProblem(mech, GRAVITY).solve(heavy.drive)
    d = heavy.drive
    rate, process, torque = (np.empty(c.theta.size) for _ in range(3))
    for k in range(c.theta.size):
        jl = joint_loads(mech, c.theta[k : k + 1], c.speed[k], c.accel[k], GRAVITY)
        rate[k], process[k], torque[k] = jl.energy_rate[0], jl.process_power[0], jl.torque[0]
    motor_power = d.gear_ratio * c.motor_torque * c.speed
    drive_side = d.inertia * c.accel * c.speed  # d(½ J_d ω²)/dt
    assert np.max(np.abs(motor_power - drive_side - (rate - process))) <= 1e-10 * np.abs(motor_power).max()
    assert np.max(np.abs(c.crank_torque - torque)) <= 1e-10 * np.abs(torque).max()


def test_flywheel_for_a_requested_fluctuation(scene):
    problem = DriveProblem(build_mechanism(scene))
    steps = []
    J_f, cycle = flywheel_for(problem, scene.drive, 0.01, progress=lambda *a: steps.append(a))
    assert abs(cycle.fluctuation / 0.01 - 1.0) <= 1e-10
    assert cycle.drive.flywheel_inertia == J_f and 0 < len(steps) <= 8
    again = problem.solve(replace(scene.drive, flywheel_inertia=J_f))
    assert again.fluctuation == pytest.approx(0.01, rel=1e-10)
    # δ above the bare machine's: no flywheel needed
    assert flywheel_for(problem, scene.drive, 0.9)[0] == 0.0


BAD = [
    ({"motor_stall_torque_n_m": -3.0, "motor_no_load_speed_rpm": 1500.0}, "drive.motor_stall_torque_n_m", "-3.0"),
    ({"motor_stall_torque_n_m": 3.0}, "drive.motor_no_load_speed_rpm", "missing"),
    ({"motor_stall_torque_n_m": 3.0, "motor_no_load_speed_rpm": 1500.0, "motor_no_load_speed_rad_s": 150.0},
     "drive.motor_no_load_speed_rad_s", "not both"),
    ({"motor_torque_table": [[0.0, 5.0], [100.0, 3.0], [90.0, 1.0]]}, "drive.motor_torque_table[2][0]", "90.0"),
    ({"motor_torque_table": [[0.0, 5.0]]}, "drive.motor_torque_table", "at least two"),
    ({"motor_torque_table": [[0.0, 5.0], [1.0, 1.0]], "motor_stall_torque_n_m": 4.0}, "drive.motor_stall_torque_n_m",
     "not both"),
    ({"motor_stall_torque_n_m": 3.0, "motor_no_load_speed_rpm": 1500.0, "flywheel_inertia_kg_m2": -1.0},
     "drive.flywheel_inertia_kg_m2", "-1.0"),
    ({"motor_stall_torque_n_m": 3.0, "motor_no_load_speed_rpm": 1500.0, "gear_ratio": 0.0}, "drive.gear_ratio", "0.0"),
    ({"motor_stall_torque_n_m": 3.0, "motor_no_load_speed_rpm": 1500.0, "shaft_damping_n_m_s_per_rad": 1.0},
     "drive.shaft_damping_n_m_s_per_rad", "shaft_stiffness"),
    ({"motor_stall_torque_n_m": 3.0, "motor_no_load_speed_rpm": 1500.0, "shaft_stiffness_n_m_per_rad": "stiff"},
     "drive.shaft_stiffness_n_m_per_rad", "'stiff'"),
    ({"motor_stall_torque_n_m": 3.0, "motor_no_load_speed_rpm": 1500.0, "flywheel_kg_m2": 1.0}, "drive.flywheel_kg_m2",
     "did you mean"),
]


@pytest.mark.parametrize("keys, path, word", BAD, ids=[b[1] for b in BAD])
def test_bad_drive_is_refused_naming_the_field(keys, path, word):
    with pytest.raises(SceneError) as err:
        parse_scene(with_drive(DRIVE_SCENE.read_text(), **keys), "bad.toml")
    line = next(str(p) for p in err.value.problems if p.path == path)
    assert word in line, line


def test_a_motor_too_weak_or_rising_is_refused_before_the_cycle(scene):
    weak = parse_scene(with_drive(DRIVE_SCENE.read_text(), motor_stall_torque_n_m=5.0, motor_no_load_speed_rpm=1500.0))
    with pytest.raises(SceneError) as err:
        study_drive(weak)
    assert err.value.problems[0].path == "drive.motor_stall_torque_n_m" and "mean load torque" in str(err.value)
    rising = parse_scene(with_drive(DRIVE_SCENE.read_text(), motor_torque_table=[[0.0, 1.0], [200.0, 30.0]]))
    with pytest.raises(SceneError) as err:
        study_drive(rising)
    assert err.value.problems[0].path == "drive.motor_torque_table"
    with pytest.raises(SceneError, match="no \\[drive\\] section"):
        study_drive(load_scene(ROOT / "runs/packaging-slider-crank.toml"))


def test_a_drive_section_changes_no_other_result(scene):
    """The constant-speed analyses ignore [drive] (item 3 of issue 37 is not built): bit-identical loads."""
    plain = load_scene(ROOT / "runs/packaging-slider-crank.toml")
    assert plain.drive is None and scene.drive is not None
    a = joint_loads(build_mechanism(plain), np.radians([0.0, 77.0]), 170.0).torque
    b = joint_loads(build_mechanism(scene), np.radians([0.0, 77.0]), 170.0).torque
    assert np.array_equal(a, b)


KEYS = {"crank_angle_deg", "speed_rad_s", "accel_rad_s2", "time_s", "mean_speed_rad_s", "coefficient_of_fluctuation",
        "motor_torque_n_m", "flywheel_for_fluctuation_kg_m2"}


def test_fkev_drive_json_archive_and_figure(tmp_path):
    out, fig = tmp_path / "drive.h5", tmp_path / "drive.png"
    r = fkev("drive", DRIVE_SCENE, "--fluctuation", "0.02", "--json", "-o", out, "--plot", fig)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert KEYS <= set(d)
    api = fk.load(DRIVE_SCENE).drive(fluctuation=0.02).as_dict()  # Study.drive: the same numbers
    assert set(api) == set(d) and api["speed_rad_s"] == d["speed_rad_s"]
    assert api["flywheel_for_fluctuation_kg_m2"] == d["flywheel_for_fluctuation_kg_m2"]
    n = len(d["crank_angle_deg"])
    assert n >= 360 and all(len(d[k]) == n for k in ("speed_rad_s", "accel_rad_s2", "time_s", "motor_torque_n_m"))
    assert d["coefficient_of_fluctuation"] == pytest.approx(
        (max(d["speed_rad_s"]) - min(d["speed_rad_s"])) / d["mean_speed_rad_s"], rel=1e-3)
    assert fig.stat().st_size > 10_000
    check = verify(out)
    assert check.ok and check.complete, check.summary()
    with h5py.File(out, "r") as f:
        assert np.allclose(f["speed_rad_s"][()], d["speed_rad_s"], rtol=0, atol=0)
        assert f.attrs["flywheel_for_fluctuation_kg_m2"] == d["flywheel_for_fluctuation_kg_m2"]
    with h5py.File(out, "r+") as f:  # one value changed: the checksum says so
        f["speed_rad_s"][3] += 1e-9
    assert not verify(out).ok


def test_fkev_drive_refuses_bad_flags_and_scenes_without_a_drive():
    r = fkev("drive", DRIVE_SCENE, "--fluctuation", "1.5")
    assert r.returncode == 2 and problem_lines(r.stderr)[0].startswith("--fluctuation: must be > 0 and < 1 (got 1.5)")
    r = fkev("drive", ROOT / "runs/packaging-slider-crank.toml")
    assert r.returncode == 2 and problem_lines(r.stderr)[0].startswith("drive: missing")
