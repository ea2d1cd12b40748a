"""Critical speeds (solve/critical.py, fkev critical) against independent references."""

import json
import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from builders import turcic_midha

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import Damping
from fkev_slepc.solve.critical import critical_speeds, divergence_speed, min_damping_ratio
from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.stability import check_divergence

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def det_sign_bisection(model, pieces, case, step=1.0, tol=1e-12):
    """Independent reference: scan Ω upwards until det K(Ω) (LAPACK LU of the assembled K of
    the QEP itself) changes sign, then bisect the bracket."""
    def sign(w):
        return np.linalg.slogdet(model.qep(pieces, w, case).stiffness.toarray())[0]

    s0, lo = sign(0.0), 0.0
    while sign(lo + step) == s0:
        lo += step
        assert lo < 1e4
    hi = lo + step
    while hi - lo > tol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if sign(mid) == s0 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("case", ["full", "no_normal"])
def test_cli_buckling_speed_matches_det_bisection(case):
    """`fkev critical runs/turcic-midha-1984.toml --case CASE --angle 10 --json` (the acceptance
    command) against a dense bisection on the sign of det K(Ω)."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    out = subprocess.run([sys.executable, "-m", "fkev_slepc", "critical", os.path.join(ROOT, "runs/turcic-midha-1984.toml"),
                          "--case", case, "--angle", "10", "--json"], capture_output=True, text=True, env=env, check=True)
    o = json.loads(out.stdout)
    model = Model(turcic_midha(3, cases=(case,)))
    pieces = model.pieces(np.radians(10.0))
    ref = det_sign_bisection(model, pieces, case)
    assert o["divergence_speed_rad_s"] == pytest.approx(ref, rel=1e-6)
    assert o["angle_deg"] == 10.0 and o["flutter_speed_rad_s"] is not None
    # the verdict changes at that speed: proven divergent just above, not divergent well below
    w = o["divergence_speed_rad_s"]
    assert check_divergence(model.qep(pieces, 1.001 * w, case)).proven
    assert check_divergence(model.qep(pieces, 1.001 * w, case)).divergent
    assert not check_divergence(model.qep(pieces, 0.5 * w, case)).divergent


def test_structure_has_no_critical_speed_and_max_speed_bounds():
    model = Model(turcic_midha(3, cases=("structure", "full")))
    p = model.pieces(np.radians(10.0))
    assert np.isnan(divergence_speed(model, p, "structure"))
    w = divergence_speed(model, p, "full")
    assert np.isnan(divergence_speed(model, p, "full", max_speed=0.99 * w))
    r = critical_speeds(DenseEngine(), model, 10.0, "structure", 3, 1e-6, max_speed=100.0)
    assert np.isnan(r.divergence_speed) and np.isnan(r.flutter_speed)


def test_flutter_onset_with_structural_damping_is_refined_to_1e8():
    """With Rayleigh damping the modes are stable at rest; the flutter speed is the root of the
    smallest damping ratio, min ζ = 0, refined to 1e-8 (issue 20: -damping_tol only decides
    that there is a crossing): ζ changes sign within 1e-7 on each side, and is positive on a
    finer grid below it."""
    base = turcic_midha(3, cases=("full",))
    model = Model(replace(base, damping=Damping(0.05, 1e-7)))  # ζ ≈ 1e-4 at rest
    p = model.pieces(np.radians(10.0))
    eng, tol = DenseEngine(), 1e-6
    r = critical_speeds(eng, model, 10.0, "full", 3, tol)
    wf = r.flutter_speed
    assert 0 < wf < r.divergence_speed and r.scan_points == 64 and r.notes == ()
    assert min_damping_ratio(eng, model, p, "full", 0.0, 3) > 0  # damped at rest
    assert min_damping_ratio(eng, model, p, "full", wf * (1 - 1e-7), 3) > 0
    assert -tol < min_damping_ratio(eng, model, p, "full", wf * (1 + 1e-7), 3) < 0  # past the root, within tol
    below = np.linspace(0, wf, 40)[1:-1]  # the lowest crossing: none below it on a finer grid
    assert all(min_damping_ratio(eng, model, p, "full", w, 3) > 0 for w in below)


def test_undamped_flutter_onset_is_at_rest_and_its_notes_are_silenced_by_q():
    """Undamped, the Coriolis and tangential terms give ± real parts as soon as Ω > 0: min ζ is
    never positive below the first unstable scan speed, so the onset is Ω = 0 (no -damping_tol
    artefact); `fkev critical` prints the scan once and -q prints the two speeds only."""
    model = Model(turcic_midha(3, cases=("full",)))
    r = critical_speeds(DenseEngine(), model, 10.0, "full", 3, 1e-6)
    assert r.flutter_speed == 0.0 and r.divergence_speed > 0
    env = dict(os.environ, PYTHONPATH=ROOT)
    cmd = [sys.executable, "-m", "fkev_slepc", "critical", os.path.join(ROOT, "runs/turcic-midha-1984.toml"),
           "--case", "full", "--angle", "10"]
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True).stdout.splitlines()
    assert "from 0 rad/s" in out[2] and "crosses 0" in out[2]
    assert sum("scanned on 64 speeds" in ln for ln in out) == 1 and "from none" not in "\n".join(out)
    quiet = subprocess.run(cmd + ["-q"], capture_output=True, text=True, env=env, check=True).stdout.splitlines()
    assert quiet == out[:3]


def test_cli_over_the_scene_angles_reports_the_lowest(tmp_path):
    text = open(os.path.join(ROOT, "runs/turcic-midha-1984.toml")).read()
    scene = tmp_path / "tm.toml"
    scene.write_text(text.replace("{ start = 0, stop = 360, step = 5 }", "[0.0, 90.0, 180.0]"))
    env = dict(os.environ, PYTHONPATH=ROOT)
    run = subprocess.run([sys.executable, "-m", "fkev_slepc", "critical", str(scene), "--case", "full", "--json",
                          "--max-speed", "200"], capture_output=True, text=True, env=env, check=True)
    o = json.loads(run.stdout)
    per = {r["angle_deg"]: r["divergence_speed_rad_s"] for r in o["per_angle"]}
    assert set(per) == {0.0, 90.0, 180.0}
    finite = {a: w for a, w in per.items() if w is not None}
    assert finite and all(w <= 200 for w in finite.values())
    best = min(finite, key=lambda a: finite[a])
    assert (o["divergence_speed_rad_s"], o["divergence_angle_deg"]) == (per[best], best)
    bad = subprocess.run([sys.executable, "-m", "fkev_slepc", "critical", str(scene), "--max-speed", "-1"],
                         capture_output=True, text=True, env=env)
    assert bad.returncode == 2 and "--max-speed: must be a finite speed > 0" in bad.stderr
