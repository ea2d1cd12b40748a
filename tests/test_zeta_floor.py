"""The damping a Floquet verdict answers for (docs/stability.md, "The damping a verdict answers for"):
a damped scene's own (its monodromies include it), an undamped scene's reporting floor
``zeta_floor`` against which each band's ζ* says whether real damping keeps it."""

from __future__ import annotations

import json
import math

import pytest

from fkev_slepc.periodic.bands import Band, survives_damping
from fkev_slepc.periodic.settings import DEFAULTS, PeriodicSettings, SettingsError, resume_refusal
from fkev_slepc.scene.model import Damping

from clitools import ROOT, fkev

BW = ROOT / "runs" / "bahgat-willmert-1976.toml"
BW_DAMPED = ROOT / "runs" / "bahgat-willmert-damped.toml"


def _band(zeta: float) -> Band:
    return Band(459.5, 461.5, peak_speed=460.0, peak_max_abs=1.096, resonance="(ω̄3-ω̄2)/4", suppressing_damping=zeta)


def test_the_rule_keeps_a_damped_scenes_bands_and_holds_undamped_ones_against_the_floor():
    assert survives_damping(_band(1e-6), True, 1e-4) is True  # the monodromy included the damping
    assert survives_damping(_band(1.1e-3), False, 1e-4) is True
    assert survives_damping(_band(1.1e-3), False, 5e-3) is False
    assert survives_damping(_band(math.nan), False, 1e-4) is None  # no ζ*: never dropped
    assert survives_damping(_band(1e-9), False, 0.0) is True  # floor 0: every band


def test_the_floor_is_a_checked_archived_setting_that_a_resume_may_change():
    assert DEFAULTS.zeta_floor == 1e-4
    with pytest.raises(SettingsError, match=r"zeta_floor: must be in \[0, 1\) \(got -0.001\)"):
        PeriodicSettings(zeta_floor=-1e-3)
    assert PeriodicSettings.from_attrs(PeriodicSettings(zeta_floor=0.0).to_attrs()).zeta_floor == 0.0
    assert resume_refusal(DEFAULTS, PeriodicSettings(zeta_floor=0.01), "floquet") is None
    attrs = DEFAULTS.to_attrs()
    del attrs["zeta_floor"]  # an archive written before the floor existed
    assert PeriodicSettings.from_attrs(attrs).zeta_floor == DEFAULTS.zeta_floor


def test_rayleigh_modal_damping_ratio():
    d = Damping(2.0, 1e-5)
    assert d.ratio(100.0) == pytest.approx(2.0 / 200.0 + 1e-5 * 50.0, rel=1e-15)
    # the ratio is smallest at ω = sqrt(α/β), where it is sqrt(αβ)
    assert float(d.ratio(math.sqrt(2.0 / 1e-5))) == pytest.approx(math.sqrt(2e-5), rel=1e-12)


def test_an_undamped_band_is_listed_against_the_floor_and_a_resume_re_reports_it(tmp_path):
    """The (ω̄3-ω̄2)/4 band of the thesis linkage at 1 el/link needs ζ* = 1.1e-3 (Re s = 6.74 1/s)."""
    out = tmp_path / "f.h5"
    args = ["floquet", BW, "--elements", "1", "--speeds", "455:465:5", "-o", out, "--no-critical", "--json", "-q"]
    r = fkev(*args, "--zeta-floor", "0.005")
    assert r.returncode == 0, r.stderr
    o = json.loads(r.stdout)
    assert o["damping"] == {"answers_for": "undamped scene, reporting floor", "mass_proportional_1_s": 0.0,
                            "stiffness_proportional_s": 0.0, "zeta_floor": 0.005, "modal_zeta_min": None,
                            "modal_zeta_max": None}
    [band] = o["bands"]
    assert 1e-3 < band["suppressing_damping_ratio"] < 1.2e-3
    assert band["survives_damping"] is False and o["bands_surviving_damping"] == 0
    # the full model at every speed: no truncation, so no "not converged" 0 (issue 36: it said 0)
    assert o["basis_size"] == [0, 0, 0] and o["truncation_converged"] == [None] * 3
    r = fkev(*args[:-2], "--resume", "--zeta-floor", "0.001")  # a floor is a refinement: the resume is allowed
    assert r.returncode == 0, r.stderr
    assert "held against the floor ζ = 0.001 (--zeta-floor): 1 of 1 unstable run survive it" in r.stdout
    assert "closed by real damping" not in r.stdout


def test_a_damped_scene_states_its_modal_damping_and_keeps_every_band(tmp_path):
    r = fkev("floquet", BW_DAMPED, "--elements", "1", "--speeds", "455:465:5", "-o", tmp_path / "d.h5", "--no-critical",
             "--json", "-q")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)["damping"]
    assert d["answers_for"] == "scene damping" and d["zeta_floor"] is None
    # the scene is Rayleigh damping of 1 % at modes 1 and 3 of the 5-element mesh: between them less, outside more
    assert 0.005 < d["modal_zeta_min"] < 0.01 < d["modal_zeta_max"] < 0.05
    assert all(b["survives_damping"] is True for b in json.loads(r.stdout)["bands"])


def test_a_bad_floor_is_refused_before_work(tmp_path):
    r = fkev("floquet", BW, "--elements", "1", "--speeds", "460", "-o", tmp_path / "x.h5", "--zeta-floor", "1.5")
    assert r.returncode == 2
    assert "--zeta-floor" in r.stderr and "1.5" in r.stderr
    assert not (tmp_path / "x.h5").exists()
