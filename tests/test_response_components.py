"""The periodic response on link-frame component modes (fkev_slepc/periodic/component_response.py;
docs/response.md §3.1): every mode kept is the full model, fewer modes converge to it as the modes
per link double, and the static correction of the dropped modes is what makes the stress converge.
Light Rayleigh damping so that the harmonic balance converges at a small H (undamped, a dense web
of high FE modes meets the load's harmonics)."""

from dataclasses import replace

import numpy as np
import pytest
from clitools import ROOT
from clitools import fkev as run_fkev

from fkev_slepc.model.operators import Model
from fkev_slepc.periodic.component_response import changes, component_response, response_reduction
from fkev_slepc.periodic.components import link_components
from fkev_slepc.periodic.response import periodic_response
from fkev_slepc.periodic.stations import element_end_stations, station_response
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.scene.model import Damping

RUNS = ROOT / "runs"


def bw_system(elements, w, beta):
    sc = replace(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), elements), damping=Damping(0.0, beta))
    model = Model(sc, cases=("full",))
    return model, PeriodicSystem(model, w, "full")


def test_every_mode_kept_is_the_full_model_on_the_thesis_mesh():
    """Bahgat-Willmert, thesis mesh (9 DOFs), 300 rad/s, β = 1e-5, H = 96 (the harmonic tail 1e-10):
    with every fixed-interface mode kept W(θ) is square and the projection a change of variables.
    Deflection, bending moment, axial and shear force at every element end (the elastic forces at
    the pins) agree with the full model's to 1e-8 of their peaks (measured 1.4e-11 on q)."""
    model, s = bw_system(1, 300.0, 1e-5)
    full = periodic_response(s, 300.0, harmonics=96, reduce="none")
    red = periodic_response(s, 300.0, harmonics=96, reduce="links")
    assert red.truncation is not None and red.truncation.value == 0.0 and red.truncation.converged
    assert red.truncation.basis == model.n_free
    theta = np.radians(np.arange(0.0, 360.0, 5.0))
    qa, qb = full.hb.at(theta), red.hb.at(theta)
    assert np.abs(qa - qb).max() <= 1e-8 * np.abs(qa).max()
    ends = element_end_stations(model.mechanism)
    sa, sb = (station_response(model, theta, q, ends) for q in (qa, qb))
    for key in ("moment", "axial_force", "shear", "transverse", "axial"):
        a, b = getattr(sa, key), getattr(sb, key)
        assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), key


def test_modes_per_link_doubled_converge_to_the_full_model_with_the_static_correction():
    """Bahgat-Willmert at 4 elements per link (36 DOFs, 10-11 interior DOFs per link), 50 rad/s,
    β = 1e-4, H = 16: 1 and 4 modes per link against every mode kept (the full model in component
    coordinates, previous test), relative change of the bending moment (no fibre distance) at the
    element ends over 72 angles. Measured for 1, 2, 4, 8 modes per link with the static correction
    7.0e-4, 1.6e-4, 1.1e-4, 4.5e-5 (about halved per doubling past 2: rate ~ k^-0.9), without it
    2.2e-2, 5.3e-3, 3.6e-3, 1.5e-3: the correction gains 31x at one mode per link, 32x at 8."""
    model, s = bw_system(4, 50.0, 1e-4)
    top = int(link_components(model).interior.max())
    ref = component_response(s, 50.0, top, harmonics=16)
    corrected = [changes(model, component_response(s, 50.0, k, harmonics=16), ref)[0] for k in (1, 4)]
    bare = changes(model, component_response(s, 50.0, 1, harmonics=16, correct=False), ref)[0]
    assert corrected[0] < 1.5e-3 and corrected[1] < 2e-4 and corrected[1] < corrected[0] / 4
    assert bare > 10 * corrected[0]


def test_reduce_values_and_the_default_switch():
    model, _ = bw_system(1, 100.0, 0.0)
    assert response_reduction(model, None) is None and response_reduction(model, "default") is None
    assert response_reduction(model, "links:3") == "links:3" and response_reduction(model, "none") is None
    for bad in ("auto", "4", "links:x"):
        with pytest.raises(ValueError, match="default, none, links or links:N"):
            response_reduction(model, bad)
    big = Model(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), 6), cases=("full",))
    assert big.n_free > 48 and response_reduction(big, None) == "links"


def test_cli_reduce_flag_names_a_bad_value():
    r = run_fkev("response", RUNS / "slider-crank-benchmark.toml", "--elements", "1", "--reduce", "auto")
    assert r.returncode == 2 and "--reduce" in r.stderr and "auto" in r.stderr
