"""Every figure kind fits its figure (issue 27): drawn on a narrow speed range (3 speeds 5 rad/s
apart) and on a wide one (0-2000 rad/s), on a crank-rocker and a slider-crank, no title, label,
tick label, annotation or legend leaves the figure, no two labels overlap, no data axes is
squeezed (tests/figcheck.py measures the drawn extents with the Agg renderer).

The data are real: small sweeps (`fkev run`, 3 elements, 4 angles, 4 cases, dense), responses and loads of
the stiff-crank benchmark, and Floquet runs whose monodromy is the Mathieu oscillator of
tests/test_floquet_cli.py (tongues at Ω = 2ω₀/n crowd towards low speed: many band labels).
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from figcheck import assert_clean, problems
from matplotlib.figure import Figure

from fkev_slepc.archive.reader import load
from fkev_slepc.plots import draw as plots
from fkev_slepc.plots.bands import band_campbell

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "runs"
SCENES = {"crank-rocker": RUNS / "bahgat-willmert-1976.toml", "slider-crank": RUNS / "slider-crank.toml"}
RANGES = {"narrow": "500,505,510", "wide": "0:2000:400"}  # rad/s; the slider-crank's in rpm (rpm axes drawn too)
RANGES_RPM = {"narrow": "4775,4823,4870", "wide": "0:19000:3800"}
ANGLES = "0,10,120,240"  # 10: the default angle of the one-angle kinds
CASES = "structure,full,no_coriolis,no_pseudo_normal"  # param-speed needs structure, error-angle full


def test_the_checker_finds_clipped_and_overlapping_labels():
    """A title hanging off the figure, two annotations on one spot, crowded tick labels and a
    squeezed axes are each reported; a plain figure is clean."""
    fig = Figure(figsize=(4, 3), layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("x")
    assert problems(fig) == []
    ax.set_title("a title far wider than this small figure can show on one line, clipped at both ends")
    ax.annotate("band A", (0.5, 0.5))
    ax.annotate("band B", (0.5, 0.5))
    ax.set_yticks(np.linspace(0, 1, 60))
    found = "\n".join(problems(fig))
    assert "outside the figure: Text 'a title far wider" in found
    assert "labels overlap: Annotation 'band A' and Annotation 'band B'" in found
    assert "tick labels overlap on axes 0 y" in found
    tiny = Figure(figsize=(4, 3), layout="constrained")
    tiny.subplots(1, 2, width_ratios=(12, 1))
    assert any(p.startswith("squeezed axes") for p in problems(tiny))


# ---------------------------------------------------------------- `fkev plot` kinds, margins bands
@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    from test_plots import fkev

    d = tmp_path_factory.mktemp("layout")
    out = {}
    for scene, path in SCENES.items():
        for rng, speeds in RANGES.items():
            out[scene, rng] = d / f"{scene}-{rng}.h5"
            grid = ("--speeds", speeds) if scene == "crank-rocker" else ("--speeds-rpm", RANGES_RPM[rng])
            fkev("run", path, "-o", out[scene, rng], "--elements", 1, "--angles", ANGLES, *grid, "--cases", CASES,
                 "--modes", 3, "--mode-shapes", "--solver", "dense", "--quiet", check=False)
    return {k: load(v) for k, v in out.items()}


@pytest.mark.parametrize("rng", RANGES)
@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("kind", plots.KINDS)
def test_every_plot_kind_fits_on_narrow_and_wide_ranges(archives, kind, scene, rng):
    res = archives[scene, rng]
    assert res.speed_rad_s.size == (3 if rng == "narrow" else 6) and res.crank_angle_deg.size == 4
    assert res.speeds_in_rpm == (scene == "slider-crank")
    assert res.speed_rad_s.max() < 520 if rng == "narrow" else res.speed_rad_s.max() > 1980
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. a Campbell diagram of few speeds: said in its title
        assert_clean(plots.draw(res, kind), f"{kind} {scene} {rng}")


@pytest.mark.parametrize("rng", RANGES)
def test_margins_band_campbell_with_operating_speed_fits(archives, rng):
    """`fkev margins --plot`: the band Campbell with the operating speed marked, all 48 orders."""
    res = archives["slider-crank", rng]
    assert_clean(band_campbell(res, speed=float(res.speed_rad_s[-1]), orders=48), f"bands {rng}")


# ----------------------------------------------------------------------------- Floquet speed map
@pytest.fixture(scope="module")
def floquet_maps(tmp_path_factory):
    """Floquet runs on the rotating cantilever's frozen sweep with the Mathieu monodromy,
    ω₀ = 500 rad/s and ε = 0.4: narrow (3 speeds inside the 2ω₀/1 tongue), wide (100-2000 rad/s,
    finer below 400 where the tongues 2ω₀/n, n = 3..7, crowd)."""
    import test_floquet_cli as tf

    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.sweep import floquet_run as fr
    from fkev_slepc.sweep.grid import configure

    d = tmp_path_factory.mktemp("floquet_layout")
    mp = pytest.MonkeyPatch()
    mp.setattr(tf, "OMEGA0", 500.0)
    mp.setattr(fr, "_mean_frequencies", lambda part: (lambda w: [500.0]))
    try:
        out = {}
        for rng, speeds in (("narrow", [990.0, 995.0, 1000.0]), ("wide", np.r_[100:400:4, 400:2001:50].tolist())):
            scene = configure(with_elements(load_scene(tf.CANTILEVER), 2), angles=[0, 180], speeds=speeds,
                              cases=["full"])
            path = fr.run_floquet(fr.FloquetRequest(scene, d / f"{rng}.h5", rtol=1e-3),
                                  evaluator=lambda *a: tf.mathieu_evaluator(*a, eps=0.4))
            out[rng] = fr.read_floquet(path)
    finally:
        mp.undo()
    return out


@pytest.mark.parametrize("rng", ["narrow", "wide"])
def test_floquet_speed_map_fits(floquet_maps, rng):
    from fkev_slepc.plots.floquet import speed_map

    res = floquet_maps[rng]
    assert len(res.bands) >= (1 if rng == "narrow" else 4)  # the wide range crowds its band labels
    lo, hi = res.speed_rad_s[0], res.speed_rad_s[-1]  # fkev floquet also marks the frozen-time critical speeds
    res = replace(res, extras={"frozen_time_critical": {"flutter_speed_rad_s": lo + 0.3 * (hi - lo),
                                                        "divergence_speed_rad_s": lo + 0.8 * (hi - lo)}})
    fig = speed_map(res)
    assert_clean(fig, f"Floquet map {rng}")
    labels = {t.get_text() for t in fig.axes[0].texts}
    assert labels and labels <= {b.resonance for b in res.bands}
    # combination resonances have the longest labels: fewer fit, none overlaps
    long = replace(res, bands=tuple(replace(b, resonance=f"(ω̄1+ω̄2)/{k + 1}") for k, b in enumerate(res.bands)))
    assert_clean(speed_map(long), f"Floquet map {rng}, combination labels")


# ------------------------------------------------------------------------- response and loads
BENCH = RUNS / "slider-crank-benchmark-stiff-crank.toml"


@pytest.fixture(scope="module")
def bench():
    from fkev_slepc.api import Study
    from fkev_slepc.scene import load_scene, with_elements

    return Study(with_elements(load_scene(BENCH), (1, 2)))


@pytest.mark.parametrize("speed", [150.0, 2000.0])
def test_response_and_loads_figures_fit(bench, speed):
    r = bench.response(speed, angles_deg=np.arange(0, 360, 30.0), harmonics=8, shoot=False)
    assert_clean(r.plot("deflected"), f"deflected {speed:g}")
    assert_clean(r.plot("stations"), f"stations {speed:g}")
    assert_clean(bench.loads(speed).plot(), f"loads {speed:g}")


@pytest.mark.parametrize("rng", ["narrow", "wide"])
def test_response_vs_speed_figure_fits(bench, rng):
    speeds = [140.0, 145.0, 150.0] if rng == "narrow" else np.linspace(100.0, 2000.0, 8).tolist()
    sp = bench.response_vs_speed(speeds, harmonics=8, angles_deg=np.arange(0, 360, 45.0))
    assert rng == "narrow" or len(sp.resonances) >= 5  # the wide range has resonance labels to place
    assert_clean(sp.plot(bands=[(speeds[0], speeds[1])]), f"response vs speed {rng}")


def test_point_mode_shapes_figure_fits(bench):
    """``fkev point`` / ``PointResult.plot``: the mode shapes of one frozen point, slider guide drawn."""
    r = bench.point(30.0, 2000.0, "full", shapes=True, solver="dense")
    assert_clean(r.plot(), "point mode shapes")
