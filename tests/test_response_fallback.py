"""The response where harmonic balance will not converge (fkev_slepc/periodic/harmonic_balance.py
``will_not_converge``, fkev_slepc/periodic/shooting.py ``periodic_shot``, docs/response.md §3): the
rule on the balance's estimates, the shooting response against a long harmonic balance to its
stated error, an exact resonance refused, and the speed scan's truncation per speed."""

import json
from types import SimpleNamespace

import numpy as np
import pytest
from clitools import ROOT

from fkev_slepc.cli import main
from fkev_slepc.model.operators import Model
from fkev_slepc.periodic.harmonic_balance import galerkin_solve, harmonic_balance, will_not_converge
from fkev_slepc.periodic.response import periodic_response
from fkev_slepc.periodic.shooting import ResonanceError
from fkev_slepc.periodic.system import PeriodicSystem
from fkev_slepc.scene import load_scene, with_elements

BW = ROOT / "runs/bahgat-willmert-1976.toml"


def test_the_rule_keeps_a_geometric_balance_and_abandons_a_stagnating_one():
    # Turcic-Midha at 60 rad/s (docs/engine.md): 1.35, 4.6e-2 -> predicted 7e-11 at H = 128: kept
    assert not will_not_converge([(16, 1.35), (32, 4.63e-2)], 1e-8, 128)
    # Bahgat-Willmert, 1 el/link, 500 rad/s: 0.67 -> 1.0 does not fall
    assert will_not_converge([(16, 2.99), (32, 0.67), (64, 1.0)], 1e-8, 256)
    # falling, but geometrically too slowly: 1e-2 -> 1e-3 (rho 0.1) predicts 1e-3 * 0.1^2 = 1e-5 at 2H
    assert will_not_converge([(32, 1e-2), (64, 1e-3)], 1e-8, 128)
    assert not will_not_converge([(32, 1e-2), (64, 1e-3)], 1e-6, 256)  # 1e-3 * 0.1^6 = 1e-9 at 4H
    assert not will_not_converge([(16, 1.0)], 1e-8, 256)  # one estimate: no rate yet
    # runs/slider-crank-design.toml at 100 rad/s: a stall within √tol is the balance's floor: kept
    assert not will_not_converge([(16, 1.4e-3), (32, 2.3e-7), (64, 1.1e-7)], 1e-8, 128)


def mathieu(c=0.1):
    """ÿ + c ẏ + (2.3 − cos 2θ) y = 1 + cos θ in θ (Ω = 1): a balance that converges geometrically."""
    def mck(th):
        one = np.ones((th.size, 1, 1))
        return one, c * one, (2.3 - np.cos(2 * th))[:, None, None]

    return SimpleNamespace(mck=mck, load=lambda th: (1 + np.cos(th))[:, None])


def test_where_the_balance_converges_nothing_changes():
    s = mathieu()
    r = periodic_response(s, 1.0, tol=1e-12)
    plain = harmonic_balance(s.mck, s.load, 1.0, tol=1e-12)
    assert r.method == "harmonic balance" and r.periodic is None and not r.hb.abandoned
    assert np.array_equal(r.q, plain.q) and r.error == plain.error <= 1e-12


def test_undamped_bahgat_willmert_at_500_is_shot_to_its_stated_error():
    """The thesis mesh at 500 rad/s undamped: estimates 3.0, 0.67, 1.0 at H = 16, 32, 64, the balance
    abandoned there; the shooting response equals a long harmonic balance (H = 128, 8e-8 from a
    fine shooting) within its own step-doubling estimate, itself below tol."""
    model = Model(with_elements(load_scene(BW), 1), cases=("full",))
    s = PeriodicSystem(model, 500.0, "full")
    r = periodic_response(s, 500.0, tol=1e-4)
    assert r.method == "shooting" and r.hb.abandoned and [h for h, _ in r.hb.levels] == [16, 32, 64]
    assert r.error <= 1e-4 and r.periodic.steps >= 512
    th = np.radians(np.arange(0.0, 360.0, 15.0))
    ref = galerkin_solve(s.mck, s.load, 500.0, 128).at(th)
    assert np.abs(r.at(th) - ref).max() <= r.error * np.abs(ref).max()


def test_an_exact_resonance_is_flagged_never_filled():
    """ω = Ω undamped, forced at Ω: the balance's matrix is singular, its estimates do not fall, and
    the shooting refuses (I − Φ) singular instead of returning the abandoned balance."""
    def mck(th):
        one = np.ones((th.size, 1, 1))
        return one, 0.0 * one, one

    s = SimpleNamespace(mck=mck, load=lambda th: np.cos(th)[:, None])
    with pytest.warns(Warning), pytest.raises(ResonanceError, match="exact resonance"):
        periodic_response(s, 1.0, tol=1e-8)


def test_the_speed_scan_prints_and_carries_its_truncation_per_speed(capsys, tmp_path):
    """In process and archived (the archive keeps all but the levels and the link truncation)."""
    args = [str(BW), "--elements", "1", "--speeds", "100,200", "--harmonics", "8", "--station", "coupler:0.15"]
    assert main(["response", *args, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["solution"]) == 2
    for sol in d["solution"]:
        assert sol["method"] == "harmonic balance" and sol["harmonics"] == 8 and sol["shooting_steps"] == 0
        assert sol["levels"][0][0] == 8 and sol["response_error"] == sol["harmonic_balance_error"] > 1e-6
        assert sol["converged"] is False and sol["tol"] == 1e-8
    assert main(["response", *args]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if "HB H=8" in line]
    assert len(rows) == 2 and all(line.split("HB H=8")[1].split()[1] == "NO" for line in rows)
    assert main(["response", *args, "--json", "-o", str(tmp_path / "scan.h5")]) == 0  # a fixed H: not a failure
    archived = json.loads(capsys.readouterr().out)["solution"]
    for sol, kept in zip(d["solution"], archived):
        assert kept == {k: v for k, v in sol.items() if k not in ("levels", "truncation")}
