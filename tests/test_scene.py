"""Scene files: the three shipped scenes load with the expected numbers, and every class of
bad input gives one clear message per problem, naming the exact dotted path, with exit code 2
and never a traceback."""

from __future__ import annotations

import logging
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_linkages import BAD_LINKAGES

from fkev_slepc.scene.cases import CASE_NAMES
from fkev_slepc.cli import main
from fkev_slepc.scene import SceneError, load_scene, parse_scene, with_elements

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
RUNS = ROOT / "runs"
FKEV = [sys.executable, "-m", "fkev_slepc"]  # the installed package, wherever `fkev` is (or is not) on PATH

# A minimal valid scene (the Bahgat-Willmert four-bar, one element per link) that the
# direct-parsing tests below modify.
FOURBAR = """
[link_defaults]
youngs_modulus_pa = 2.07e11
density_kg_m3 = 7760.0
area_m2 = 1.61e-4
second_moment_m4 = 8.66e-9
elements = 1
[[links]]
name = "crank"
length_m = 0.127
[[links]]
name = "coupler"
length_m = 0.2794
[[links]]
name = "follower"
length_m = 0.2667
[[joints]]
name = "O1"
connects = ["ground", "crank.root"]
position_m = [0.0, 0.0]
[[joints]]
name = "A"
connects = ["crank.tip", "coupler.root"]
[[joints]]
name = "B"
connects = ["coupler.tip", "follower.tip"]
[[joints]]
name = "O2"
connects = ["ground", "follower.root"]
position_m = [0.254, 0.0]
[driver]
link = "crank"
speeds_rad_s = [0.0]
"""


@pytest.fixture(autouse=True)
def _restore_logging():
    """``cli.main`` installs a handler on the captured stderr; do not leak it to later tests."""
    logger = logging.getLogger("fkev_slepc")
    handlers, level = logger.handlers[:], logger.level
    yield
    logger.handlers[:], logger.level = handlers, level


def problems_of(text: str) -> list[str]:
    """``str`` of every problem of a scene text (fails the test if the scene is valid)."""
    with pytest.raises(SceneError) as info:
        parse_scene(text, "t.toml")
    return [str(p) for p in info.value.problems]


# --------------------------------------------------------------------------------------------
# The shipped scenes
# --------------------------------------------------------------------------------------------
def test_bahgat_willmert_scene():
    s = load_scene(RUNS / "bahgat-willmert-1976.toml")
    assert [lk.name for lk in s.links] == ["crank", "coupler", "follower"]
    assert [lk.elements for lk in s.links] == [1, 2, 2]
    assert [lk.length for lk in s.links] == [0.127, 0.2794, 0.2667]
    assert {(lk.youngs_modulus, lk.density, lk.area, lk.second_moment) for lk in s.links} == {
        (2.07e11, 7760.0, 1.61e-4, 8.66e-9)
    }
    angles = s.analysis.crank_angles_deg
    assert len(angles) == 73 and angles[0] == 0.0 and angles[-1] == 360.0 and angles[2] == 10.0
    assert s.driver.speeds == (0.0, 500.0, 1000.0) and s.driver.acceleration == 0.0
    assert s.analysis.cases == CASE_NAMES and len(s.analysis.cases) == 6
    assert s.analysis.modes == 4 and s.masses == ()
    grounds = {j.name: j.ground for j in s.joints if j.ground is not None}
    assert grounds == {"O1": (0.0, 0.0), "O2": (0.254, 0.0)}
    b = next(j for j in s.joints if j.name == "B")
    assert [(e.link, e.end) for e in b.ends] == [("coupler", "tip"), ("follower", "tip")]
    assert b.assembly == "left"
    assert "Bahgat" in s.source_text and s.source.endswith("bahgat-willmert-1976.toml")


def test_turcic_midha_scene():
    s = load_scene(RUNS / "turcic-midha-1984.toml")
    assert [lk.elements for lk in s.links] == [3, 3, 3]
    assert [lk.length for lk in s.links] == [0.1080, 0.2794, 0.2705]
    assert [lk.area for lk in s.links] == [1.07e-4, 4.1e-5, 4.1e-5]
    assert [lk.second_moment for lk in s.links] == [1.62e-10, 8.67e-12, 8.67e-12]
    assert {(lk.youngs_modulus, lk.density) for lk in s.links} == {(7.1e10, 2710.0)}
    assert [(m.joint, m.link, m.mass) for m in s.masses] == [("A", "crank", 0.0452), ("B", "follower", 0.0375)]
    assert s.driver.speeds == (0.0,)
    assert s.analysis.cases == ("structure",) and s.analysis.modes == 3
    assert len(s.analysis.crank_angles_deg) == 73
    # The thesis's 3- and 6-element models are the same scene re-meshed.
    assert [lk.elements for lk in with_elements(s, 1).links] == [1, 1, 1]


def test_rotating_cantilever_scene():
    s = load_scene(RUNS / "rotating-cantilever.toml")
    (beam,) = s.links
    assert beam.elements == 16
    assert beam.length / math.sqrt(beam.second_moment / beam.area) >= 500  # slender
    t = math.sqrt(beam.density * beam.area * beam.length**4 / (beam.youngs_modulus * beam.second_moment))
    lam = [w * t for w in s.driver.speeds]
    assert lam[0] == 0.0 and lam[-1] == pytest.approx(12.0, rel=1e-8)  # covers λ = 0..12
    assert lam == pytest.approx([0, 2, 4, 6, 8, 10, 12], rel=1e-8)
    (hub,) = s.joints
    assert hub.ground == (0.0, 0.0) and s.driver.link == "beam"
    assert s.analysis.crank_angles_deg == (0.0,)
    assert s.analysis.cases == ("full", "structure") and s.analysis.modes == 3


def test_check_accepts_the_shipped_scenes(capsys):
    assert main(["check", *map(str, sorted(RUNS.glob("*.toml")))]) == 0
    out = capsys.readouterr().out.splitlines()
    assert any(
        line.startswith(f"{RUNS / 'bahgat-willmert-1976.toml'}: ok (3 links, 4 joints, 5 elements, n_free 15,")
        for line in out
    ), out
    assert any("turcic-midha-1984.toml: ok (3 links, 4 joints, 9 elements, n_free 27," in line for line in out)


def test_readme_example_is_a_valid_scene():
    import re

    text = (RUNS / "README.md").read_text()
    assert "## Scene file format" in text
    (example,) = re.findall(r"```toml\n(.*?)```", text, flags=re.S)
    s = parse_scene(example, "README.md")
    assert len(s.analysis.crank_angles_deg) == 73 and s.analysis.cases == CASE_NAMES
    assert s.solver.petsc == (("pep_type", "toar"), ("pep_tol", "1e-10"))


# --------------------------------------------------------------------------------------------
# Conversions and defaults
# --------------------------------------------------------------------------------------------
def test_case_numbers_follow_table_3_1():
    s = parse_scene(FOURBAR + '[analysis]\ncases = [3, 4, "0", 3, "full", 1]\n')
    # Table 3.1 order (not the Fortran's, which swaps 3 and 4); duplicates dropped, order kept.
    assert s.analysis.cases == ("no_tangential", "no_normal", "structure", "full")
    assert parse_scene(FOURBAR + "[analysis]\ncases = 5\n").analysis.cases == ("no_pseudo_normal",)
    assert parse_scene(FOURBAR + '[analysis]\ncases = ["full", "all"]\n').analysis.cases == (
        "full", "structure", "no_coriolis", "no_tangential", "no_normal", "no_pseudo_normal",
    )


def test_defaults_and_overrides():
    s = parse_scene(FOURBAR.replace('length_m = 0.2794', 'length_m = 0.2794\nelements = 4'), "dir/fb.toml")
    assert [lk.elements for lk in s.links] == [1, 4, 1]  # [[links]] overrides [link_defaults]
    assert s.title == "fb"  # default title: the file's stem
    assert s.analysis.crank_angles_deg == (0.0,) and s.analysis.cases == ("full",)
    assert (s.analysis.modes, s.analysis.mode_shapes) == (4, False)
    assert (s.analysis.imag_tol, s.analysis.damping_tol) == (1e-9, 1e-6)
    assert (s.solver.method, s.solver.petsc) == ("auto", ())
    assert s.driver.acceleration == 0.0
    s = parse_scene(FOURBAR.replace('name = "B"', 'name = "B"\nassembly = "right"'))
    assert [j.assembly for j in s.joints] == ["left", "left", "right", "left"]


def test_ranges_are_inclusive_and_exact():
    def angles(spec: str):
        return parse_scene(FOURBAR + f"[analysis]\ncrank_angles_deg = {spec}\n").analysis.crank_angles_deg

    assert angles("{ start = 0, stop = 0.3, step = 0.1 }") == (0.0, 0.1, 0.2, 0.3)
    assert angles("{ start = 0, stop = 10, step = 3 }") == (0.0, 3.0, 6.0, 9.0)  # stop not on the grid
    assert angles("{ start = 10, stop = 10, step = 1 }") == (10.0,)
    assert angles("[350, 10.5, -20]") == (350.0, 10.5, -20.0)
    assert angles("45") == (45.0,)
    full = angles("{ start = 0, stop = 360, step = 5 }")
    assert len(full) == 73 and full == tuple(5.0 * i for i in range(73))


def test_speeds_negative_and_rpm():
    s = parse_scene(FOURBAR.replace("speeds_rad_s = [0.0]", "speeds_rad_s = [-1000, 0, 1000]"))
    assert s.driver.speeds == (-1000.0, 0.0, 1000.0)  # negative: clockwise
    s = parse_scene(FOURBAR.replace("speeds_rad_s = [0.0]", "speeds_rpm = [60, -30]"))
    assert s.driver.speeds == pytest.approx((2 * math.pi, -math.pi), rel=1e-15)


def test_petsc_options_are_normalised_to_strings():
    s = parse_scene(
        FOURBAR
        + '[solver]\nmethod = "slepc"\n[solver.petsc]\n"-fkev_pep_tol" = 1e-10\n"-pep_nev" = 8\n'
        + 'fkev_st_type = "sinvert"\npep_view = true\n'
    )
    assert s.solver.method == "slepc"
    assert s.solver.petsc == (("pep_tol", "1e-10"), ("pep_nev", "8"), ("st_type", "sinvert"), ("pep_view", "true"))


def test_a_mass_at_a_single_link_joint_needs_no_link():
    s = parse_scene(FOURBAR + '[[masses]]\njoint = "O2"\nmass_kg = 0.1\n')
    assert [(m.joint, m.link, m.mass) for m in s.masses] == [("O2", "follower", 0.1)]
    assert problems_of(FOURBAR + '[[masses]]\njoint = "A"\nmass_kg = 0.1\n') == [
        "masses[0].link: missing required key (the link that carries the mass)"
    ]


# --------------------------------------------------------------------------------------------
# Bad scenes: one file per class of problem, each with its exact path
# --------------------------------------------------------------------------------------------
BAD = {
    "bad_unknown_key": "analysis.mode: unknown key (did you mean 'analysis.modes'?)",
    "bad_missing_field": "links[1].second_moment_m4: missing required key (set it here or in [link_defaults])",
    "bad_negative_length": "links[1].length_m: must be > 0 (got -0.2)",
    "bad_zero_elements": "links[0].elements: must be >= 1 (got 0)",
    "bad_nonfinite": "link_defaults.youngs_modulus_pa: must be finite (got nan)",
    "bad_bool_number": "link_defaults.area_m2: must be a number, not a boolean (got true)",
    "bad_case_name": "analysis.cases[1]: unknown case (got 'no_coriolus'; did you mean 'no_coriolis'?",
    "bad_case_number": "analysis.cases[2]: case number must be 0-5, in Table 3.1 order (got 6)",
    "bad_joint_reference": "joints[2].connects[1]: unknown link 'folower' (got 'folower.tip'; did you mean 'follower.tip'?)",
    "bad_joint_end": "joints[1].connects[0]: must be '<link>.root', '<link>.tip' or 'ground' (got 'crank.middle'",
    "bad_end_used_twice": "joints[2].connects[0]: link end 'crank.tip' is already connected by joint 'A' (joints[1])",
    "bad_duplicate_name": "links[2].name: duplicate link name 'coupler' (first used at links[1].name)",
    "bad_ground_position": "joints[3].position_m: missing required key (a ground joint needs its [x, y] position)",
    "bad_driver_root": "driver.link: the root of 'coupler' must be at a ground joint (it is at joint 'A')",
    "bad_mass_link": "masses[0].link: unknown link for this joint (got 'follower'; known: 'crank', 'coupler')",
    "bad_angle_range": "analysis.crank_angles_deg.step: must be > 0 (got 0)",
    "bad_petsc_option": "solver.petsc.pep_tol: must be a string, number or boolean (got [1e-10])",
    "bad_mobility": "joints: the linkage has 2 degrees of freedom (3 x 4 links - 10 joint constraints)",
    "bad_links_table": "links: must be an array of tables: write [[links]], not [links]",
    "bad_syntax": "line 11, column 14: TOML syntax error: Illegal character '\\n'",
    "bad_assembly": "analysis.crank_angles_deg[2]: the linkage cannot be assembled for θ in [100.20°, 259.80°]",
}

BAD.update(BAD_LINKAGES)  # the general-linkage keys (tests/test_linkages.py)


def test_every_bad_file_has_a_test():
    files = {p.stem for p in DATA.glob("bad_*.toml")}
    assert files == set(BAD) | {"bad_many"}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_scene_is_reported_with_its_path(name, capsys):
    path = DATA / f"{name}.toml"
    assert main(["check", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "Traceback" not in err
    lines = err.splitlines()
    assert lines[0].startswith(f"{path}: ")
    # The problem line starts with its exact dotted path, then the message with the value.
    assert any(line.startswith("  " + BAD[name]) for line in lines[1:]), err


def test_all_problems_are_reported_at_once():
    with pytest.raises(SceneError) as info:
        load_scene(DATA / "bad_many.toml")
    assert [str(p) for p in info.value.problems] == [
        "links[0].elements: must be >= 1 (got 0)",
        "links[1].length_m: must be > 0 (got -0.2)",
        "driver.speeds_rad_s[1]: must be finite (got nan)",
        "analysis.mode_shape: unknown key (did you mean 'analysis.mode_shapes' or 'analysis.modes'?)",
        "analysis.cases[1]: case number must be 0-5, in Table 3.1 order (got 9)",
        "analysis.modes: must be >= 1 (got 0)",
    ]
    assert str(info.value).startswith(f"{DATA / 'bad_many.toml'}: 6 problems\n  links[0].elements:")


def test_cli_subprocess_reports_every_file_without_traceback(tmp_path):
    (tmp_path / "not-utf8.toml").write_bytes(b'title = "\xff"\n')
    paths = [*sorted(DATA.glob("bad_*.toml")), tmp_path / "missing.toml", tmp_path, tmp_path / "not-utf8.toml"]
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    proc = subprocess.run([*FKEV, "check", *map(str, paths)], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    for p in paths:
        assert f"{p}: " in proc.stderr
    assert f"{tmp_path / 'missing.toml'}: 1 problem\n  file: no such file" in proc.stderr
    assert f"{tmp_path}: 1 problem\n  file: is a directory, not a scene file" in proc.stderr
    assert "  file: is not UTF-8 text (bad byte at offset 9)" in proc.stderr


def test_cli_mixed_good_and_bad_files(capsys):
    good, bad = RUNS / "rotating-cantilever.toml", DATA / "bad_zero_elements.toml"
    assert main(["check", str(good), str(bad)]) == 2
    out, err = capsys.readouterr()
    assert out.startswith(f"{good}: ok (1 link, 1 joint, 16 elements, n_free 48, 1 angle x 7 speeds x 2 cases")
    assert f"{bad}: 1 problem" in err


# --------------------------------------------------------------------------------------------
# More validation rules, checked on the parsed problems directly
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "edit, expected",
    [
        (("elements = 1", "elements = true"), "link_defaults.elements: must be an integer (got true)"),
        (("elements = 1", "elements = 2.0"), "link_defaults.elements: must be an integer (got 2.0)"),
        (('name = "crank"', 'name = "cr.ank"'), "links[0].name: must not contain '.' or be 'ground' (got 'cr.ank')"),
        (('name = "B"', 'name = "A"'), "joints[2].name: duplicate joint name 'A' (first used at joints[1].name)"),
        (('connects = ["crank.tip", "coupler.root"]', 'connects = ["crank.tip", "coupler.root"]\nposition_m = [1, 0]'),
         "joints[1].position_m: only a joint with 'ground' in connects takes a position"),
        (('connects = ["ground", "crank.root"]', 'connects = ["crank.root"]'),
         "joints[0].connects: must be a list of at least two of '<link>.root', '<link>.tip', 'ground'"
         " (got ['crank.root'])"),
        (("position_m = [0.0, 0.0]", "position_m = [0.0, inf]"), "joints[0].position_m[1]: must be finite (got inf)"),
        (("position_m = [0.0, 0.0]", "position_m = [0.0]"), "joints[0].position_m: must be a pair [x, y] (got [0.0])"),
        (('[[joints]]\nname = "B"', '[[joints]]\nname = "B"\nassembly = "up"'),
         "joints[2].assembly: must be one of 'left', 'right' (got 'up')"),
        (('[[joints]]\nname = "B"', '[[joints]]\nname = "B"\ntype = "slider"'),
         "joints[2].type: must be one of 'revolute', 'prismatic' (got 'slider')"),
        (('[[joints]]\nname = "B"', '[[joints]]\nname = "B"\ntype = "prismatic"'),
         "joints[2].connects: a prismatic joint connects 'ground' (its guide) and exactly one link end"),
        (('link = "crank"', 'link = "crnk"'), "driver.link: unknown link (got 'crnk'; did you mean 'crank'?"),
        (("speeds_rad_s = [0.0]", "speeds_rad_s = []"), "driver.speeds_rad_s: must not be empty"),
        (("speeds_rad_s = [0.0]", 'speeds_rad_s = "fast"'),
         "driver.speeds_rad_s: must be a list of numbers or a table {start, stop, step} (got 'fast')"),
        (("speeds_rad_s = [0.0]", "speeds_rad_s = [0.0]\nspeeds_rpm = [1]"),
         "driver.speeds_rpm: give speeds_rad_s or speeds_rpm, not both"),
        (("speeds_rad_s = [0.0]", ""), "driver.speeds_rad_s: missing required key (or give speeds_rpm)"),
        (("youngs_modulus_pa = 2.07e11", 'youngs_modulus_pa = "2.07e11"'),
         "link_defaults.youngs_modulus_pa: must be a number, not a string (got '2.07e11')"),
        (("[link_defaults]", "modes = 3\n[link_defaults]"),
         "modes: unknown key (did you mean 'analysis.modes'? it belongs in [analysis])"),
    ],
)
def test_rule(edit, expected):
    old, new = edit
    assert FOURBAR.count(old) >= 1
    problems = problems_of(FOURBAR.replace(old, new, 1))
    assert any(p.startswith(expected) for p in problems), problems


@pytest.mark.parametrize(
    "analysis, expected",
    [
        ("crank_angles_deg = { start = 0, stop = -10, step = 5 }",
         "analysis.crank_angles_deg.stop: must be >= start (got -10 < 0)"),
        ("crank_angles_deg = { start = 0, stop = 10 }", "analysis.crank_angles_deg.step: missing required key"),
        ("crank_angles_deg = { start = 0, stop = 10, step = 1, stpe = 2 }",
         "analysis.crank_angles_deg.stpe: unknown key (did you mean 'analysis.crank_angles_deg.stop'"
         " or 'analysis.crank_angles_deg.step'?)"),
        ("crank_angles_deg = { start = 0, stop = 10, step = 1e-9 }",
         "analysis.crank_angles_deg.step: gives 10000000001 values, more than 1000000 (got 1e-09)"),
        ("crank_angles_deg = [0, nan]", "analysis.crank_angles_deg[1]: must be finite (got nan)"),
        ("modes = 0", "analysis.modes: must be >= 1 (got 0)"),
        ("modes = 2.5", "analysis.modes: must be an integer (got 2.5)"),
        ("mode_shapes = 1", "analysis.mode_shapes: must be true or false (got 1)"),
        ("imag_tol = -1e-3", "analysis.imag_tol: must be >= 0.0 (got -0.001)"),
        ("damping_tol = 2", "analysis.damping_tol: must be < 1.0 (got 2)"),
        ("cases = []", "analysis.cases: must not be empty"),
        ("cases = 1.0", "analysis.cases: must be a case name or a Table 3.1 number 0-5 (got 1.0)"),
        ("cases = [true]", "analysis.cases[0]: must be a case name or a Table 3.1 number 0-5 (got true)"),
        ("cases = 'everything'", "analysis.cases: unknown case (got 'everything';"),
    ],
)
def test_analysis_rule(analysis, expected):
    problems = problems_of(FOURBAR + "[analysis]\n" + analysis + "\n")
    assert any(p.startswith(expected) for p in problems), problems


@pytest.mark.parametrize(
    "solver, expected",
    [
        ("n_mode = 3", "solver.n_mode: unknown key (did you mean 'analysis.modes'? it belongs in [analysis])"),
        ("pep_type = 'toar'", "solver.pep_type: unknown key (PETSc options go in [solver.petsc])"),
        ("method = 'slep'", "solver.method: must be one of 'auto', 'slepc', 'dense' (got 'slep'; did you mean 'slepc'?)"),
        ("petsc = 3", "solver.petsc: must be a table [solver.petsc] (got 3)"),
        ("[solver.petsc]\npep_tol = inf", "solver.petsc.pep_tol: must be finite (got inf)"),
        ("[solver.petsc]\npep_type = 'toar'\n'-fkev_pep_type' = 'linear'",
         "solver.petsc.-fkev_pep_type: option 'pep_type' given twice"),
        ("[solver.petsc]\n'st.type' = 'sinvert'", "solver.petsc.st.type: not a PETSc option name (got 'st.type'"),
        ("[solver.petsc]\nst.type = 'sinvert'",
         "solver.petsc.st: must be a string, number or boolean (got {type = 'sinvert'}) (quote option names"),
    ],
)
def test_solver_rule(solver, expected):
    problems = problems_of(FOURBAR + "[solver]\n" + solver + "\n")
    assert any(p.startswith(expected) for p in problems), problems


def test_topology_rules():
    # A link hanging off nothing: not connected to ground, and the linkage is not single-DOF.
    text = FOURBAR + '[[links]]\nname = "loose"\nlength_m = 0.1\n'
    assert problems_of(text) == [
        "links[3]: link 'loose' is not connected to ground through any joint",
        "joints: the linkage has 4 degrees of freedom (3 x 4 links - 8 joint constraints);"
        " a single driver needs exactly 1",
    ]
    # Both ends of one link in one joint; 'ground' twice.
    text = FOURBAR.replace('["crank.tip", "coupler.root"]', '["crank.tip", "crank.root"]')
    assert "joints[1].connects[1]: joint connects link 'crank' to itself (got 'crank.root')" in problems_of(text)
    text = FOURBAR.replace('["ground", "crank.root"]', '["ground", "ground", "crank.root"]')
    assert "joints[0].connects[1]: 'ground' listed twice" in problems_of(text)


def test_required_sections_and_top_level():
    assert problems_of('title = 1\n') == [
        "title: must be a string (got 1)",
        "links: missing required key (add at least one [[links]] table)",
        "joints: missing required key (add at least one [[joints]] table)",
        "driver: missing required key (add a [driver] table)",
    ]
    problems = problems_of(FOURBAR + "[analysis]\nmodes = 3\n[analysys]\nmodes = 3\n")
    assert problems == ["analysys: unknown key (did you mean 'analysis'?)"]
    problems = problems_of(FOURBAR.replace('[link_defaults]', '[link_defaults]\nname = "x"'))
    assert problems == ["link_defaults.name: links need their own names; set name in each [[links]]"]


def test_load_scene_file_problems(tmp_path):
    bad = tmp_path / "syntax.toml"
    bad.write_text('title = "x"\nmodes = = 3\n')
    with pytest.raises(SceneError) as info:
        load_scene(bad)
    (problem,) = info.value.problems
    assert problem.path == "line 2, column 9" and problem.message.startswith("TOML syntax error: ")
    with pytest.raises(SceneError) as info:
        load_scene(tmp_path / "nope.toml")
    assert str(info.value) == f"{tmp_path / 'nope.toml'}: 1 problem\n  file: no such file"


def test_check_reports_an_impossible_crank_angle_after_a_clean_schema(capsys):
    # Non-Grashof: crank 0.2, coupler 0.2, follower 0.15, ground 0.254. At 180 deg the
    # distance A-O2 is 0.454 > 0.35 = coupler + follower; at 0 and 90 deg it closes.
    path = DATA / "bad_assembly.toml"
    load_scene(path)  # the schema itself is fine
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"{path}: 1 problem"
    # one line per interval (closed form: cos θ = (0.2² + 0.254² - 0.35²) / (2 · 0.2 · 0.254))
    assert err[1].startswith("  analysis.crank_angles_deg[2]: the linkage cannot be assembled for θ in [100.20°, 259.80°]")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))


def test_a_dropped_link_defaults_header_gives_one_line_per_key_not_per_link():
    """Without its [link_defaults] header the section keys become unknown top-level keys and
    every link misses them: one line per key names all the links (8 lines, not 16)."""
    text = (ROOT / "runs" / "bahgat-willmert-1976.toml").read_text().replace("[link_defaults]\n", "", 1)
    got = problems_of(text)
    assert len(got) == 8
    assert "links[0, 1, 2].area_m2: missing required key (set it here or in [link_defaults])" in got
    assert sum("belongs in [link_defaults]" in p for p in got) == 4
    # one link's problem keeps its own path: tests/data/bad_missing_field.toml (BAD above)


def test_a_re_meshed_scene_names_its_mesh_in_its_title():
    """--elements re-meshes the links; the title, which heads every report, figure and archive,
    then names the mesh analysed (the Bahgat-Willmert file's own title names its 5 elements), with
    one tag however often re-meshed, and none where the mesh is the file's."""
    scene = load_scene(RUNS / "bahgat-willmert-1976.toml")
    four = with_elements(scene, 4)
    assert four.title == f"{scene.title} [re-meshed: 12 el (4+4+4)]"
    assert with_elements(four, (2, 3, 4)).title == f"{scene.title} [re-meshed: 9 el (2+3+4)]"
    same = tuple(lk.elements for lk in scene.links)
    assert with_elements(scene, same).title == scene.title
