"""`fkev point`: one operating point from a scene file, text and JSON output, bad flags."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fkev_slepc.cli import main

ROOT = Path(__file__).resolve().parents[1]
BW = str(ROOT / "runs/bahgat-willmert-1976.toml")


def fkev(*args):
    """A subprocess: for PETSc options, which must reach PETSc before its first import."""
    return subprocess.run([sys.executable, "-m", "fkev_slepc", *args], capture_output=True, text=True, timeout=120)


def point(capsys, *args) -> tuple[int, str, str]:
    """``fkev point ARGS`` in this process: (exit code, stdout, stderr)."""
    try:
        code = main(["point", *args])
    except SystemExit as exc:  # argparse's errors (a flag's type check)
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_point_json_reports_frequencies_stability_and_status(capsys):
    code, stdout, stderr = point(capsys, BW, "--angle", "10", "--speed", "1000", "--case", "1", "--json",
                                 "--solver", "dense")
    assert code == 0, stderr
    out = json.loads(stdout)
    assert set(out) >= {"frequency_hz", "eigenvalue", "max_real", "divergent", "status"}
    assert out["case"] == "full"
    f = np.array(out["frequency_hz"])
    lam = np.array(out["eigenvalue"])
    np.testing.assert_allclose(f, lam[:, 1] / (2 * np.pi), rtol=1e-14)
    np.testing.assert_allclose(f, [362.71, 652.08, 1078.94, 2898.89], atol=0.01)  # runs/README.md table
    assert out["max_real"] == pytest.approx(lam[:, 0].max(), rel=1e-9)
    assert out["status"] == "unstable"  # Coriolis + tangential: growth rates of either sign (§10.3)


def test_point_structure_text_output_and_refinement(capsys):
    code, out, err = point(capsys, BW, "--angle", "10", "--speed", "0", "--case", "structure", "--elements", "2,4,4",
                           "--solver", "dense", "--modes", "2")
    assert code == 0, err
    assert "30 DOFs" in out and "status: ok" in out


@pytest.mark.parametrize(
    "args,needle",
    [
        (["--case", "no_gravity"], "--case: unknown case 'no_gravity'"),
        (["--elements", "0"], "--elements: every count must be >= 1"),
        (["--elements", "1,2"], "--elements: needs 1 or 3 values (got 2)"),
        (["--modes", "0"], "--modes: must be >= 1 (got 0)"),
    ],
)
def test_point_bad_flags_exit_2_with_the_flag_named(capsys, args, needle):
    code, _, err = point(capsys, BW, "--angle", "10", "--speed", "0", *args)
    assert code == 2 and needle in err


def test_missing_modes_are_nan_not_zero():
    """A point that finds fewer modes than asked reports them as missing (null), never as 0 Hz."""
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.status import Status
    from fkev_slepc.solve.protocol import EigenSolution

    sol = EigenSolution(np.array([-3.0 + 100j, -3.0 - 100j]), np.array([1e-12, 1e-12]), None, True, "test")
    r = postprocess(sol, 3)
    assert r.status == Status.NOT_CONVERGED
    assert r.frequency_hz[0] == pytest.approx(100 / (2 * np.pi))
    assert np.isnan(r.frequency_hz[1:]).all() and np.isnan(r.eigenvalue[1:].imag).all()


def test_bad_petsc_option_is_a_scene_error_not_a_traceback():
    r = fkev("point", BW, "--angle", "10", "--speed", "1000", "--case", "full", "--solver", "slepc",
             "-fkev_pep_type", "toarr")
    assert r.returncode == 2
    assert "pep_type" in r.stderr and "toarr" in r.stderr and "Traceback" not in r.stderr


def test_point_json_separates_accepted_pairs_from_the_stability_verdict(capsys):
    """`unstable` is a converged status: case full at θ = 10°, 1000 rad/s has modes 1 and 2 with negative
    damping ratio (docs/accuracy.md §2), every pair accepted; the same point without the Coriolis term
    (undamped, non-gyroscopic) is ok; a threshold no pair can meet gives pairs_accepted false."""
    common = (BW, "--angle", "10", "--speed", "1000", "--elements", "4", "--json")
    code, stdout, stderr = point(capsys, *common, "--case", "full")
    full = json.loads(stdout)
    assert code == 0 and full["status"] == "unstable" and full["pairs_accepted"] is True, stderr
    assert full["unstable_modes"] == [1, 2] and full["max_pair_error"] == 1e-3
    zeta = np.array(full["damping_ratio"])
    assert zeta[0] < -1e-3 and zeta[1] < -1e-3 and np.all(zeta[2:] > 0)
    assert max(full["residual"]) <= full["max_pair_error"]
    code, stdout, _ = point(capsys, *common, "--case", "no_coriolis")
    nc = json.loads(stdout)
    assert code == 0 and nc["status"] == "ok" and nc["pairs_accepted"] is True and nc["unstable_modes"] == []
    code, stdout, _ = point(capsys, *common[:-1], "--case", "full")  # the table says both, on one line
    line = next(s for s in stdout.splitlines() if s.startswith("accuracy:"))
    assert "every reported pair accepted" in line and "modes 1, 2 grow" in line
    r = fkev("point", *common, "--case", "full", "--solver", "dense", "-fkev_max_pair_error", "1e-30")
    strict = json.loads(r.stdout)
    assert r.returncode == 3 and strict["status"] == "not_converged" and strict["pairs_accepted"] is False
