"""Out of plane in the design check (docs/design.md "Out of plane", docs/theory.md §19):
``fkev check``'s weak-axis f₁ and torsion f_t per link against their closed forms, and the
lowest out-of-plane frequency of ``fkev design-check`` / ``Study.design_check`` against the
frozen out-of-plane points it is the minimum of, with its crank-order margins by hand."""

import math
from pathlib import Path

import numpy as np
import pytest

import fkev_slepc as fk
from fkev_slepc.cli import main
from fkev_slepc.scene import load_scene
from fkev_slepc.scene.plausible import summarize_scene

ROOT = Path(__file__).resolve().parents[1]
FLAT = ROOT / "runs/flat-rod-slider-crank.toml"
SC = ROOT / "runs/slider-crank-benchmark.toml"
RPM = math.pi / 30


def round_bars(tmp_path) -> Path:
    """The slider-crank benchmark with its Ø 6 mm bars given by shape, and a shear modulus."""
    text = SC.read_text().replace("area_m2 = 2.827433e-5", 'section = {shape = "circle", diameter_m = 0.006}')
    text = text.replace("second_moment_m4 = 6.361725e-11", "shear_modulus_pa = 7.7e10")
    text = text.replace("fibre_distance_m = 0.003", "")
    out = tmp_path / "round.toml"
    out.write_text(text)
    return out


def test_check_out_of_plane_columns_are_the_closed_forms(tmp_path, capsys):
    """Weak-axis pinned-pinned f₁ = (π/2L²)√(E I_out/ρA) and first torsion f_t = (1/2L)√(GJ/ρI_p)
    (twist held at both ends): for the flat rod's rectangles f₁ = (π/2L²)√(E b²/12ρ) (b the
    out-of-plane width), for round bars (J = I_p) f_t = (1/2L)√(G/ρ) and f₁ out = f₁ in plane;
    a scene without out-of-plane data prints '-'."""
    E, rho = 2.07e11, 7850.0
    for s, (L, b) in zip(summarize_scene(load_scene(FLAT)), ((0.04, 0.012), (0.16, 0.008))):
        assert s.pinned_frequency_out_hz == pytest.approx(math.pi / (2 * L * L) * math.sqrt(E * b * b / (12 * rho)),
                                                          rel=1e-12, abs=0)
    round_scene = round_bars(tmp_path)
    E, rho, G = 2.0e11, 7870.0, 7.7e10
    rows = summarize_scene(load_scene(round_scene))
    for s, L in zip(rows, (0.15, 0.3)):
        assert s.torsion_frequency_hz == pytest.approx(math.sqrt(G / rho) / (2 * L), rel=1e-12, abs=0)
        assert s.pinned_frequency_out_hz == pytest.approx(s.pinned_frequency_hz, rel=1e-12, abs=0)
    assert main(["check", str(round_scene), str(SC)]) == 0
    out = capsys.readouterr().out
    printed = [ln.split() for ln in out.splitlines() if ln.startswith("  rod ") and "P_cr" not in ln]
    assert printed[0][5:] == [f"{rows[1].pinned_frequency_out_hz:.5g}", f"{rows[1].torsion_frequency_hz:.5g}"]
    assert printed[1][5:] == ["-", "-"] and "f_t torsion [Hz]" in out


@pytest.fixture(scope="module")
def flat_check():
    st = fk.load(FLAT, elements=1)
    return st, st.design_check(2000 * RPM, angles_deg=np.arange(0.0, 360.0, 30.0))


def test_lowest_out_of_plane_frequency_is_the_frozen_minimum(flat_check):
    """f₁(θ) of the check is the lowest frequency of ``Study.point(..., plane="out")`` at each
    checked angle; the reported minimum, its angle and the band are theirs, and the crank orders
    inside the band (or the nearest outside) follow the rule of ``fkev margins``."""
    st, check = flat_check
    o = check.as_dict()["out_of_plane"]
    angles = np.arange(0.0, 360.0, 30.0)
    f1 = np.array([st.point(a, 2000 * RPM, "full", modes=1, plane="out").frequency_hz[0] for a in angles])
    np.testing.assert_allclose(o["f1_hz"], f1, rtol=1e-12)
    assert o["checked"] and o["f1_min_hz"] == f1.min() and o["angle_min_deg"] == angles[np.argmin(f1)]
    assert o["f1_max_hz"] == f1.max() and o["divergent_angles_deg"] == []
    base = 2000 * RPM / (2 * math.pi)
    n = np.arange(1, int(f1.max() // base) + 2)
    assert o["orders_inside"] == [int(k) for k in n if f1.min() <= k * base <= f1.max()]
    below = n[n * base < f1.min()].max()
    assert o["below"]["order"] == below
    assert o["below"]["margin_percent"] == pytest.approx(100 * (f1.min() - below * base) / f1.min(), rel=1e-12)
    above = n[n * base > f1.max()].min()
    assert o["above"]["order"] == above
    assert o["above"]["margin_percent"] == pytest.approx(100 * (above * base - f1.max()) / f1.max(), rel=1e-12)
    rod = check.as_dict()["links"]["rod"]["buckling_sf"]
    assert o["buckling_link"] == "rod" and o["buckling_sf"] == rod


def test_no_out_of_plane_section_is_not_checked(tmp_path, capsys):
    """The flat rod with its sections given as A and I only (no out-of-plane data): the check says
    so in its JSON and text."""
    text = FLAT.read_text()
    for b, h in (("0.012", "0.030"), ("0.008", "0.020")):
        B, H = float(b), float(h)
        text = text.replace(f'section = {{shape = "rectangle", width_m = {b}, height_m = {h}}}',
                            f"area_m2 = {B * H!r}\nsecond_moment_m4 = {B * H**3 / 12!r}")
    assert "rectangle" not in text
    plain = tmp_path / "plain.toml"
    plain.write_text(text)
    assert main(["design-check", str(plain), "--elements", "1", "--angles", "0:355:30", "--speed-rpm", "2000"]) == 0
    out = capsys.readouterr().out
    assert "  out of plane: not checked (no out-of-plane section)" in out.splitlines()
    check = fk.load(plain, elements=1).design_check(2000 * RPM, angles_deg=np.arange(0.0, 360.0, 30.0))
    assert check.as_dict()["out_of_plane"] == {"checked": False, "note": "not checked (no out-of-plane section)"}


def test_divergent_angles_are_listed_not_counted_as_frequencies(tmp_path):
    """Bahgat-Willmert's thin bars out of plane at 1000 rad/s buckle about the weak axis at some
    angles (weak-axis factor 0.08-0.12): the check lists exactly the angles where the frozen
    out-of-plane point is divergent, and takes the band over the others only."""
    from fkev_slepc.design.out_of_plane import out_of_plane_check
    from fkev_slepc.model.buckling import weak_axis_buckling
    from fkev_slepc.model.mechanism import build_mechanism
    from fkev_slepc.api.loads import study_loads

    scene = tmp_path / "bw.toml"
    scene.write_text((ROOT / "runs/bahgat-willmert-1976.toml").read_text().replace(
        "[link_defaults]\n", "[link_defaults]\nsecond_moment_out_of_plane_m4 = 5.42e-10\n"
        "torsion_constant_m4 = 1.826e-9\nshear_modulus_pa = 7.96e10\n", 1))
    st = fk.load(scene, elements=1)
    angles = np.arange(0.0, 360.0, 30.0)
    points = [st.point(a, 1000.0, "full", modes=1, plane="out") for a in angles]
    divergent = [a for a, p in zip(angles, points) if p.status == "divergent"]
    assert 0 < len(divergent) < angles.size
    buckling = weak_axis_buckling(build_mechanism(st.scene), study_loads(st.scene, 1000.0))
    o = out_of_plane_check(st.scene, 1000.0, "full", angles, buckling).as_dict()
    assert o["divergent_angles_deg"] == divergent
    f1 = np.array([np.nan if p.status == "divergent" else p.frequency_hz[0] for p in points])
    assert o["f1_min_hz"] == np.nanmin(f1) and o["f1_max_hz"] == np.nanmax(f1)
    assert o["buckling_sf"] == min(b.factor for b in buckling if b.factor is not None) < 1
