"""Materials and both-plane sections (scene/materials.py, scene/shapes.py, docs/response.md §2):
torsion constants against closed forms and published tables, [materials] referenced by links,
the out-of-plane element data of the mechanism, and every bad key named with its value."""

import math

import numpy as np
import pytest
from clitools import ROOT

from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.scene import SceneError, parse_scene
from fkev_slepc.scene.shapes import out_of_plane, rectangle_torsion_constant

BASE = (ROOT / "runs" / "slider-crank.toml").read_text()
ROD = "area_m2 = 1.8e-4            # 18 mm x 10 mm\nsecond_moment_m4 = 4.86e-9  # 0.010 * 0.018**3 / 12"
STEEL = ("[materials.steel]\nyoungs_modulus_pa = 2.1e11\ndensity_kg_m3 = 7850.0\npoisson_ratio = 0.3\n"
         "yield_pa = 5.3e8\nultimate_pa = 6.25e8\nendurance_pa = 2.8e8\n")


def scene(rod_text, head=""):
    assert ROD in BASE
    return parse_scene(BASE.replace(ROD, rod_text) + "\n" + head, "m.toml")


@pytest.mark.parametrize("ratio,beta", [(1.0, 0.141), (1.5, 0.196), (2.0, 0.229), (3.0, 0.263), (5.0, 0.291),
                                        (10.0, 0.312)])
def test_rectangle_torsion_constant_matches_the_published_table(ratio, beta):
    """J = β a b³ (Timoshenko & Goodier, Theory of Elasticity, §109 table: 3 digits)."""
    assert rectangle_torsion_constant(ratio, 1.0) == pytest.approx(beta * ratio, abs=5e-4 * ratio)


def test_rectangle_torsion_constant_limits():
    """Square: 0.1405770 a⁴ (the series' known value); a thin strip: (a b³/3)(1 - 0.630247 b/a),
    the coefficient 192/π⁵ Σ_odd 1/n⁵ = (192/π⁵)(31/32) ζ(5); either order of the sides."""
    assert rectangle_torsion_constant(2.0, 2.0) == pytest.approx(0.1405770 * 16, rel=1e-6)
    zeta5 = 1.0369277551433699
    a, b = 1.0, 1e-3
    thin = a * b**3 / 3 * (1 - 192 / math.pi**5 * 31 / 32 * zeta5 * b / a)
    assert rectangle_torsion_constant(b, a) == pytest.approx(thin, rel=1e-12)


def test_round_sections_out_of_plane():
    d, D = 0.016, 0.02
    assert out_of_plane("circle", {"diameter_m": D}) == pytest.approx(
        (math.pi * D**4 / 64, math.pi * D**4 / 32, math.pi * D**4 / 32, D / 2), rel=1e-15)
    tube = out_of_plane("tube", {"outer_diameter_m": D, "inner_diameter_m": d})
    assert tube == pytest.approx((math.pi * (D**4 - d**4) / 64, math.pi * (D**4 - d**4) / 32,
                                  math.pi * (D**4 - d**4) / 32, D / 2), rel=1e-15)


def test_material_and_rectangle_give_the_out_of_plane_element_data():
    """A 20 x 8 mm steel rod (20 mm in plane): E I_out, G J with G = E/2(1+ν), ρ I_p with
    I_p = b h (b² + h²)/12, per element of the mechanism; the crank without data gives NaN."""
    sc = scene('section = {shape = "rectangle", width_m = 0.008, height_m = 0.02}\nmaterial = "steel"\n'
               "buckling_length_factor = 0.7", STEEL)
    rod = sc.links[1]
    assert (rod.youngs_modulus, rod.density, rod.material, rod.buckling_length_factor) == (2.1e11, 7850.0, "steel", 0.7)
    assert sc.links[0].material is None and sc.links[0].buckling_length_factor == 1.0
    assert sc.material("steel").yield_strength == 5.3e8 and sc.material("steel").endurance_limit == 2.8e8
    b, h = 0.008, 0.02
    mech = build_mechanism(sc)
    on_rod = mech.elem_link == 1
    G = 2.1e11 / 2.6
    np.testing.assert_allclose(mech.elem_ei_out[on_rod], 2.1e11 * h * b**3 / 12, rtol=1e-15)
    np.testing.assert_allclose(mech.elem_gj[on_rod], G * rectangle_torsion_constant(b, h), rtol=1e-15)
    np.testing.assert_allclose(mech.elem_rho_ip[on_rod], 7850.0 * b * h * (b * b + h * h) / 12, rtol=1e-14)
    assert np.isnan(mech.elem_ei_out[~on_rod]).all() and np.isnan(mech.elem_gj[~on_rod]).all()
    np.testing.assert_allclose(mech.elem_ei[on_rod], 2.1e11 * b * h**3 / 12, rtol=1e-15)


def test_explicit_out_of_plane_keys_inherit_and_default_the_polar_moment():
    """Explicit I_out and J with a link's shear_modulus_pa; I_p = I + I_out when not given;
    a segment inherits them from its link and may set its own material."""
    sc = scene(ROD.replace("#", "\n#") + "\nsecond_moment_out_of_plane_m4 = 1.5e-9\ntorsion_constant_m4 = 4.1e-9\n"
               "shear_modulus_pa = 8e10")
    rod = sc.links[1]
    assert (rod.second_moment_out, rod.torsion_constant, rod.shear_modulus) == (1.5e-9, 4.1e-9, 8e10)
    assert rod.polar_moment == pytest.approx(4.86e-9 + 1.5e-9, rel=1e-15)
    seg = scene('second_moment_out_of_plane_m4 = 1.5e-9\ntorsion_constant_m4 = 4.1e-9\n'
                '[[links.segments]]\nlength_m = 0.05\nelements = 3\nsection = {shape = "circle", diameter_m = 0.01}\n'
                'material = "steel"\n[[links.segments]]\nlength_m = 0.1\narea_m2 = 1e-4\nsecond_moment_m4 = 1e-9',
                STEEL).links[1]
    first, second = seg.segments
    assert first.material == "steel" and first.shear_modulus == pytest.approx(2.1e11 / 2.6, rel=1e-15)
    assert first.torsion_constant == pytest.approx(math.pi * 0.01**4 / 32, rel=1e-15)
    assert (second.material, second.shear_modulus, second.second_moment_out) == (None, None, 1.5e-9)
    assert second.youngs_modulus == 2.07e11 and second.polar_moment == pytest.approx(1e-9 + 1.5e-9, rel=1e-15)


def test_material_in_link_defaults_and_units():
    """[link_defaults] material applies to every link (a link's own E wins, key by key); with
    [units] the strengths convert like a modulus (kN/m² here)."""
    text = BASE.replace("youngs_modulus_pa = 2.07e11\ndensity_kg_m3 = 7850.0", 'material = "steel"')
    sc = parse_scene(text.replace('name = "rod"                # A -> P (gudgeon pin)',
                                  'name = "rod"\nyoungs_modulus_pa = 2.0e11') + "\n" + STEEL, "d.toml")
    assert [lk.material for lk in sc.links] == ["steel", "steel"]
    assert [lk.youngs_modulus for lk in sc.links] == [2.1e11, 2.0e11] and sc.links[1].density == 7850.0
    kn = parse_scene(BASE.replace("youngs_modulus_pa = 2.07e11\ndensity_kg_m3 = 7850.0", 'material = "s"')
                     + '\n[units]\nforce = "kN"\n[materials.s]\nyoungs_modulus_pa = 2.07e8\ndensity_kg_m3 = 7850.0\n'
                     'yield_pa = 5.3e5\nendurance_pa = 2.8e5\n', "kn.toml")  # stresses in kN/m²
    assert kn.links[0].youngs_modulus == pytest.approx(2.07e11, rel=1e-15) and kn.links[1].density == 7850.0
    assert (kn.material("s").yield_strength, kn.material("s").endurance_limit) == pytest.approx((5.3e8, 2.8e8), rel=1e-15)


@pytest.mark.parametrize("rod_text,head,message", [
    ('material = "stee"\n' + ROD, STEEL, "links[1].material: unknown material (got 'stee'; did you mean 'steel'?"),
    ('material = "steel"\nyoungs_modulus_pa = 2e11\n' + ROD, STEEL,
     "links[1].youngs_modulus_pa: give material = 'steel' or youngs_modulus_pa/density_kg_m3, not both"),
    (ROD, STEEL.replace("poisson_ratio = 0.3", "poisson_ratio = 0.7"),
     "materials.steel.poisson_ratio: must be < 0.5 (got 0.7)"),
    (ROD, STEEL.replace("yield_pa = 5.3e8", "yield_pa = 7e8"),
     "materials.steel.yield_pa: must be <= ultimate_pa = 625000000.0 (got 700000000.0)"),
    (ROD, STEEL.replace("density_kg_m3 = 7850.0\n", ""), "materials.steel.density_kg_m3: missing required key"),
    (ROD, STEEL.replace("endurance_pa", "endurance_mpa"), "materials.steel.endurance_mpa: unknown key"),
    (ROD, "[materials]\nsteel = 3", "materials.steel: must be a table"),
    (ROD + "\nbuckling_length_factor = -1", "", "links[1].buckling_length_factor: must be > 0 (got -1)"),
    (ROD + "\ntorsion_constant_m4 = 0", "", "links[1].torsion_constant_m4: must be > 0 (got 0)"),
    ('section = {shape = "circle", diameter_m = 0.01}\ntorsion_constant_m4 = 1e-9', "",
     "links[1].torsion_constant_m4: give the section either"),
])
def test_bad_material_keys_name_the_field_once(rod_text, head, message):
    with pytest.raises(SceneError) as err:
        scene(rod_text, head)
    assert len(err.value.problems) == 1 and message in str(err.value), str(err.value)
