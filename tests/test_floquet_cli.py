"""``fkev floquet`` and the scenes of the cycle (Floquet) verdict (docs/stability.md)."""

from __future__ import annotations

import math
from pathlib import Path

from fkev_slepc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "runs"
BENCH = RUNS / "slider-crank-benchmark.toml"


def test_benchmark_slider_crank_has_the_classical_proportions():
    """runs/slider-crank-benchmark.toml: steel crank 0.15 m and rod 0.3 m of solid Ø 6 mm circular
    section (A = πd²/4, I = πd⁴/64 to 1e-6), a massless in-line slider, driven at 150 rad/s."""
    sc = load_scene(BENCH)
    d = 0.006
    links = {link.name: link for link in sc.links}
    assert sorted(links) == ["crank", "rod"]
    assert (links["crank"].length, links["rod"].length) == (0.15, 0.3)
    for link in links.values():
        assert math.isclose(link.area, math.pi * d**2 / 4, rel_tol=1e-6)
        assert math.isclose(link.second_moment, math.pi * d**4 / 64, rel_tol=1e-6)
        assert (link.youngs_modulus, link.density) == (2.0e11, 7870.0)
    slider = [j for j in sc.joints if j.prismatic]
    assert len(slider) == 1 and slider[0].slider_mass == 0.0 and slider[0].guide_angle == 0.0
    assert 150.0 in sc.driver.speeds


def test_frozen_time_outputs_say_so_and_point_to_floquet():
    """fkev point labels its verdict frozen-time, prints no growth "per crank revolution" stretched
    from a frozen eigenvalue, and names the fkev floquet command of the cycle verdict; its JSON
    carries stability_scope.time and no growth_per_revolution; fkev critical's speeds are frozen-time."""
    import json

    from clitools import BW, fkev

    r = fkev("point", BW, "--angle", "10", "--speed", "1000", "--case", "full")
    assert r.returncode == 0, r.stderr
    assert "frozen-time status: unstable" in r.stdout and "per crank revolution is" not in r.stdout
    assert "per crank revolution)" not in r.stdout and " x1.0" not in r.stdout
    assert f"fkev floquet {BW} --speeds 1000 --case full" in r.stdout
    out = json.loads(fkev("point", BW, "--angle", "10", "--speed", "1000", "--case", "full", "--json").stdout)
    assert "growth_per_revolution" not in out and out["stability_scope"]["time"].startswith("frozen-time")
    rest = fkev("point", BW, "--angle", "10", "--speed", "0", "--case", "structure")
    assert rest.returncode == 0 and "fkev floquet" not in rest.stdout  # at rest the frozen verdict is exact
    crit = fkev("critical", RUNS / "turcic-midha-1984.toml", "--case", "full", "--angle", "10")
    assert "frozen-time flutter" in crit.stdout and "fkev floquet" in crit.stdout, crit.stderr


def test_info_labels_its_regions_frozen_time(tmp_path):
    """fkev info: the unstable regions are frozen-time, with no growth per revolution stretched from a
    frozen eigenvalue, and a 'cycle' line names the fkev floquet command of the archived speeds."""
    from clitools import BW, fkev

    out = tmp_path / "bw.h5"
    r = fkev("run", BW, "-q", "-o", out, "--angles", "0,10", "--speeds", "0,1000", "--cases", "full")
    assert r.returncode == 0, r.stderr
    info = fkev("info", out).stdout
    assert "unstable/divergent regions (frozen-time):" in info
    region = next(ln for ln in info.splitlines() if ln.strip().startswith("unstable  full at 1000 rad/s"))
    assert "frozen-time, not a growth per revolution" in region and " x1." not in region
    cycle = next(ln for ln in info.splitlines() if ln.strip().startswith("cycle"))
    assert cycle.endswith(f"fkev floquet {BW} --speeds 1000")
