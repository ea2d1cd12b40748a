"""Study.replace / scene.edit: any scene key set by path, validated exactly like a file."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

import fkev_slepc as fk
from fkev_slepc.scene import SceneError, parse_scene
from fkev_slepc.scene.edit import dumps, parse_key

RUNS = Path(__file__).resolve().parents[1] / "runs"
BW = RUNS / "bahgat-willmert-1976.toml"


@pytest.mark.parametrize("path", sorted(RUNS.glob("*.toml")), ids=lambda p: p.stem)
def test_written_back_scene_is_the_same_scene(path):
    """dumps() of a parsed scene file reads back to the same document and the same Scene."""
    text = path.read_text()
    doc = tomllib.loads(text)
    assert tomllib.loads(dumps(doc)) == doc
    a, b = parse_scene(text, "a"), parse_scene(dumps(doc), "a")
    assert dataclasses.replace(a, source_text="") == dataclasses.replace(b, source_text="")


def test_replace_equals_the_edited_file():
    """The replaced study solves like a file with that value typed in, and the original is unchanged."""
    bw = fk.load(BW)
    text = BW.read_text().replace("length_m = 0.2794", "length_m = 0.31")
    assert text != BW.read_text()
    by_file = fk.Study.from_text(text).point(10, 500, "full")
    edited = bw.replace("links[coupler].length_m", 0.31)
    by_key = edited.point(10, 500, "full")
    np.testing.assert_allclose(by_key.eigenvalues, by_file.eigenvalues, rtol=1e-12)
    assert bw.scene.links[1].length == 0.2794 and edited.scene.links[1].length == 0.31
    assert "links[coupler].length_m = 0.31" in edited.scene.source_text.splitlines()[0]
    # several at once, by position and by name; numpy scalars are numbers
    two = bw.replace({"links[0].length_m": np.float64(0.13), "link_defaults.density_kg_m3": 7800})
    assert two.scene.links[0].length == 0.13 and {lk.density for lk in two.scene.links} == {7800.0}


def test_replace_keeps_a_remesh_unless_it_sets_the_elements():
    bw = fk.load(BW, elements=4)
    assert [lk.elements for lk in bw.replace("links[1].length_m", 0.3).scene.links] == [4, 4, 4]
    assert [lk.elements for lk in bw.replace("links[1].elements", 6).scene.links] == [4, 6, 4]


@pytest.mark.parametrize("key, value, line", [
    ("links[1].length_m", -0.3, "links[1].length_m: must be > 0 (got -0.3)"),
    ("links[1].length_m", "0.3", "links[1].length_m: must be a number, not a string (got '0.3')"),
    ("links[0].lenght_m", 0.1, "links[0].lenght_m: unknown key (did you mean 'links[0].length_m'?)"),
    ("links[7].length_m", 0.1, "links[7]: no such item (links has 3: 0-2)"),
    ("links[cupler].area_m2", 1e-4, "links[cupler]: no item named 'cupler'; did you mean 'coupler'?"),
    ("links.length_m", 0.1, "links: is an array: index it, links[0] or links[<name>]"),
    ("title.x", 1, "title: is a value, not a table"),
    ("analysis.modes", 0, "analysis.modes: must be >= 1 (got 0)"),
    ("driver.speeds_rpm", [100], "driver.speeds_rpm: give speeds_rad_s or speeds_rpm, not both"),
    ("links[1]..x", 1, "must be a dotted key path"),
])
def test_replace_errors_name_the_key_and_value(key, value, line):
    with pytest.raises(SceneError) as exc:
        fk.load(BW).replace(key, value)
    assert line in str(exc.value)
    assert f"with {key} = " in str(exc.value).splitlines()[0]


def test_new_tables_and_removal():
    bw = fk.load(BW)
    damped = bw.replace("damping.stiffness_proportional_s", 1e-5)
    assert damped.scene.damping.stiffness_proportional == 1e-5
    assert damped.replace("damping.stiffness_proportional_s", None).scene.damping.active is False
    assert parse_key("links[rod].segments[0].length_m") == ["links", "rod", "segments", 0, "length_m"]
