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
