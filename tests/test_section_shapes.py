"""Section shape helpers (scene/shapes.py, docs/response.md §2): shapes convert to the SI area,
second moment and extreme-fibre distance once, stand wherever area_m2/second_moment_m4 may, and
every bad value is reported with its dotted path and nothing else."""

import math

import numpy as np
import pytest
from clitools import ROOT

from fkev_slepc.scene import SceneError, parse_scene

BASE = (ROOT / "runs" / "slider-crank.toml").read_text()
ROD = "area_m2 = 1.8e-4            # 18 mm x 10 mm\nsecond_moment_m4 = 4.86e-9  # 0.010 * 0.018**3 / 12"


def rod(text):
    assert ROD in BASE
    return parse_scene(BASE.replace(ROD, text), "s.toml")


@pytest.mark.parametrize("section,area,inertia,c", [
    ('{shape = "circle", diameter_m = 0.006}', math.pi * 0.006**2 / 4, math.pi * 0.006**4 / 64, 0.003),
    ('{shape = "rectangle", width_m = 0.010, height_m = 0.018}', 1.8e-4, 0.010 * 0.018**3 / 12, 0.009),
    ('{shape = "tube", outer_diameter_m = 0.02, inner_diameter_m = 0.016}', math.pi * (0.02**2 - 0.016**2) / 4,
     math.pi * (0.02**4 - 0.016**4) / 64, 0.01),
])
def test_shapes_convert_to_si(section, area, inertia, c):
    link = rod(f"section = {section}").links[1]
    assert (link.area, link.second_moment, link.fibre_distance) == pytest.approx((area, inertia, c), rel=1e-15)


def test_rectangle_gives_the_explicit_scene():
    """The shipped rod (18 x 10 mm, explicit A and I) and the same rectangle: identical frequencies."""
    from fkev_slepc.api import Study

    explicit = Study(parse_scene(BASE, "a.toml")).point(30, 300, "full", solver="dense").frequency_hz
    shaped = Study(rod('section = {shape = "rectangle", width_m = 0.010, height_m = 0.018}')).point(
        30, 300, "full", solver="dense").frequency_hz
    np.testing.assert_allclose(shaped, explicit, rtol=1e-12)


def test_defaults_segments_and_explicit_fibre():
    sc = rod("fibre_distance_m = 0.009\n" + ROD.replace("#", "\n#"))
    assert sc.links[1].fibre_distance == 0.009 and sc.links[0].fibre_distance is None
    text = BASE.replace("[link_defaults]", '[link_defaults]\nsection = {shape = "circle", diameter_m = 0.01}')
    text = text.replace("area_m2 = 4.2e-4            # 30 mm x 14 mm\nsecond_moment_m4 = 3.15e-8  # 0.014 * 0.030**3 / 12", "")
    sc = parse_scene(text, "d.toml")
    assert sc.links[0].fibre_distance == 0.005 and sc.links[0].area == pytest.approx(math.pi * 0.01**2 / 4)
    seg = rod("[[links.segments]]\nlength_m = 0.05\nelements = 3\nsection = {shape = \"circle\", diameter_m = 0.008}\n"
              "[[links.segments]]\nlength_m = 0.1\narea_m2 = 1e-4\nsecond_moment_m4 = 1e-9\n"
              "fibre_distance_m = 0.0045").links[1]
    # the second segment takes the link's trailing elements = 8
    assert [s.fibre_distance for s in seg.segments] == [0.004, 0.0045] and seg.fibre_distance == 0.004


@pytest.mark.parametrize("section,message", [
    ('section = {shape = "tube", outer_diameter_m = 0.02, inner_diameter_m = 0.026}',
     "links[1].section.inner_diameter_m: must be < outer_diameter_m = 0.02 (got 0.026)"),
    ('section = {shape = "circel", diameter_m = 0.006}', "links[1].section.shape: must be one of"),
    ('section = {shape = "circle", diameter_m = -0.006}', "links[1].section.diameter_m: must be > 0 (got -0.006)"),
    ('section = {shape = "circle", diameter_m = 0.006}\narea_m2 = 1e-4', "links[1].area_m2: give the section either"),
    ("section = 3", "links[1].section: must be a table"),
    ("area_m2 = 1.8e-4\nsecond_moment_m4 = 4.86e-9\nfibre_distance_m = -1", "links[1].fibre_distance_m: must be > 0"),
])
def test_bad_sections_name_the_field_once(section, message):
    with pytest.raises(SceneError) as err:
        rod(section)
    assert len(err.value.problems) == 1 and message in str(err.value), str(err.value)
