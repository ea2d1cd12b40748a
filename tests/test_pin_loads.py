"""Every pin and bearing (fkev loads, docs/response.md §1.1): the slider block as a body of its
own (wrist-pin force beside the guide reaction) against the exact slider acceleration of an
in-line slider-crank, Newton-Euler of the links without their blocks, and every pin's force in
the frames of the links it joins against the ground-frame force turned by the link's angle."""

import json
from dataclasses import replace

import numpy as np
from balance import newton_euler_of
from clitools import ROOT
from clitools import fkev as run_fkev

from fkev_slepc.model.joint_loads import joint_loads
from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.scene import load_scene

SLIDER = ROOT / "runs" / "slider-crank.toml"  # in-line, r = 0.045 m, L = 0.15 m, block 0.45 kg
R, L, M_BLOCK = 0.045, 0.15, 0.45
THETA = np.radians(np.arange(0.0, 360.0, 7.5))


def slider_exact(theta):
    """x(θ) = r cos θ + √(L² − r² sin² θ) of an in-line slider-crank: dx/dθ and d²x/dθ²."""
    c, s = np.cos(theta), np.sin(theta)
    D = np.sqrt(L**2 - R**2 * s**2)
    return -R * s - R**2 * s * c / D, -R * c - R**2 * (c**2 - s**2) / D - R**4 * s**2 * c**2 / D**3


def test_wrist_pin_is_the_block_mass_times_the_exact_slider_acceleration():
    """At constant Ω the wrist pin's force along the guide is m ẍ = m Ω² x''(θ) at every angle
    (1e-10), and pin force + guide reaction (along the guide's left normal) = the block's
    inertia force m a; the guide alone reads 0 N at the dead centres, the pin m r Ω² (1 + r/L)."""
    mech = build_mechanism(load_scene(SLIDER))
    omega = 314.16
    jl = joint_loads(mech, THETA, omega)
    pin, guide = jl.pin_force[:, 2], jl.guide_reaction[:, 2]
    _, xdd = slider_exact(THETA)
    scale = M_BLOCK * omega**2 * np.abs(xdd).max()
    assert np.abs(pin[:, 0] - M_BLOCK * omega**2 * xdd).max() <= 1e-10 * scale
    inertia = np.stack([M_BLOCK * omega**2 * xdd, np.zeros_like(xdd)], axis=-1)
    total = pin + guide[:, None] * np.array([0.0, 1.0])
    assert np.abs(total - inertia).max() <= 1e-10 * scale
    assert abs(guide[0]) <= 1e-10 * scale
    assert abs(np.hypot(*pin[0]) - M_BLOCK * R * omega**2 * (1 + R / L)) <= 1e-10 * scale
    assert np.isnan(jl.pin_force[:, :2]).all()  # revolute joints have no block


def test_links_without_their_blocks_satisfy_newton_euler():
    """The pins' forces on the links (bearing_force: at a slider the wrist pin's, reversed)
    balance the links' own inertia with the blocks taken off (slider mass 0), with crank
    acceleration and gravity, to 1e-9: the block is a body of its own."""
    sc = load_scene(SLIDER)
    mech = build_mechanism(sc)
    bare = build_mechanism(replace(sc, joints=tuple(replace(j, slider_mass=0.0) for j in sc.joints)))
    omega, alpha, g = 250.0, 3e4, (0.0, -9.81)
    jl = joint_loads(mech, THETA, omega, alpha, g)
    kin = solve_kinematics(bare, THETA)
    assert newton_euler_of(bare, kin, jl.bearing_force, jl.torque, omega, alpha, g) <= 1e-9
    assert newton_euler_of(bare, kin, jl.end_force, jl.torque, omega, alpha, g) > 1e-3  # the merged view does not


def test_link_frame_pin_forces_json_csv_archive_and_polar_figure(tmp_path):
    """fkev loads --json: joints.<name>.in_link.<link>.along_n/normal_n are the ground-frame pin
    force on that link turned by the link's angle (crank: θ; rod: the direction A -> P from the
    joint positions) to 1e-12; pin_fx_n/pin_fy_n at the slider; the same in CSV and HDF5."""
    import xarray as xr

    out, png, csv = tmp_path / "l.h5", tmp_path / "l.png", tmp_path / "l.csv"
    r = run_fkev("loads", SLIDER, "--speed", "314.16", "--angles", "0:360:15", "--json", "-o", out,
                 "--plot", png, "--polar", "link", "--csv", csv)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    theta = np.radians(d["crank_angle_deg"])
    kin = solve_kinematics(build_mechanism(load_scene(SLIDER)), theta)
    rod = kin.pos[:, 2] - kin.pos[:, 1]
    phi_rod = np.arctan2(rod[:, 1], rod[:, 0])
    A, P = d["joints"]["A"], d["joints"]["P"]
    on_crank = np.array([A["fx_n"], A["fy_n"]]).T  # the pin's force on the first end (crank.tip)
    on_rod_tip = -np.array([P["pin_fx_n"], P["pin_fy_n"]]).T
    for f, phi, got in ((on_crank, theta, A["in_link"]["crank"]), (-on_crank, phi_rod, A["in_link"]["rod"]),
                        (on_rod_tip, phi_rod, P["in_link"]["rod"])):
        along = np.cos(phi) * f[:, 0] + np.sin(phi) * f[:, 1]
        normal = -np.sin(phi) * f[:, 0] + np.cos(phi) * f[:, 1]
        scale = np.abs(f).max()
        assert np.abs(np.array(got["along_n"]) - along).max() <= 1e-12 * scale
        assert np.abs(np.array(got["normal_n"]) - normal).max() <= 1e-12 * scale
    assert P["pin_peak_n"] == max(P["pin_magnitude_n"]) and P["pin_peak_crank_angle_deg"] == 0.0
    assert A["peak_n"] == max(A["magnitude_n"]) and A["peak_crank_angle_deg"] in (0.0, 360.0)
    assert P["pin_magnitude_n"][0] > 2500.0 and abs(P["magnitude_n"][0]) < 1e-9  # TDC: pin loaded, guide not
    ds = xr.open_dataset(out, engine="h5netcdf")
    np.testing.assert_allclose(ds["pin_force_n"].sel(guide_joint="P", component="x").values, P["pin_fx_n"],
                               rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(ds["bearing_force_along_n"].sel(link_end="rod.tip").values,
                               P["in_link"]["rod"]["along_n"], rtol=1e-12, atol=1e-9)
    head = csv.read_text().splitlines()[0].split(",")
    assert {"P_pin_fx_n", "A_in_rod_along_n", "A_in_crank_normal_n"} <= set(head)
    assert png.stat().st_size > 10_000
    table = run_fkev("loads", SLIDER, "--speed", "314.16", "--angles", "0:360:90").stdout
    assert "wrist pin (link end on the block): peak |F| 2598.19 N at θ = 0°" in table


def test_polar_frame_is_checked():
    r = run_fkev("loads", SLIDER, "--plot", "x.png", "--polar", "rod")
    assert r.returncode == 2 and "--polar" in r.stderr
