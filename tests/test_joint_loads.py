"""Kinetostatics as a result (fkev loads, Study.loads; docs/response.md §1): the exposed joint
forces and torque against Newton-Euler on every link and the power balance, from first
principles (tests/balance.py: elements as uniform rods, particles as point masses)."""

import json

import numpy as np
import pytest
from balance import _pieces, kinetic_energy, newton_euler_of
from builders import bahgat_willmert, six_bar, turcic_midha
from clitools import ROOT
from clitools import fkev as run_fkev

from fkev_slepc.model.joint_loads import joint_loads
from fkev_slepc.model.kinematics import point_local, solve_kinematics
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.scene import SceneError, load_scene

THETA = np.radians(np.arange(0.0, 360.0, 15.0))
SLIDER = ROOT / "runs" / "slider-crank.toml"
BUILDERS = {"bahgat_willmert": bahgat_willmert, "turcic_midha": turcic_midha, "six_bar": six_bar,
            "slider_crank": lambda: load_scene(SLIDER)}


@pytest.fixture(params=list(BUILDERS), scope="module")
def mech(request):
    return build_mechanism(BUILDERS[request.param]())


@pytest.mark.parametrize("omega,alpha,g", [(500.0, 0.0, (0, 0)), (300.0, 4e4, (0, 0)), (150.0, -2e4, (1.5, -9.81))])
def test_exposed_forces_satisfy_newton_euler(mech, omega, alpha, g):
    """ΣF + Σ m g = Σ m a and the moment balance on every link, from the per-link-point forces
    and the torque that fkev loads reports (gravity and crank acceleration included)."""
    kin = solve_kinematics(mech, THETA)
    L = joint_loads(mech, THETA, omega, alpha, g)
    assert newton_euler_of(mech, kin, L.end_force, L.torque, omega, alpha, g) <= 1e-9


def _potential(mech, theta, g):
    kin = solve_kinematics(mech, theta)
    link, local, mass, _ = _pieces(mech)
    return -(mass * (point_local(kin, link, local)[0] @ np.asarray(g, float))).sum(-1)


@pytest.mark.parametrize("g", [(0.0, 0.0), (0.0, -9.81)])
def test_driving_power_equals_rate_of_energy(mech, g):
    """τΩ = d(E_k + E_p)/dt at constant crank speed, E from the elements and particles one by one,
    differentiated by central differences (the result's own energy_rate agrees too)."""
    omega, h = 120.0, 1e-5
    L = joint_loads(mech, THETA, omega, 0.0, g)
    E = lambda th: kinetic_energy(mech, th, omega) + _potential(mech, th, g)  # noqa: E731
    dE = (E(THETA + h) - E(THETA - h)) / (2 * h) * omega
    scale = np.abs(L.power).max()
    np.testing.assert_allclose(L.power, dE, rtol=1e-6, atol=1e-6 * scale)
    assert L.power_residual < 1e-12


def test_joint_reactions_and_axial_force(mech):
    """A ground joint's force is the sum over its link points; a pin's two ends get opposite
    forces; the axial force at each link end equals minus the end force along the link (no
    particle at the very end), and is continuous between elements without a particle."""
    L = joint_loads(mech, THETA, 400.0, 1e4, (0.0, -9.81))
    for jj, here in enumerate(L.attach):
        ends = [L.end_force[:, lk, k] for lk, k in here]
        if L.joint_ground[jj]:
            np.testing.assert_allclose(L.joint_force[:, jj], sum(ends), rtol=1e-13)
        elif len(here) == 2 and np.isnan(L.guide_reaction[:, jj]).all():
            np.testing.assert_allclose(ends[0], -ends[1], atol=1e-12 * np.abs(ends[0]).max())
    N = L.axial_force()
    for lk in range(len(L.link_names)):
        sel = np.flatnonzero((L.elem_link == lk) & L.elem_axis)
        root = -L.end_along[:, lk, 0]
        scale = np.abs(N[:, sel]).max()
        np.testing.assert_allclose(N[:, sel[0], 0], root, atol=1e-9 * scale)


def test_cli_json_csv_archive_and_figure(tmp_path):
    import xarray as xr

    out, png, csv = tmp_path / "l.h5", tmp_path / "l.png", tmp_path / "l.csv"
    r = run_fkev("loads", SLIDER, "--speed", "314.16", "--angles", "0:360:30", "--json", "-o", out,
                 "--plot", png, "--csv", csv)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["crank_angle_deg"][:3] == [0.0, 30.0, 60.0]
    assert set(d["joints"]) == {"O", "A", "P"} and len(d["joints"]["A"]["fx_n"]) == 13
    assert len(d["driving_torque_n_m"]) == 13 and d["power_residual"] < 1e-12
    mech = build_mechanism(load_scene(SLIDER))
    L = joint_loads(mech, np.radians(d["crank_angle_deg"]), 314.16)
    np.testing.assert_allclose(d["joints"]["O"]["fy_n"], L.joint_force[:, 0, 1], rtol=1e-12, atol=1e-9)
    ds = xr.open_dataset(out, engine="h5netcdf")
    np.testing.assert_allclose(ds["driving_torque_n_m"].values, d["driving_torque_n_m"], rtol=1e-12, atol=1e-12)
    assert ds["joint_force_n"].sel(joint="A", component="x").shape == (13,)
    assert ds["joint_force_n"].attrs["units"] == "N" and ds.attrs["speed_rad_s"] == 314.16
    assert png.stat().st_size > 10_000
    assert csv.read_text().splitlines()[0].startswith("crank_angle_deg,driving_torque_n_m,power_w,O_fx_n")


@pytest.mark.parametrize("flags,field", [(["--speed", "nan"], "--speed"), (["--gravity", "0,x"], "--gravity"),
                                         (["--angles", "0,500x"], "--angles")])
def test_cli_bad_input_names_the_flag(flags, field):
    r = run_fkev("loads", SLIDER, *flags)
    assert r.returncode == 2 and field in r.stderr, r.stderr


def test_api_refuses_unassemblable_angle():
    from builders import STEEL, four_bar

    from fkev_slepc.api import Study

    st = Study(four_bar((0.3, 0.2, 0.2), 0.254, STEEL))
    with pytest.raises(SceneError, match="angles_deg.*cannot be assembled at 180"):
        st.loads(100.0, [0.0, 180.0])
