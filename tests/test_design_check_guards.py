"""``fkev design-check`` refuses before any solve what ``fkev response`` refuses (issue 36): the mesh
size, operators that overflow, a CSV path that cannot be written, --json with --csv - on one stdout,
names --tol as the flag, and a fatigue factor from part of the revolution; a safety factor below 1
fails the check (exit 3)."""

from __future__ import annotations

import json

import pytest

from clitools import ROOT, fkev

SCENE = ROOT / "runs" / "slider-crank-design.toml"


@pytest.mark.parametrize("args, words", [
    (["--json", "--csv", "-"], "--csv: '-' (stdout) with --json would mix CSV into the JSON"),
    (["--csv", "{tmp}/no/such/dir/x.csv"], "does not exist (create it first)"),
    (["--csv", "{tmp}"], "is a directory"),
    (["--elements", "100000"], "--elements: 600000 free DOFs exceed"),
    (["--speed", "1e155"], "--speed: case full at 1e+155 rad/s: C has entries up to"),
    (["--tol", "0"], "--tol: must be in (0, 1) (got 0.0)"),
])
def test_refused_before_work_with_the_flag_named(tmp_path, args, words):
    r = fkev("design-check", SCENE, *(a.format(tmp=tmp_path) for a in args), timeout=60)
    assert r.returncode == 2, r.stdout + r.stderr
    assert words in r.stderr
    assert r.stdout == ""  # nothing solved, nothing printed
    assert not list(tmp_path.rglob("*.csv"))


def test_the_same_oversize_mesh_is_refused_by_fkev_response_in_the_same_words():
    a = fkev("design-check", SCENE, "--elements", "100000", timeout=60)
    b = fkev("response", SCENE, "--elements", "100000", "--speed", "100", timeout=60)
    assert a.returncode == b.returncode == 2
    line = next(ln for ln in a.stderr.splitlines() if "--elements" in ln)
    assert line in b.stderr.splitlines()


SMALL = ("--elements", "2", "--angles", "0:330:30", "--harmonics", "8")  # 12 angles round the revolution


@pytest.mark.parametrize("angles, gap", [("10", "360"), ("0:30:5", "330"), ("0:300:60", "60")])
def test_a_fatigue_factor_from_part_of_the_revolution_is_refused(angles, gap):
    """σm and σa are the mean and half range over the angles: one angle gave σa = 0 and a factor of
    4.93 where the whole cycle gives 2.42 (issue 36). Refused before any solve, --angles named."""
    r = fkev("design-check", SCENE, "--angles", angles, timeout=60)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"--angles: the fatigue factor needs σm and σa over the whole revolution: the angles leave a gap of " \
           f"{gap} deg" in r.stderr
    assert r.stdout == ""


def test_without_fatigue_strengths_part_of_the_revolution_is_a_peak_check(tmp_path):
    """No endurance_pa: no fatigue factor, so one angle is a legitimate peak-stress check."""
    scene = tmp_path / "no-endurance.toml"
    scene.write_text(SCENE.read_text().replace("endurance_pa = 3.1e8\n", ""))
    r = fkev("design-check", scene, *SMALL[:2], "--angles", "10", "--harmonics", "8", "--json", timeout=120)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert all(lk["fatigue_sf"] is None and lk["static_sf"] > 1 for lk in d["links"].values())


def test_a_safety_factor_below_1_fails_the_check_with_exit_3_and_says_which(tmp_path):
    """A yield strength of 30 MPa under the crank's ~48 MPa: static SF = S_y / peak|σ| < 1 is a
    failed check (exit 3, the link and factor on stderr), the table still printed; the rod passes."""
    scene = tmp_path / "weak.toml"
    scene.write_text(SCENE.read_text().replace("yield_pa = 5.30e8", "yield_pa = 3.0e7"))
    r = fkev("design-check", scene, *SMALL, "--json", timeout=120)
    assert r.returncode == 3, r.stdout + r.stderr
    d = json.loads(r.stdout)
    crank, rod = d["links"]["crank"], d["links"]["rod"]
    assert crank["static_sf"] == pytest.approx(3.0e7 / crank["peak_stress_pa"], rel=1e-12) and crank["static_sf"] < 1
    assert rod["static_sf"] > 1
    assert d["failures"] == [f"link crank: static SF {crank['static_sf']:.3g} < 1"]
    assert f"error: link crank: static SF {crank['static_sf']:.3g} < 1" in r.stderr
    assert "link rod" not in r.stderr
    text = fkev("design-check", scene, *SMALL, timeout=120)
    assert text.returncode == 3 and "static SF" in text.stdout  # the table is printed before the verdict


def test_a_design_study_with_stress_refuses_part_of_the_revolution_too(tmp_path):
    """``fkev design --stress`` computes the same fatigue factor at every design point: the same
    refusal, before the sweep, nothing written."""
    out = tmp_path / "d.h5"
    r = fkev("design", SCENE, "--set", "links[rod].section.width_m=0.006", "--speeds", "100", "--cases", "full",
             "--angles", "0:90:30", "--modes", "1", "--stress", "--harmonics", "8", "-o", out, timeout=60)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "--angles: the fatigue factor needs σm and σa over the whole revolution: the angles leave a gap of " \
           "270 deg" in r.stderr
    assert not list(tmp_path.iterdir())
