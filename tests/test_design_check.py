"""The design check (design/check.py, design/fatigue.py, model/buckling.py, cli/design_check.py;
docs/design.md): fatigue factors against the hand formulas from the tool's own σ_m, σ_a, the
weak-axis Euler margin of the slider-crank rod by hand, and the peak stress equal to
`fkev response` at the same point."""

import csv
import io
import json
import math

import numpy as np
import pytest
from clitools import ROOT, fkev

from fkev_slepc.api.loads import study_loads
from fkev_slepc.design.fatigue import fatigue_factor
from fkev_slepc.scene import Material, parse_scene, with_elements

SCENE = ROOT / "runs" / "slider-crank-design.toml"
SMALL = ("--elements", "2", "--angles", "0:330:30", "--harmonics", "8")
STEEL = Material("s", 2.05e11, 7870.0, 0.29, yield_strength=5.3e8, ultimate_strength=6.25e8, endurance_limit=3.1e8)


def small_check(text=None, **options):
    """The check at 100 rad/s on 2 elements per link, 12 angles, 8 harmonics (``Study.design_check``)."""
    import fkev_slepc as fk

    study = fk.load(SCENE, elements=2) if text is None else fk.Study(with_elements(parse_scene(text, "d.toml"), 2))
    return study.design_check(100.0, angles_deg=np.arange(0.0, 360.0, 30.0), harmonics=8, **options)


@pytest.mark.parametrize("criterion", ["goodman", "soderberg", "gerber"])
def test_fatigue_factor_is_the_hand_formula_of_the_tools_own_stresses(criterion):
    """n from the check's σ_m, σ_a at the critical point and the material: Goodman
    1/(σa/Se + σm/Sut), Soderberg 1/(σa/Se + σm/Sy), Gerber (Shigley eq. 6-47) to 1e-12;
    every point of the link has n >= the reported one."""
    check = small_check(criterion=criterion)
    lk = check.as_dict()["links"]["crank"]
    sm, sa = lk["sigma_mean_pa"], lk["sigma_alternating_pa"]
    se, sut, sy = 3.1e8, 6.25e8, 5.3e8
    assert sm > 0 and sa > 0
    hand = {"goodman": 1 / (sa / se + sm / sut), "soderberg": 1 / (sa / se + sm / sy),
            "gerber": 0.5 * (sut / sm) ** 2 * (sa / se) * (-1 + math.sqrt(1 + (2 * sm * se / (sut * sa)) ** 2))}
    assert lk["fatigue_sf"] == pytest.approx(hand[criterion], rel=1e-12)
    assert lk["fatigue_criterion"] == criterion
    assert lk["static_sf"] == pytest.approx(sy / lk["peak_stress_pa"], rel=1e-12)
    per_point = np.array([lk["points"]["fatigue_sf"][face] for face in ("plus", "minus")], dtype=float)
    assert np.nanmin(per_point) == lk["fatigue_sf"] and len(lk["points"]["s_m"]) == per_point.shape[1]


def test_fatigue_factor_conventions():
    """A compressive mean: n = Se/σa for every criterion; no alternation: Sut/σm (Goodman)."""
    for criterion in ("goodman", "soderberg", "gerber"):
        assert fatigue_factor(-2e8, 1e8, STEEL, criterion) == pytest.approx(3.1, rel=1e-15)
    assert fatigue_factor(1e8, 0.0, STEEL) == pytest.approx(6.25, rel=1e-15)
    assert fatigue_factor(1e8, 0.0, STEEL, "gerber") == pytest.approx(6.25, rel=1e-15)


def test_weak_axis_euler_margin_of_the_rod_by_hand():
    """buckling_sf = π² E I_weak / (K L)² / |N_min|, I_weak = h b³/12 of the 20 x 5 mm rod, K = 0.7
    set on the rod, N_min the most compressive kinetostatic axial force over the rod and the cycle."""
    text = SCENE.read_text().replace('name = "rod"                 # A -> B (wrist pin)',
                                     'name = "rod"\nbuckling_length_factor = 0.7')
    check = small_check(text)
    rod = check.as_dict()["links"]["rod"]
    jl = study_loads(with_elements(parse_scene(text, "d.toml"), 2), 100.0, np.arange(0.0, 360.0, 30.0))
    n_min = jl.link_axial(1)[1].min()
    assert n_min < 0 and rod["min_axial_force_n"] == n_min
    hand = math.pi**2 * 2.05e11 * (0.020 * 0.005**3 / 12) / (0.7 * 0.3) ** 2 / abs(n_min)
    assert rod["buckling_sf"] == pytest.approx(hand, rel=1e-13)
    weak = small_check(text, threshold=hand * 1.01)
    assert any("link 'rod': weak-axis buckling factor" in w for w in weak.warnings)
    assert not small_check(text, threshold=hand * 0.99).warnings


def test_design_check_peak_equals_fkev_response_and_csv():
    """The design table's peak |σ| per link equals `fkev response --json` (whole link) at the same
    point to 1e-10; the CSV has one row per link with the JSON keys."""
    r = fkev("design-check", SCENE, "--speed", "100", *SMALL, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    # the same 8 harmonics as the design check (their estimate, 0.1, is not what is compared: --tol 0.5)
    resp = fkev("response", SCENE, "--speed", "100", *SMALL, "--tol", "0.5", "--no-shooting", "--json")
    assert resp.returncode == 0, resp.stderr
    links = json.loads(resp.stdout)["links"]
    for name in ("crank", "rod"):
        assert d["links"][name]["peak_stress_pa"] == pytest.approx(links[name]["peak"]["stress_pa"], rel=1e-10)
        assert set(d["links"][name]) >= {"peak_stress_pa", "static_sf", "fatigue_sf", "fatigue_criterion",
                                          "sigma_mean_pa", "sigma_alternating_pa", "buckling_sf", "min_axial_force_n"}
    rpm = fkev("design-check", SCENE, "--speed-rpm", str(100 * 60 / (2 * math.pi)), *SMALL, "--csv", "-")
    assert rpm.returncode == 0, rpm.stderr
    rows = list(csv.DictReader(io.StringIO(rpm.stdout)))
    assert [row["link"] for row in rows] == ["crank", "rod"]
    assert float(rows[1]["peak_stress_pa"]) == pytest.approx(d["links"]["rod"]["peak_stress_pa"], rel=1e-9)


def test_bad_arguments_name_the_flag():
    r = fkev("design-check", SCENE, "--speed", "100", "--buckling-threshold", "-1", *SMALL)
    assert r.returncode == 2 and "--buckling-threshold: must be a finite number > 0 (got -1.0)" in r.stderr, r.stderr
    r = fkev("design-check", SCENE, "--speed", "100", "--criterion", "wohler")
    assert r.returncode == 2 and "--criterion" in r.stderr


def test_check_and_loads_report_the_weak_axis_margin(tmp_path):
    """`fkev check` prints each link's weak-axis margin at the scene's highest speed and warns below
    3 (exit 2 with --strict); `fkev loads --json` gives it under buckling.<link>, equal to
    P_cr/|N_min| of its own axial forces. K = 2 (fixed-free) quarters the pinned-ends margin."""
    scene = tmp_path / "k2.toml"
    scene.write_text(SCENE.read_text().replace('name = "rod"                 # A -> B (wrist pin)',
                                               'name = "rod"\nbuckling_length_factor = 2.0'))
    r = fkev("check", scene)
    assert r.returncode == 0 and "weak-axis buckling at the scene's highest speed 100 rad/s" in r.stdout, r.stderr
    assert "link 'rod': weak-axis buckling factor" in r.stderr and "K = 2" in r.stderr
    assert fkev("check", "--strict", scene).returncode == 2
    loads = fkev("loads", scene, "--angles", "0:330:30", "--json")
    d = json.loads(loads.stdout)
    n_min = np.nanmin(np.array(d["links"]["rod"]["axial_force_n"], dtype=float))
    p_cr = math.pi**2 * 2.05e11 * (0.020 * 0.005**3 / 12) / (2.0 * 0.3) ** 2
    assert d["buckling"]["rod"]["euler_load_n"] == pytest.approx(p_cr, rel=1e-14)
    assert d["buckling"]["rod"]["buckling_sf"] == pytest.approx(p_cr / abs(n_min), rel=1e-12)


def test_no_stress_gives_no_factor_and_strict_json():
    """At rest without gravity nothing is stressed: no finite safety factor (None, not ∞), no
    compression, and the JSON has no NaN or infinity."""
    import fkev_slepc as fk

    d = fk.load(SCENE, elements=2).design_check(0.0, angles_deg=np.arange(0.0, 360.0, 30.0), harmonics=2).as_dict()
    json.dumps(d, allow_nan=False)
    for name in ("crank", "rod"):
        lk = d["links"][name]
        assert lk["peak_stress_pa"] == 0.0 and lk["static_sf"] is None and lk["fatigue_sf"] is None
        assert lk["buckling_sf"] is None


def test_the_check_carries_its_periodic_settings_whole():
    """The check's JSON (strict) carries the response's PeriodicSettings whole, --harmonics and the
    angles as run. full_max_dofs = 0 puts the response on link components, whose levels at 2 elements
    per link end with every interior mode kept (W square, 12 of 12 DOFs: the full model): the same
    peak stresses to the harmonic balance's truncation (1.4e-4 at H = 8, 5.8e-8 at H = 16)."""
    from dataclasses import replace

    import fkev_slepc as fk
    from fkev_slepc.periodic.settings import DEFAULTS

    study = fk.load(SCENE, elements=2)
    angles = np.arange(0.0, 360.0, 30.0)
    base = study.design_check(100.0, angles_deg=angles, harmonics=16)
    d = base.as_dict()
    json.dumps(d, allow_nan=False)
    assert d["settings"] == {**DEFAULTS.as_json(), "harmonics": 16, "response_angles_deg": list(angles)}
    links = study.design_check(100.0, angles_deg=angles, harmonics=16, settings=replace(DEFAULTS, full_max_dofs=0))
    assert links.as_dict()["settings"]["full_max_dofs"] == 0
    for name in ("crank", "rod"):
        a, b = (c.as_dict()["links"][name]["peak_stress_pa"] for c in (base, links))
        assert abs(a - b) <= 1e-6 * a


def test_the_rods_pin_column_at_a_slider_is_the_wrist_pin():
    """Issue 36: at the slider the rod's pin load was the guide reaction (the block merged into the
    rod). The wrist pin carries the block's D'Alembert force, m·ẍ_B along the guide and the guide
    reaction R across it: |P| = hypot(m ẍ_B, R), with ẍ_B = Ω² d²x/dθ² of x = r cos θ + √(l² − r² sin² θ)
    by hand; the crank pin A is the same force on both links."""
    angles = np.arange(0.0, 360.0, 30.0)
    d = small_check().as_dict()["links"]
    loads = study_loads(with_elements(parse_scene(SCENE.read_text(), str(SCENE)), 2), 100.0, angles)
    r, l, m, w = 0.15, 0.3, 0.3, 100.0
    t = np.radians(angles)
    s, c = np.sin(t), np.cos(t)
    D = np.sqrt(l * l - r * r * s * s)
    xdd = w * w * (-r * c - r * r * (c * c - s * s) / D - r**4 * s * s * c * c / D**3)
    guide = loads.guide_reaction[:, loads.joint_names.index("B")]
    assert d["rod"]["pin_loads"]["B"]["peak_n"] == pytest.approx(np.hypot(m * xdd, guide).max(), rel=1e-10)
    assert d["rod"]["pin_loads"]["B"]["peak_n"] > 2 * np.abs(guide).max()  # not the guide reaction
    assert d["rod"]["pin_loads"]["A"]["peak_n"] == pytest.approx(d["crank"]["pin_loads"]["A"]["peak_n"], rel=1e-12)
