"""The Floquet step count from accuracy (fkev_slepc/periodic/magnus.py "Pre-asymptotic levels",
docs/engine.md "Step count"): the first Magnus level at h·ρ(A) ≈ 2, the steps doubled on the
multiplier error, and a pre-asymptotic N/2 level never taken for a converged one.

Known answers: the step-doubling errors measured on Bahgat–Willmert at 4 elements per link
(500 rad/s, docs/engine.md), and on two linkages a tight reference (twice the steps, fixed)
that the stated error must bound.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fkev_slepc.model.operators import Model
from fkev_slepc.periodic.floquet import FREQUENCY_TOL_SHARE, floquet_multipliers, full_min_steps, matched_tolerance
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.periodic.magnus import match_multipliers, step_doubling_error
from fkev_slepc.periodic.settings import DEFAULTS
from fkev_slepc.periodic.truncation import frequency_change
from fkev_slepc.scene import load_scene, with_elements

RUNS = Path(__file__).resolve().parents[1] / "runs"


def test_a_pre_asymptotic_half_level_is_stated_undivided():
    """Bahgat–Willmert, 4 elements per link, 500 rad/s, order 6: max|μ| errors 2.8e-5, 8.1e-9,
    2.0e-9, 2.9e-11 at 2,048, 4,096, 8,192, 16,384 steps (against 32,768). The 4,096 → 8,192
    difference 6.1e-9 divided by 63 would state 9.6e-11 for a true 2.0e-9; the rate from the
    level before (2.8e-5/6.1e-9 ≫ 64) marks it pre-asymptotic and the difference itself is stated,
    which bounds the truth. At 16,384 → 32,768 the rate 68 is asymptotic: divided by 63."""
    true_8192, true_32768 = 2.0e-9, 1.4e-13
    stated = step_doubling_error(6.1e-9, 2.8e-5, 6)
    assert stated == 6.1e-9 and stated >= true_8192
    assert step_doubling_error(6.1e-9, None, 6) == pytest.approx(6.1e-9 / 63)  # fixed steps: as before
    assert step_doubling_error(2.9e-11, 2.0e-9, 6) == pytest.approx(2.9e-11 / 63)
    assert step_doubling_error(2.9e-11, 2.0e-9, 6) >= true_32768
    assert step_doubling_error(2.0e-9, 6.1e-9, 6) == 2.0e-9  # a rate of 3: not asymptotic either


def _tm_one_element():
    base = load_scene(RUNS / "turcic-midha-1984.toml")
    return replace(base, links=tuple(replace(lk, elements=1) for lk in base.links))


@pytest.mark.parametrize("scene, omega", [("bahgat-willmert-damped.toml", 1000.0), ("turcic-midha", 200.0)])
def test_stated_error_bounds_a_tight_reference(scene, omega):
    """Bahgat–Willmert (thesis mesh, its Rayleigh damping) at 1000 rad/s and Turcic–Midha (1 element
    per link, undamped, unstable: max|μ| ≈ 1.5e3) at 200 rad/s, tol 1e-8: converged in no
    more steps than the stiff bound 2·2π·ρ(A) of the earlier rule, and the stated errors are at
    least the true errors against twice the steps (whose own error is 2^-6 of them): of the
    moduli |μ| (compared sorted: the growth factors the verdict reads) and of the lowest four
    Floquet frequencies (relative, the truncation measure's comparison)."""
    if scene == "turcic-midha":
        model, damping = Model(_tm_one_element(), ("full",)), False
    else:
        model, damping = Model(load_scene(RUNS / scene), ("full",)), True
    res = floquet_multipliers(PeriodicSystem(model, omega, "full", damping=damping),
                              PeriodicSettings(reduce="none", monodromy_tol=1e-8))
    assert res.monodromy.converged
    assert res.monodromy.steps <= 2 ** np.ceil(np.log2(full_min_steps(model, omega, damping=damping)))
    ref = floquet_multipliers(PeriodicSystem(model, omega, "full", damping=damping),
                              PeriodicSettings(reduce="none", steps=2 * res.monodromy.steps))
    true = float(np.max(np.abs(np.sort(np.abs(res.multipliers)) - np.sort(np.abs(ref.multipliers)))))
    assert true <= res.error <= 1e-8 * max(1.0, res.max_abs)
    true_f = frequency_change(ref.exponents, res.exponents, omega, 4)
    assert true_f <= res.monodromy.second_error  # stated, not asked of the full model


def test_a_reduced_level_asks_its_low_frequencies_to_a_thousandth_of_reduce_tol():
    """On a reduced basis (Bahgat–Willmert at 2 elements per link, 500 rad/s, 1 link mode per link)
    the lowest four Floquet frequencies enter the truncation measure: their stated step error is
    below FREQUENCY_TOL_SHARE·reduce_tol and bounds the true one against twice the steps."""
    from fkev_slepc.periodic.components import link_components

    model = Model(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), 2), ("full",))
    basis = link_components(model).basis(1)
    res = floquet_multipliers(PeriodicSystem(model, 500.0, "full", basis=basis), PeriodicSettings(reduce="none"))
    assert res.monodromy.converged and res.basis < model.n_free
    assert res.monodromy.second_error <= FREQUENCY_TOL_SHARE * DEFAULTS.reduce_tol
    ref = floquet_multipliers(PeriodicSystem(model, 500.0, "full", basis=basis),
                              PeriodicSettings(reduce="none", steps=2 * res.monodromy.steps))
    assert frequency_change(ref.exponents, res.exponents, 500.0, 4) <= res.monodromy.second_error


def test_two_coarse_stable_levels_do_not_hide_a_band():
    """Bahgat–Willmert thesis mesh at 582.7007 rad/s, inside the band labelled (ω̄2-ω̄1)/4: at 256
    and 512 steps the coarse steps misplace the band and both levels are stable, |μ| = 1 on both
    (symplectic steps), so their moduli agree to 1e-14; from 1,024 steps on max|μ| - 1 = 3.5e-3.
    The count is also decided on every multiplier matched, to a quarter of the smallest distance
    between two multipliers (no collision hides in the error; at least 2π·edge_rtol): the verdict
    is the fixed-step one, and the stated matched error bounds the true one."""
    model = Model(load_scene(RUNS / "bahgat-willmert-1976.toml"), ("full",))
    res = floquet_multipliers(PeriodicSystem(model, 582.7007, "full"), PeriodicSettings(reduce="none"))
    ref = floquet_multipliers(PeriodicSystem(model, 582.7007, "full"),
                              PeriodicSettings(reduce="none", steps=2 * res.monodromy.steps))
    assert res.max_abs - 1.0 > 3e-3 and abs(res.max_abs - ref.max_abs) <= 1e-8
    assert res.monodromy.matched_error <= matched_tolerance(DEFAULTS.edge_rtol)(res.multipliers)
    i, j = match_multipliers(res.multipliers, ref.multipliers)
    assert float(np.max(np.abs(res.multipliers[i] - ref.multipliers[j]))) <= res.monodromy.matched_error
