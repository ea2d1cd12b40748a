"""Eigenvalue sensitivities (solve/sensitivity.py) against central differences of the eigenvalues,
and a closed form: with one material, every frequency at rest scales like sqrt(E/ρ)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import fkev_slepc as fk
from fkev_slepc.scene import SceneError
from fkev_slepc.solve import sensitivity as sens
from clitools import fkev

RUNS = Path(__file__).resolve().parents[1] / "runs"
BW = RUNS / "bahgat-willmert-1976.toml"
SC = RUNS / "slider-crank-benchmark.toml"


def central(study, key, p, h, angle, speed, case):
    up = study.replace(key, p + h).point(angle, speed, case).eigenvalues
    down = study.replace(key, p - h).point(angle, speed, case).eigenvalues
    return (up - down) / (2 * h)


@pytest.mark.parametrize("scene, key, angle, speed, h", [
    (BW, "links[1].length_m", 10, 1000, 1e-5),                 # the coupler: kinematics and mesh move
    (BW, "joints[O2].position_m[0]", 10, 1000, 1e-5),          # a ground pivot: kinematics only
    (BW, "link_defaults.density_kg_m3", 10, 1000, 1e-2),
    (BW, "driver.acceleration_rad_s2", 10, 1000, 10.0),        # 0 in the scene: a step of its own
    (SC, "links[rod].length_m", 30, 150, 1e-5),                # SLEPc engine, a prismatic joint
    (RUNS / "stephenson-six-bar.toml", "links[4].segments[1].area_m2", 10, 100, 2e-8),  # inherited from defaults
])
def test_adjoint_equals_central_differences_of_the_eigenvalues(scene, key, angle, speed, h):
    study = fk.load(scene)
    r = study.point(angle, speed, "full")
    s = r.sensitivity(key)
    assert s.method == "adjoint"
    fd = central(study, key, s.value, h, angle, speed, "full")
    assert np.abs(s.eigenvalue - fd).max() <= 1e-5 * np.abs(fd).max()
    df, dz = sens.mode_derivatives(r.eigenvalues, fd)
    np.testing.assert_allclose(s.frequency_hz, df, rtol=0, atol=1e-5 * np.abs(df).max())
    np.testing.assert_allclose(s.damping_ratio, dz, rtol=0, atol=1e-5 * np.abs(dz).max() + 1e-12)


@pytest.mark.parametrize("key, h", [("speed_rad_s", 1e-2), ("angle_deg", 1e-4)])
def test_the_point_own_speed_and_angle(key, h):
    """d/dΩ (the Campbell slope) and d/dθ at a point, against central differences of point solves."""
    study = fk.load(BW)
    r = study.point(10, 1000, "full")
    s = r.sensitivity(key)
    at = {"speed_rad_s": lambda d: study.point(10, 1000 + d, "full"),
          "angle_deg": lambda d: study.point(10 + d, 1000, "full")}
    fd = (at[key](h).eigenvalues - at[key](-h).eigenvalues) / (2 * h)
    assert s.method == "adjoint" and s.value == {"speed_rad_s": 1000.0, "angle_deg": 10.0}[key]
    assert np.abs(s.eigenvalue - fd).max() <= 1e-5 * np.abs(fd).max()
    if key == "speed_rad_s":  # the structure does not depend on speed
        assert np.all(study.point(10, 1000, "structure").sensitivity(key).eigenvalue == 0)


def test_frequencies_at_rest_scale_like_the_root_of_e_over_rho():
    """BW: one material, no lumped masses: f ∝ sqrt(E/ρ), so (p/f) df/dp = +1/2 for E, -1/2 for ρ."""
    r = fk.load(BW).point(10, 0, "structure")
    np.testing.assert_allclose(r.sensitivity("link_defaults.youngs_modulus_pa").relative_frequency, 0.5, atol=1e-8)
    np.testing.assert_allclose(r.sensitivity("link_defaults.density_kg_m3").relative_frequency, -0.5, atol=1e-8)


def test_damping_from_zero_is_a_forward_difference():
    """β = 0 has no β - h: forward difference; Rayleigh damping is linear in β, so ζ grows like
    β·ω/2 for a mode at rest: dζ/dβ = ω/2 = π f."""
    r = fk.load(BW).point(10, 0, "structure")
    s = r.sensitivity("damping.stiffness_proportional_s")
    assert s.method.startswith("adjoint (forward")
    np.testing.assert_allclose(s.damping_ratio, np.pi * r.frequency_hz, rtol=1e-7)


def test_mesh_changing_keys_difference_whole_points(monkeypatch):
    """Where the DOFs would not mean the same at p ± h the whole point is differenced; both routes agree."""
    r = fk.load(BW).point(10, 500, "full")
    adjoint = r.sensitivity("links[1].length_m")
    monkeypatch.setattr(sens, "same_mesh", lambda a, b: False)
    points = r.sensitivity("links[1].length_m")
    assert points.method.startswith("points")
    assert np.abs(points.eigenvalue - adjoint.eigenvalue).max() <= 1e-5 * np.abs(adjoint.eigenvalue).max()


@pytest.mark.parametrize("key, line", [
    ("links[1].elements", "links[1].elements: is an integer setting (got 2): no derivative"),
    ("links[9].length_m", "links[9]: no such item (links has 3: 0-2)"),
    ("title", "title: is not a number"),
    ("analysis.modes", "analysis.modes: is an integer setting (got 4): no derivative"),
])
def test_bad_keys_are_named(key, line):
    r = fk.load(BW).point(10, 0, "structure")
    with pytest.raises(SceneError) as exc:
        r.sensitivity(key)
    assert line in str(exc.value)


def test_cli_point_sensitivity_json():
    out = fkev("point", BW, "--angle", "10", "--speed", "1000", "--case", "full", "--json",
               "--sensitivity", "links[1].length_m", "--sensitivity", "link_defaults.youngs_modulus_pa")
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)["sensitivity"]
    assert set(got) == {"links[1].length_m", "link_defaults.youngs_modulus_pa"}
    want = fk.load(BW).point(10, 1000, "full").sensitivity("links[1].length_m")
    np.testing.assert_allclose(got["links[1].length_m"]["frequency_hz"], want.frequency_hz, rtol=1e-9)
    np.testing.assert_allclose(got["links[1].length_m"]["damping_ratio"], want.damping_ratio, rtol=1e-9)
    bad = fkev("point", BW, "--sensitivity", "links[1].lenght_m")
    assert bad.returncode == 2 and "links[1].lenght_m" in bad.stderr
