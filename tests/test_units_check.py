"""[units] (scene/units.py: a scene written in mm-N-t or in-lbf-s, read once into SI) and the
per-link summary and unit-slip warnings of ``fkev check`` (scene/plausible.py)."""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import fkev_slepc as fk
from fkev_slepc.cli import main
from fkev_slepc.scene import SceneError, load_scene, parse_scene
from fkev_slepc.scene.edit import dumps
from fkev_slepc.scene.plausible import summarize_scene
from fkev_slepc.scene.units import DIMENSIONS, INCH_M, LBF_N

ROOT = Path(__file__).resolve().parents[1]
SC = ROOT / "runs" / "slider-crank-benchmark.toml"
SC_MM = ROOT / "tests" / "data" / "slider-crank-mm-N-t.toml"
BW = ROOT / "runs" / "bahgat-willmert-1976.toml"


def same_links(a, b, rtol=0.0):
    for x, y in zip(a.links, b.links):
        for f in ("length", "youngs_modulus", "density", "area", "second_moment"):
            assert getattr(x, f) == pytest.approx(getattr(y, f), rel=rtol, abs=0), (x.name, f)


def test_mm_n_t_scene_is_the_si_scene():
    si, mm = load_scene(SC), load_scene(SC_MM)
    same_links(si, mm)  # exactly: 150 mm -> 0.15 m, 7.87e-9 t/mm³ -> 7870 kg/m³ (15 significant digits)
    assert mm.joints == si.joints and mm.driver == si.driver
    a = fk.Study(si).point(30, 150, "full").eigenvalues
    b = fk.Study(mm).point(30, 150, "full").eigenvalues
    np.testing.assert_allclose(b, a, rtol=1e-12)
    # the scene text (what archives keep) is SI and reads back alone; the file as written is quoted
    again = parse_scene(mm.source_text, "again")
    same_links(si, again)
    assert "units" not in tomllib.loads(mm.source_text) and "#   system = \"mm-N-t\"" in mm.source_text


def test_section_shapes_are_converted_too():
    """A circle of Ø 6 (mm) in a mm-N-t scene is the benchmark's Ø 6 mm section."""
    text = SC_MM.read_text().replace("area_m2 = 28.27433", 'section = { shape = "circle", diameter_m = 6.0 }')
    text = text.replace("second_moment_m4 = 63.61725\n", "")
    mm = parse_scene(text, "circle.toml")
    assert mm.links[1].area == pytest.approx(math.pi * 0.006**2 / 4, rel=1e-14)
    assert mm.links[1].second_moment == pytest.approx(math.pi * 0.006**4 / 64, rel=1e-14)
    assert mm.links[1].fibre_distance == pytest.approx(0.003, rel=1e-14)


def test_in_lbf_s_scene_is_the_si_scene():
    """Bahgat-Willmert written in inches, pounds-force and lbf·s²/in (its section is 0.25 in x 1 in)."""
    doc = tomllib.loads(BW.read_text())
    factor = {k: INCH_M**a * LBF_N**b * (LBF_N / INCH_M)**c for k, (a, b, c) in DIMENSIONS.items()}
    for table in [doc["link_defaults"], *doc["links"], *doc["joints"]]:
        for k, v in table.items():
            if k in factor:
                table[k] = [x / factor[k] for x in v] if isinstance(v, list) else v / factor[k]
    assert doc["links"][0]["length_m"] == pytest.approx(5.0)  # 0.127 m = 5 in
    assert doc["link_defaults"]["youngs_modulus_pa"] == pytest.approx(3.0e7, rel=1e-3)  # 30 Mpsi
    doc["units"] = {"system": "in-lbf-s"}
    scene = parse_scene(dumps(doc), "bw-in.toml")
    same_links(load_scene(BW), scene, rtol=1e-14)
    f_si = fk.load(BW).point(10, 1000, "full").frequency_hz
    np.testing.assert_allclose(fk.Study(scene).point(10, 1000, "full").frequency_hz, f_si, rtol=1e-11)


@pytest.mark.parametrize("units, line", [
    ('system = "mm-N-kg"', "units.system: must be one of 'SI', 'mm-N-t', 'in-lbf-s' (got 'mm-N-kg'; did you mean 'mm-N-t'?)"),
    ('system = "mm-N-t"\nlength = "mm"', "units.length: give units.system or length/force/mass, not both"),
    ('length = "mmm"', "units.length: must be one of 'm', 'mm', 'cm', 'in', 'ft' (got 'mmm'; did you mean 'mm'?)"),
    ('lenght = "mm"', "units.lenght: unknown key (did you mean 'units.length'?)"),
])
def test_bad_units_tables_are_named(units, line):
    text = SC_MM.read_text().replace('system = "mm-N-t"', units)
    with pytest.raises(SceneError) as exc:
        parse_scene(text, "x.toml")
    assert line in str(exc.value)


def test_errors_in_a_units_scene_quote_the_value_as_typed():
    text = SC_MM.read_text().replace("length_m = 300.0", "length_m = -300.0")
    with pytest.raises(SceneError) as exc:
        parse_scene(text, "x.toml")
    assert "links[1].length_m: must be > 0 (got -300.0)" in str(exc.value)


def test_a_units_sweep_is_archived_in_si(tmp_path):
    res = fk.load(SC_MM).sweep([30], [150], ["full"], tmp_path / "mm.h5")
    same_links(load_scene(SC), parse_scene(res.scene_toml, "archived"))
    ref = fk.load(SC).point(30, 150, "full").frequency_hz
    np.testing.assert_allclose(res.frequency("full", 150)[0], ref, rtol=1e-12)


def test_check_summary_per_link(capsys):
    assert main(["check", str(SC), str(SC_MM)]) == 0
    out, err = capsys.readouterr()
    warned = [ln for ln in err.splitlines() if "warning" in ln]
    assert len(warned) == 2 and all("'crank': slenderness L/r = 100" in ln for ln in warned), err  # both unit systems alike
    rows = [ln.split() for ln in out.splitlines() if ln.startswith("  rod ")]
    assert len(rows) == 2 and rows[0] == rows[1]  # the mm-N-t file gives the same summary
    E, rho, A, I, L = 2.0e11, 7870.0, 2.827433e-5, 6.361725e-11, 0.3
    assert float(rows[0][2]) == pytest.approx(rho * A * L, rel=1e-3)  # mass
    assert float(rows[0][3]) == pytest.approx(L / math.sqrt(I / A), rel=1e-3)  # L/r = 200 for Ø 6 mm
    assert float(rows[0][4]) == pytest.approx(math.pi / (2 * L**2) * math.sqrt(E * I / (rho * A)), rel=1e-4)
    assert "units: written in mm-N-t, converted to SI on reading" in out


def test_check_warns_on_unit_slips(tmp_path, capsys):
    slip = tmp_path / "slip.toml"
    slip.write_text(SC.read_text().replace("length_m = 0.3", "length_m = 300")
                    .replace("youngs_modulus_pa = 2.0e11", "youngs_modulus_pa = 200")
                    .replace("density_kg_m3 = 7870.0", "density_kg_m3 = 7.87"))
    assert main(["check", str(slip)]) == 0  # valid, but implausible
    err = capsys.readouterr().err
    assert "links[1] 'rod': length_m = 300 m, a link longer than 50 m" in err
    assert "links[1] 'rod': slenderness L/r = 2e+05" in err
    assert "links[0] 'crank': youngs_modulus_pa = 200 Pa is no structural material" in err
    assert "links[0] 'crank': density_kg_m3 = 7.87 kg/m³ is no structural material" in err
    assert main(["check", "--strict", str(slip)]) == 2


def test_no_shipped_scene_warns():
    for path in sorted((ROOT / "runs").glob("*.toml")):
        assert [w for s in summarize_scene(load_scene(path)) for w in s.warnings] == [], path
