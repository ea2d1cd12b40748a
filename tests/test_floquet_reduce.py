"""The frozen-mode reduction of the linkage monodromy on a closed loop (fkev_slepc/periodic/truncation.py).

Turcic–Midha four-bar, undamped, case ``full``: at 1 element per link (9 DOFs, 100 rad/s, unstable,
max|μ| ≈ 25) the full monodromy is cheap, so the convergence sequence of the reduction is compared
with it level by level; at 2 elements per link and 30 rad/s (Floquet-stable) a strict sub-basis is
integrated and must keep the Lagrangian structure (|μ| = 1, det Φ = 1).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene
from fkev_slepc.periodic.magnus import match_multipliers
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem

TM = Path(__file__).resolve().parents[1] / "runs" / "turcic-midha-1984.toml"


def _tm(elements: int) -> Model:
    sc = load_scene(TM)
    return Model(replace(sc, links=tuple(replace(lk, elements=elements) for lk in sc.links)), ("full",))


@pytest.fixture(scope="module")
def tm100():
    model = _tm(1)
    full = floquet_multipliers(PeriodicSystem(model, 100.0, "full", damping=False), PeriodicSettings(reduce="none"))
    auto = floquet_multipliers(PeriodicSystem(model, 100.0, "full", damping=False),
                               PeriodicSettings(reduce="auto", reduce_tol=1e-9))
    return model, full, auto


def test_reduced_max_multiplier_converges_to_the_full_model(tm100):
    """The basis levels approach the full max|μ| (unstable, ≈ 25 per revolution); the last level
    spans every DOF and is the full model (the projection is then a change of variables)."""
    model, full, auto = tm100
    sizes = [s for s, _, _ in auto.truncation.levels]
    mu = np.array([m for _, m, _ in auto.truncation.levels])
    assert full.max_abs > 20.0
    assert sizes == sorted(set(sizes)) and sizes[-1] == model.n_free and sizes[0] < model.n_free
    err = np.abs(mu - full.max_abs) / full.max_abs
    assert err[-1] < 1e-8 and auto.truncation.converged and auto.truncation.value == 0.0
    assert err[-2] < 1e-3 and err[-3] < 1e-3  # two reduced levels already within 1e-3
    assert np.all(np.diff(err[-4:]) < 0)  # and the last ones approach it monotonically


def test_truncation_estimate_bounds_the_true_error(tm100):
    """Each level's estimate (the relative change of max|μ| from the previous level) is at least
    its true relative error against the full model, once the basis holds the unstable pair."""
    _, full, auto = tm100
    mu = np.array([m for _, m, _ in auto.truncation.levels])[:-1]  # the reduced levels
    est = np.abs(np.diff(mu)) / mu[1:]
    true = np.abs(mu[1:] - full.max_abs) / full.max_abs
    assert est.size >= 3
    assert np.all(est[1:] >= true[1:])


def test_a_capped_basis_reports_its_error_unconverged(tm100):
    """max_basis below convergence: the last level is returned with its measured changes and
    converged False (the error is reported, never hidden)."""
    model, full, _ = tm100
    res = floquet_multipliers(PeriodicSystem(model, 100.0, "full", damping=False),
                              PeriodicSettings(reduce="auto", max_basis=7))
    t = res.truncation
    assert res.basis <= 7 and not t.converged
    assert t.max_abs > 1e-3 and np.isfinite(t.frequency) and np.isfinite(t.growth_rate)
    assert abs(res.max_abs - full.max_abs) / full.max_abs <= t.max_abs


def test_undamped_reduced_multipliers_stay_on_the_unit_circle():
    """A strict sub-basis (11 of 18 DOFs) at a Floquet-stable speed: the Galerkin projection of the
    Lagrangian system is Lagrangian, so the symplectic steps keep every |μ| = 1, det Φ = 1 and the
    set closed under μ -> 1/μ̄."""
    model = _tm(2)
    res = floquet_multipliers(PeriodicSystem(model, 30.0, "full", damping=False),
                              PeriodicSettings(reduce=4, basis_angles=8, threshold=1e-3), check_truncation=False)
    assert 6 <= res.basis < model.n_free
    mu = res.multipliers
    assert res.error < 1e-8
    assert np.max(np.abs(np.abs(mu) - 1.0)) < 1e-9
    assert abs(np.linalg.det(res.monodromy.phi) - 1.0) < 1e-8
    i, j = match_multipliers(mu, 1.0 / mu.conj())
    assert np.max(np.abs(mu[i] - 1.0 / mu[j].conj())) < 1e-8


@pytest.mark.parametrize("bad", ["full", 0, -2])
def test_bad_reduce_is_named(bad):
    with pytest.raises(ValueError, match="reduce"):
        floquet_multipliers(PeriodicSystem(_tm(1), 100.0, "full"), PeriodicSettings(reduce=bad))


def test_fkev_floquet_archives_the_basis_and_truncation(tmp_path):
    """``fkev floquet --reduce auto`` (Turcic–Midha, 1 element per link, 100 rad/s): the archived
    max|μ| is the in-process reduced one, with its basis size and truncation measures per speed;
    ``--reduce none`` archives the full model (basis 0, no truncation); a bad value names the flag."""
    import h5py

    from clitools import fkev

    runs = {}
    for flag in ("auto", "none"):
        out = tmp_path / f"{flag}.h5"
        r = fkev("floquet", TM, "--elements", "1", "--speeds", "100", "--angles", "0:360:90", "--no-critical",
                 "--reduce", flag, "-q", "-o", out)
        assert r.returncode == 0, r.stderr
        with h5py.File(out, "r") as f:
            runs[flag] = {k: f[f"floquet/{k}"][0, 0] for k in ("max_abs_multiplier", "basis_size", "truncation_max_abs",
                                                              "truncation_frequency", "truncation_converged")}
            reduce = f["floquet"].attrs["reduce"]
            assert (reduce.decode() if isinstance(reduce, bytes) else reduce) == {"auto": "auto", "none": "None"}[flag]
    a, n = runs["auto"], runs["none"]
    assert a["basis_size"] >= 5 and a["truncation_converged"] == 1 and np.isfinite(a["truncation_max_abs"])
    assert n["basis_size"] == 0 and np.isnan(n["truncation_max_abs"])
    assert abs(a["max_abs_multiplier"] - n["max_abs_multiplier"]) <= 1e-3 * n["max_abs_multiplier"]
    # the JSON (as_dict) and the text report show them too
    from fkev_slepc.cli.floquet import lines
    from fkev_slepc.sweep.floquet_run import read_floquet

    oa, on = (read_floquet(tmp_path / f"{flag}.h5").as_dict() for flag in ("auto", "none"))
    assert oa["basis_size"] == [int(a["basis_size"])] and oa["truncation_converged"] == [1]
    assert oa["truncation_max_abs"] == [float(a["truncation_max_abs"])]
    assert any(t.startswith(f"  model: 1 of 1 grid speed on a frozen-mode basis of {int(a['basis_size'])} vectors; "
                            "truncation change of max|μ| ") for t in lines(oa)), lines(oa)
    assert on["basis_size"] == [0] and on["truncation_max_abs"] == [None]
    assert "  model: the full model at every grid speed (no frozen-mode reduction)" in lines(on)
    # a resume with another reduction is refused before any work, the archive left byte-identical (issue 24:
    # the periodic settings compared whole); the same reduction resumes with nothing to solve
    from clitools import digest

    for archive, flag in (("none", "auto"), ("auto", "none"), ("auto", "auto")):
        before = digest(tmp_path / f"{archive}.h5")
        r = fkev("floquet", TM, "--elements", "1", "--speeds", "100", "--angles", "0:360:90", "--no-critical",
                 "--reduce", flag, "--resume", "-o", tmp_path / f"{archive}.h5")
        if archive == flag:
            assert r.returncode == 0 and "floquet: 0 of 1 speed(s) to solve" in r.stderr, r.stderr
            continue
        assert r.returncode == 2 and r.stderr.strip().endswith(
            f"cannot resume: the periodic settings differ from the archive's: reduce: archive has {archive}, "
            f"this run {flag}"), r.stderr
        assert digest(tmp_path / f"{archive}.h5") == before
    r = fkev("floquet", TM, "--speeds", "100", "--reduce", "half", "-o", tmp_path / "bad.h5")
    assert r.returncode != 0 and "--reduce" in r.stderr


def test_default_reduces_only_where_the_full_model_is_expensive():
    """reduce="default": the full model where its step count 2·2π·ρ(A) is below AUTO_MIN_STEPS
    (Turcic–Midha, 1 element per link, 100 rad/s: ~4,400), auto above (9 elements, 60 rad/s:
    ~74,000, where the full monodromy takes 131,072 steps)."""
    from fkev_slepc.periodic.floquet import full_min_steps
    from fkev_slepc.periodic.truncation import AUTO_MIN_STEPS

    small = _tm(1)
    assert full_min_steps(small, 100.0) < AUTO_MIN_STEPS
    assert floquet_multipliers(PeriodicSystem(small, 100.0, "full", damping=False),
                               PeriodicSettings(reduce="default")).basis is None
    assert full_min_steps(_tm(3), 60.0) >= AUTO_MIN_STEPS


def test_frequency_measure_compares_folded_phases_not_unwrapped_branches():
    """The truncation's frequency measure on the branch switch of docs/stability.md (Bahgat–Willmert,
    500 rad/s, 2 modes per link): the lowest four unwrapped Floquet frequencies at 4 elements per
    link (2909.96 = 6Ω − 90.04, ...) against 8 (2592.70 = 5Ω + 92.70, ...). One pair on two 2π
    branches moved its multiplier's phase by 2.66 rad/s, not by the 317 rad/s between its unwrapped
    values; the folded changes 2.66, 2.58, 1.02 and 60.73 rad/s (the table's Δf) are what is measured."""
    from types import SimpleNamespace

    from fkev_slepc.periodic.truncation import folded, measures

    w = 500.0
    coarse = np.array([2909.9607, 3394.5453, 5686.7799, 18384.4265])
    fine = np.array([2592.6957, 2897.1299, 7687.7963, 14676.3038])

    def level(freq, mu):  # the conjugate pairs ±i·f, one growing pair
        s = np.concatenate([1j * freq, -1j * freq])
        return SimpleNamespace(exponents=s, max_abs=mu, omega=w)

    np.testing.assert_allclose(folded(coarse, w), [90.0393, 105.4547, 186.7799, 115.5735], atol=1e-9)
    dmu, _, freq = measures(level(coarse, 1.0), level(fine, 1.0), 4)
    assert dmu == 0.0
    # the largest change is the 4th pair's 60.73 rad/s folded, relative to its finer unwrapped value
    np.testing.assert_allclose(freq, (176.3038 - 115.5735) / 14676.3038, rtol=1e-9)
    dmu, _, freq = measures(level(coarse[:2], 1.0), level(fine[:2], 1.0), 2)  # the reproducer's pairs
    np.testing.assert_allclose(freq, (92.6957 - 90.0393) / 2592.6957, rtol=1e-9)  # not 317/2592.7
    # the same phase on another branch is no change at all; the measure is symmetric in the branch
    _, _, same = measures(level(fine + np.array([3, -2, 5, 1]) * w, 1.0), level(fine, 1.0), 4)
    assert same < 1e-12
