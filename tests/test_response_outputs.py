"""Outputs of fkev response (docs/response.md §4-5): station stresses from the section's fibre
distance, the response vs speed with forced-resonance speeds, the figures and the GIF."""

import numpy as np
import pytest
from clitools import ROOT
from PIL import Image

from fkev_slepc.api import Study
from fkev_slepc.api.response_speeds import forced_resonances
from fkev_slepc.scene import SceneError, load_scene, with_elements

BENCH = ROOT / "runs" / "slider-crank-benchmark-stiff-crank.toml"


@pytest.fixture(scope="module")
def bench():
    return Study(with_elements(load_scene(BENCH), (1, 2))).response(150.0, angles_deg=np.arange(0, 360, 30.0),
                                                                    harmonics=16, shoot=False)


def test_stress_from_fibre_distance_and_envelopes(bench):
    sr = bench.stations
    c, d = 0.003, 0.006
    A, I = np.pi * d**2 / 4, np.pi * d**4 / 64
    rod = [k for k, st in enumerate(sr.stations) if st.link == 1]
    expect = np.abs(sr.axial_force[:, rod]) / 2.827433e-5 + np.abs(sr.moment[:, rod]) * c / 6.361725e-11
    np.testing.assert_allclose(sr.stress[:, rod], expect, rtol=1e-12)
    assert abs(A / 2.827433e-5 - 1) < 1e-6 and abs(I / 6.361725e-11 - 1) < 1e-6  # the scene's values
    d = bench.as_dict()
    mid = d["stations"][4]
    assert (mid["link"], mid["s_m"]) == ("rod", 0.15)
    assert mid["envelope"]["transverse_chord_m"][1] == pytest.approx(max(mid["transverse_chord_m"]))
    assert d["peak_stress"]["stress_pa"] == pytest.approx(np.nanmax(sr.stress))
    # the chord deflection vanishes at the link's ends, the moment nearly (pinned: h-dependent)
    assert np.abs(sr.transverse_chord[:, rod[0]]).max() == 0.0


def test_figures_and_animation(bench, tmp_path):
    fig = bench.plot("deflected")
    assert "× " in fig._suptitle.get_text()
    assert len(bench.plot("stations").axes[0].lines) == 6
    gif = bench.animate(tmp_path / "a.gif")
    with Image.open(gif) as im:
        assert im.n_frames == 12


def test_forced_resonance_speeds():
    speeds = np.array([100.0, 200.0, 300.0])
    wbar = np.array([[450.0], [450.0], [450.0]])  # n Ω = 450: Ω = 225 (n = 2), 150 (n = 3), 112.5 (n = 4)
    found = forced_resonances(speeds, wbar, orders=4)
    assert [(r["order"], round(r["speed_rad_s"], 9)) for r in found] == [(4, 112.5), (3, 150.0), (2, 225.0)]


def test_response_vs_speed_and_bad_speeds(tmp_path):
    st = Study(with_elements(load_scene(BENCH), (1, 2)))
    sp = st.response_vs_speed([50.0, 150.0], harmonics=12, angles_deg=np.arange(0, 360, 45.0))
    assert sp.peak_chord.shape == (2, 6) and sp.peak_chord[1, 4] > 5 * sp.peak_chord[0, 4]  # ~ Ω²
    assert sp.mean_frequencies.shape == (2, 4)
    assert sp.plot().axes
    import xarray as xr

    ds = xr.open_dataset(sp.save(tmp_path / "s.h5"), engine="h5netcdf")
    np.testing.assert_array_equal(ds["peak_transverse_chord_m"].values, sp.peak_chord)
    with pytest.raises(SceneError, match="speeds_rad_s"):
        st.response_vs_speed([150.0, 50.0])
