"""``fkev design-check`` refuses before any solve what ``fkev response`` refuses (issue 36): the mesh
size, operators that overflow, a CSV path that cannot be written, --json with --csv - on one stdout,
and names --tol as the flag."""

from __future__ import annotations

import pytest

from clitools import ROOT, fkev

SCENE = ROOT / "runs" / "slider-crank-design.toml"


@pytest.mark.parametrize("args, words", [
    (["--json", "--csv", "-"], "--csv: '-' (stdout) with --json would mix CSV into the JSON"),
    (["--csv", "{tmp}/no/such/dir/x.csv"], "does not exist (create it first)"),
    (["--csv", "{tmp}"], "is a directory"),
    (["--elements", "100000"], "--elements: 600000 free DOFs exceed"),
    (["--speed", "1e155"], "--speed: case full at 1e+155 rad/s: C has entries up to"),
    (["--tol", "0"], "--tol: must be in (0, 1) (got 0.0)"),
])
def test_refused_before_work_with_the_flag_named(tmp_path, args, words):
    r = fkev("design-check", SCENE, *(a.format(tmp=tmp_path) for a in args), timeout=60)
    assert r.returncode == 2, r.stdout + r.stderr
    assert words in r.stderr
    assert r.stdout == ""  # nothing solved, nothing printed
    assert not list(tmp_path.rglob("*.csv"))


def test_the_same_oversize_mesh_is_refused_by_fkev_response_in_the_same_words():
    a = fkev("design-check", SCENE, "--elements", "100000", timeout=60)
    b = fkev("response", SCENE, "--elements", "100000", "--speed", "100", timeout=60)
    assert a.returncode == b.returncode == 2
    line = next(ln for ln in a.stderr.splitlines() if "--elements" in ln)
    assert line in b.stderr.splitlines()
