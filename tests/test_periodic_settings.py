"""One frozen PeriodicSettings (issue 24, Deliver 1 "settings"): every periodic tolerance in one object,
validated when made, archived whole (``/floquet/settings``, ``/response/settings``) and compared whole
on ``--resume``. Lean: Bahgat–Willmert on the thesis mesh (one element per link), one speed, four angles."""

from dataclasses import fields, replace

import h5py
import numpy as np
import pytest
from clitools import BW, digest, edited, fkev

from fkev_slepc.model.operators import Model
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.periodic.settings import (
    DEFAULTS, PeriodicSettings, SettingsError, checked_settings, resume_refusal,
)
from fkev_slepc.scene import SceneError, load_scene, with_elements

FLOQUET = ("floquet", BW, "--elements", "1", "--speeds", "100", "--angles", "0:360:90", "--no-critical",
           "--reduce", "none")
# one bad value per field: wrong type, out of range or not a choice
BAD = {"magnus_order": 5, "monodromy_tol": 0.0, "steps": -1, "max_steps": 0, "samples": 1, "interp_tol": 1.0,
       "max_samples": 1, "reduce": "half", "basis_angles": 0, "threshold": float("nan"), "reduce_tol": -1e-3,
       "max_basis": 2.5, "verdict_tol": 2.0, "edge_rtol": float("inf"), "resonance_order": -1, "probe": "yes",
       "harmonics": 1, "harmonic_tol": "1e-8", "shoot": 1, "shooting_tol": 0.0, "response_angles_deg": [0.0, np.nan],
       "auto_modes": 0, "link_modes": 1.5, "auto_min_steps": -1, "links_step_ratio": 0.0, "full_max_dofs": True,
       "attract_tol": 1e-8j, "zeta_floor": -1e-4, "moving_modes": 0, "moving_angles": 4}


def test_round_trip_through_hdf5_attributes_is_exact(tmp_path):
    """Every field of a non-default settings object written as HDF5 attributes reads back equal,
    type for type; diff names exactly the fields changed, with both values."""
    s = PeriodicSettings(magnus_order=4, monodromy_tol=3e-11, steps=64, samples=8, reduce=12, max_basis=40,
                         verdict_tol=1e-7, probe=True, harmonics=16, shoot=True, response_angles_deg=(0.0, 90.5, 181.0))
    with h5py.File(tmp_path / "s.h5", "w") as f:
        f.create_group("settings").attrs.update(s.to_attrs())
    with h5py.File(tmp_path / "s.h5", "r") as f:
        back = PeriodicSettings.from_attrs(f["settings"].attrs)
    assert back == s and all(type(getattr(back, k.name)) is type(getattr(s, k.name)) for k in fields(s))
    assert back.reduce == "12" and back.response_angles_deg == (0.0, 90.5, 181.0)
    assert set(DEFAULTS.diff(s)) == {"magnus_order", "monodromy_tol", "steps", "samples", "reduce", "max_basis",
                                     "verdict_tol", "probe", "harmonics", "shoot", "response_angles_deg"}
    assert DEFAULTS.diff(s)["monodromy_tol"] == (1e-8, 3e-11) and s.diff(s) == {}
    assert PeriodicSettings.from_attrs(DEFAULTS.to_attrs()) == DEFAULTS
    partial = {k: v for k, v in s.to_attrs().items() if k != "edge_rtol"}
    with pytest.raises(SettingsError, match="edge_rtol: missing from the archived settings"):
        PeriodicSettings.from_attrs(partial)


@pytest.mark.parametrize("name", sorted(BAD))
def test_each_bad_field_is_refused_naming_it_and_its_value(name):
    assert set(BAD) == {f.name for f in fields(PeriodicSettings)}  # every field has its bad value here
    with pytest.raises(SettingsError) as err:
        replace(DEFAULTS, **{name: BAD[name]})
    assert str(err.value).startswith(f"{name}: ") and f"(got {BAD[name]!r})" in str(err.value)
    # as the command line names it: the flag for the field, every bad override together
    with pytest.raises(SceneError) as err:
        checked_settings("scene.toml", None, {name: BAD[name], "verdict_tol": 5.0}, {name: "--flag", "verdict_tol": "--tol"})
    paths = [p.path for p in err.value.problems]
    assert paths == (["--tol"] if name == "verdict_tol" else ["--flag", "--tol"])


def test_resume_refusal_names_each_field_with_both_values():
    """Refinements (edge_rtol: bisect the archived edges further) resume; anything else is refused in one
    line; an archive without settings is refused (not taken as the defaults)."""
    new = replace(DEFAULTS, monodromy_tol=1e-9, samples=32, edge_rtol=1e-9)
    why = resume_refusal(DEFAULTS, new, "floquet")
    assert why == ("cannot resume: the periodic settings differ from the archive's: monodromy_tol: archive has "
                   "1e-08, this run 1e-09; samples: archive has 16, this run 32") and "\n" not in why
    assert resume_refusal(DEFAULTS, replace(DEFAULTS, edge_rtol=1e-9), "floquet") is None
    assert "written before its periodic settings were archived" in resume_refusal(None, DEFAULTS, "floquet")


def test_settings_and_keywords_give_the_same_multipliers():
    """floquet_multipliers(system, s) is the call with settings built from s's values, bit for bit; a
    keyword given to ``with_overrides`` replaces its field. Undamped thesis mesh at 800 rad/s, inside the band
    710-838 rad/s of docs/stability.md: max|μ| > 1, and det Φ = 1 (Liouville: ∏|μ| = 1) either way."""
    model = Model(with_elements(load_scene(BW), 1), ("full",))
    s = replace(DEFAULTS, reduce="none", monodromy_tol=1e-6)
    a = floquet_multipliers(PeriodicSystem(model, 800.0, "full", damping=False), s)
    b = floquet_multipliers(PeriodicSystem(model, 800.0, "full", damping=False),
                            PeriodicSettings(reduce="none", monodromy_tol=1e-6))
    c = floquet_multipliers(PeriodicSystem(model, 800.0, "full", damping=False),
                            replace(s, monodromy_tol=1e-3).with_overrides(monodromy_tol=1e-6))
    np.testing.assert_array_equal(a.multipliers, b.multipliers)
    np.testing.assert_array_equal(a.multipliers, c.multipliers)
    assert a.max_abs > 1.0 + 1e-6 + 10 * a.error
    assert abs(np.sum(np.log(np.abs(a.multipliers)))) < 1e-8
    with pytest.raises(ValueError, match="magnus_order: must be 4 or 6"):
        floquet_multipliers(PeriodicSystem(model, 800.0, "full"), PeriodicSettings(reduce="none", magnus_order=5))


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    out = tmp_path_factory.mktemp("settings") / "f.h5"
    r = fkev(*FLOQUET, "--monodromy-tol", "1e-9", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    return out


def test_floquet_archives_its_settings_whole_and_verifies(archive):
    with h5py.File(archive, "r") as f:
        g = f["floquet/settings"]
        assert "compared whole on --resume" in g.attrs["description"]
        archived = PeriodicSettings.from_attrs(g.attrs)
    assert archived == replace(DEFAULTS, reduce="none", monodromy_tol=1e-9)
    assert fkev("verify", archive).returncode == 0


def test_resume_with_a_changed_tolerance_is_refused_and_the_same_settings_continue(archive):
    """A resume asking another monodromy tolerance: exit 2 before any work, one line naming the field
    with the archived and the requested value, the archive byte-identical, no .part or .lock left.
    The same settings: the resume continues (nothing left to solve) and the archive verifies."""
    before = digest(archive)
    r = fkev(*FLOQUET, "--monodromy-tol", "1e-8", "--resume", "-o", archive)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines()[-1].endswith(
        "cannot resume: the periodic settings differ from the archive's: monodromy_tol: archive has 1e-09, this run "
        "1e-08"), r.stderr
    assert digest(archive) == before
    assert sorted(p.name for p in archive.parent.iterdir()) == [archive.name]
    r = fkev(*FLOQUET, "--monodromy-tol", "1e-9", "--resume", "-o", archive)
    assert r.returncode == 0 and "floquet: 0 of 1 speed(s) to solve" in r.stderr, r.stderr
    assert fkev("verify", archive).returncode == 0


def test_an_archive_without_settings_is_not_resumed(archive, tmp_path):
    """Written before the settings were archived (the group removed here, checksums re-stamped as such an
    archive has them): a resume is refused with what to do, the archive left as it was."""
    old = tmp_path / "old.h5"
    old.write_bytes(archive.read_bytes())
    with edited(old) as f:
        del f["floquet/settings"]
    before = digest(old)
    r = fkev(*FLOQUET, "--monodromy-tol", "1e-9", "--resume", "-o", old)
    assert r.returncode == 2 and "written before its periodic settings were archived (no /floquet/settings); " \
                                 "rerun with --force" in r.stderr, r.stderr
    assert digest(old) == before


def test_response_takes_its_tolerances_from_the_settings():
    """Study.response(settings=s) is the keyword call with s's harmonics and output angles, bit for bit
    (slider-crank benchmark, one element per link); a keyword beside the settings overrides them; the
    harmonic balance's estimated error is below the settings' harmonic_tol when H is doubled to it."""
    from clitools import ROOT

    from fkev_slepc.api import Study

    study = Study(with_elements(load_scene(ROOT / "runs" / "slider-crank-benchmark-stiff-crank.toml"), (1, 1)))
    s = replace(DEFAULTS, harmonics=8, response_angles_deg=(0.0, 90.0, 180.0, 270.0))
    a = study.response(150.0, settings=s)
    b = study.response(150.0, harmonics=8, angles_deg=[0.0, 90.0, 180.0, 270.0])
    c = study.response(150.0, settings=replace(s, harmonics=4), harmonics=8)
    assert a.harmonics == 8 and np.asarray(a.angle_deg).tolist() == [0.0, 90.0, 180.0, 270.0]
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.q, c.q)
    loose = study.response(150.0, settings=replace(DEFAULTS, harmonic_tol=1e-4, response_angles_deg=(0.0,)))
    assert loose.hb_error <= 1e-4
    with pytest.raises(SceneError, match="tol: must be in"):
        study.response(150.0, tol=2.0)


REDUCTION = {"auto_modes": 6, "link_modes": 3, "auto_min_steps": 1000, "links_step_ratio": 2.5,
             "full_max_dofs": 12, "attract_tol": 1e-5, "zeta_floor": 2e-3,
             "moving_modes": 6, "moving_angles": 96}  # the fields of LATER, each off its default


def test_later_fields_round_trip_and_an_archive_without_them_reads_as_the_defaults(tmp_path):
    """The reduction constants, the response's full-model limit and its attract rule are fields: written
    and read back exactly; settings written before they were fields (none of them among the
    attributes) read back with their defaults, the module constants those runs used. Any other missing
    field is still refused."""
    from fkev_slepc.periodic import component_response, components, truncation
    from fkev_slepc.periodic.settings import LATER

    assert set(REDUCTION) == set(LATER)
    s = replace(DEFAULTS, **REDUCTION)
    with h5py.File(tmp_path / "s.h5", "w") as f:
        f.create_group("settings").attrs.update(s.to_attrs())
    with h5py.File(tmp_path / "s.h5", "r") as f:
        back = PeriodicSettings.from_attrs(f["settings"].attrs)
    assert back == s and set(DEFAULTS.diff(back)) == set(LATER)
    assert type(back.links_step_ratio) is float and type(back.auto_min_steps) is int
    old = {k: v for k, v in s.to_attrs().items() if k not in LATER}
    assert PeriodicSettings.from_attrs(old) == replace(s, **{k: getattr(DEFAULTS, k) for k in LATER})
    with pytest.raises(SettingsError, match="verdict_tol: missing from the archived settings"):
        PeriodicSettings.from_attrs({k: v for k, v in old.items() if k != "verdict_tol"})
    # the constants other modules export are the defaults (one source)
    assert (truncation.AUTO_MODES, components.LINK_MODES, truncation.AUTO_MIN_STEPS, truncation.LINKS_STEP_RATIO,
            component_response.FULL_MAX_DOFS) == (4, 2, 60_000, 4.0, 48)


def test_default_reduction_reads_its_thresholds_from_the_settings():
    """reduce="default" at one speed (docs/engine.md): the full model exactly below ``auto_min_steps``
    full-model steps 2·2π·ρ(A), reduced from there on; above, "links" only where the level of
    4·``link_modes`` modes per link needs at most 1/``links_step_ratio`` of the full steps.
    Bahgat–Willmert at 500 rad/s: thesis mesh (9 DOFs), 1553 full-model steps; 3 elements per link
    (27 DOFs), 24654 steps against 7282 for 4 modes per link (16 vectors): a ratio of 3.39."""
    from fkev_slepc.periodic.floquet import default_reduction, full_min_steps

    thesis = Model(with_elements(load_scene(BW), 1), ("full",))
    full = full_min_steps(thesis, 500.0)
    assert default_reduction(thesis, 500.0) is None  # the defaults: 60000 steps
    assert default_reduction(thesis, 500.0, settings=replace(DEFAULTS, auto_min_steps=full + 1)) is None
    assert default_reduction(thesis, 500.0, settings=replace(DEFAULTS, auto_min_steps=full)) == "auto"
    assert default_reduction(thesis, 500.0, settings=replace(DEFAULTS, auto_min_steps=1)) == "auto"  # 8 per link: all
    fine = Model(with_elements(load_scene(BW), 3), ("full",))
    st = replace(DEFAULTS, auto_min_steps=1, link_modes=1)
    assert default_reduction(fine, 500.0, settings=st) == "auto"  # 4 x 7282 > 24654
    assert default_reduction(fine, 500.0, settings=replace(st, links_step_ratio=3.0)) == "links"  # 3 x 7282 <= 24654
    assert default_reduction(fine, 500.0, settings=replace(st, links_step_ratio=3.0, link_modes=2)) == "auto"  # all


def test_an_archive_without_the_later_fields_resumes_and_a_changed_one_is_refused(archive, tmp_path):
    """A /floquet/settings group written before the reduction constants were fields (their attributes
    removed, checksums re-stamped): the same run resumes (nothing left to solve). An archive whose
    auto_min_steps differs from the run's is refused by the resume's check (the one the command runs
    before any work: exit 2 there, tested above), naming the field with both values, the archive untouched."""
    from fkev_slepc.archive import products as P
    from fkev_slepc.periodic.settings import LATER
    from fkev_slepc.sweep.parallel import local
    from fkev_slepc.sweep.product_run import refuse_changed_settings
    from fkev_slepc.sweep.session import OutputError

    old = tmp_path / "old.h5"
    old.write_bytes(archive.read_bytes())
    with edited(old) as f:
        for k in LATER:
            del f["floquet/settings"].attrs[k]
    run = replace(DEFAULTS, reduce="none", monodromy_tol=1e-9)
    refuse_changed_settings(old, P.FLOQUET, run, local())  # the defaults filled in: nothing differs
    r = fkev(*FLOQUET, "--monodromy-tol", "1e-9", "--resume", "-o", old)
    assert r.returncode == 0 and "floquet: 0 of 1 speed(s) to solve" in r.stderr, r.stderr
    before = digest(archive)
    with pytest.raises(OutputError) as err:
        refuse_changed_settings(archive, P.FLOQUET, replace(run, auto_min_steps=1000), local())
    assert str(err.value).endswith("cannot resume: the periodic settings differ from the archive's: auto_min_steps: "
                                   "archive has 60000, this run 1000") and "\n" not in str(err.value)
    with pytest.raises(OutputError, match="link_modes: archive has 2, this run 1$"):
        refuse_changed_settings(old, P.FLOQUET, replace(run, link_modes=1), local())
    assert digest(archive) == before


def test_the_response_reads_its_reduction_and_attract_rule_from_the_settings():
    """full_max_dofs: the slider-crank benchmark on one element per link (6 DOFs) is solved on the full
    model by default and on link components with full_max_dofs = 0, where its 2 modes per link keep
    every DOF (W square: the full model, truncation zero, the same response to the harmonic
    balance's truncation). attract_tol: one rule (periodic.response.response_verdict) for the result's
    verdict, with the run's value, and the archived speed scan's status."""
    from clitools import ROOT

    from fkev_slepc.api import Study
    from fkev_slepc.api.response_archive import _status
    from fkev_slepc.periodic.response import response_verdict
    from fkev_slepc.status import Status

    study = Study(with_elements(load_scene(ROOT / "runs" / "slider-crank-benchmark-stiff-crank.toml"), (1, 1)))
    s = replace(DEFAULTS, harmonics=8, response_angles_deg=(0.0, 90.0, 180.0, 270.0))
    full = study.response(150.0, settings=s)
    links = study.response(150.0, settings=replace(s, full_max_dofs=0, attract_tol=1e-5))
    assert full.truncation is None and full.attract_tol == 1e-8
    t = links.truncation
    assert t.basis == full.q.shape[1] and t.converged and (t.stress, t.deflection) == (0.0, 0.0)
    assert np.abs(links.q - full.q).max() <= 1e-5 * np.abs(full.q).max()
    # max|μ| 1 + 5e-8 (error 1e-12): grows beyond attract_tol 1e-8, neutral within 1e-5 or within 10 x error 1e-8
    assert response_verdict(1 + 5e-8, 1e-12) == "does not attract" and response_verdict(0.9, 1e-12) == "attracts"
    assert response_verdict(1 + 5e-8, 1e-12, 1e-5) == "neutral" == response_verdict(1 + 5e-8, 1e-8)
    assert response_verdict(np.nan, np.nan) is None and full.verdict is None
    assert replace(links, max_abs_multiplier=1 + 5e-8, multiplier_error=1e-12).verdict == "neutral"
    assert replace(full, max_abs_multiplier=1 + 5e-8, multiplier_error=1e-12).attracting is False
    row = {"harmonic_balance_error": 0.0, "max_abs_multiplier": 1 + 5e-8, "multiplier_error": 1e-12}
    assert _status(row, DEFAULTS) == Status.UNSTABLE.code
    assert _status(row, replace(DEFAULTS, attract_tol=1e-5)) == Status.OK.code
