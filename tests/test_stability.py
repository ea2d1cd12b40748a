"""Stability verdicts (docs/stability.md): Rayleigh damping against its closed form, whole-spectrum
divergence identical on both engines, damping ratios in fkev point."""

import json
import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as la

from builders import STEEL, bahgat_willmert, four_bar, turcic_midha

from fkev_slepc.model.operators import Model
from fkev_slepc.model.qep import GENERAL
from fkev_slepc.scene import Damping, parse_scene
from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.solve.dense import all_eigenvalues
from fkev_slepc.solve.stability import check_divergence, damping_ratio, det_sign, sym_positive_definite
from fkev_slepc.status import Status

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _slepc():
    from fkev_slepc.solve.slepc import SlepcEngine

    return SlepcEngine()


@pytest.mark.parametrize("engine", ["dense", "slepc"])
@pytest.mark.parametrize("case", ["structure", "full"])
def test_rayleigh_damping_at_rest_matches_closed_form(engine, case):
    """At Ω = 0 every mode of M q'' + (αM + βK)q' + Kq = 0 has |λ| = ω and ζ = α/(2ω) + βω/2,
    with ω the undamped structure's; the damping is kept in every case, structure included."""
    base = turcic_midha(3, cases=(case,), speeds=(0.0,))
    omega = np.sqrt(la.eigh(*(a.toarray() for a in _km(Model(base))), eigvals_only=True))[:4]
    alpha, beta = 0.02 * omega[0], 0.02 / omega[3]  # ζ₁ ≈ 0.01, ζ₄ ≈ 0.01: a realistic structure
    model = Model(replace(base, damping=Damping(alpha, beta)))
    q = model.qep(model.pieces(np.radians(10.0)), 0.0, case)
    assert q.kind == GENERAL and q.damping is not None
    eng = DenseEngine() if engine == "dense" else _slepc()
    res = postprocess(eng.solve(q, 4), 4)
    eng.close()
    assert res.status == Status.OK
    np.testing.assert_allclose(np.abs(res.eigenvalue), omega, rtol=1e-9)
    np.testing.assert_allclose(res.damping_ratio, alpha / (2 * omega) + beta * omega / 2, rtol=1e-8)


def _km(model):
    p = model.pieces(np.radians(10.0))
    return model.pattern.matrix(p.structural), model.pattern.matrix(p.mass)


def test_damping_ratio_and_unstable_threshold():
    np.testing.assert_allclose(damping_ratio([-3 + 4j, 2j, 0.5 + 0j]), [0.6, 0.0, -1.0])
    model = Model(bahgat_willmert(cases=("full",), speeds=(1000.0,)))
    sol = DenseEngine().solve(model.qep(model.pieces(np.radians(10.0)), 1000.0, "full"), 4)
    res = postprocess(sol, 4)
    # Coriolis + tangential: ± real parts (their sum is zero over the whole spectrum)
    assert abs(np.sum(sol.eigenvalues.real)) < 1e-9 * np.abs(sol.eigenvalues).max()
    assert res.min_damping_ratio == pytest.approx(np.min(-res.eigenvalue.real / np.abs(res.eigenvalue)))
    strict = postprocess(sol, 4, damping_tol=0.0).status
    lax = postprocess(sol, 4, damping_tol=1.0 - 1e-12).status
    assert (strict, lax) == (Status.UNSTABLE, Status.OK)


def test_certificates_on_known_matrices():
    import scipy.sparse as sp

    A = sp.csr_matrix(np.array([[2.0, 1.0, 0], [-1.0, 2.0, 0], [0, 0, 1.0]]))  # sym part PD, skew part
    assert sym_positive_definite(A) and det_sign(A) == 1
    B = sp.csr_matrix(np.diag([1.0, -2.0, 3.0]))
    assert not sym_positive_definite(B) and det_sign(B) == -1
    P = sp.csr_matrix(np.array([[0, 1.0, 0], [1.0, 0, 0], [0, 0, 1.0]]))  # a transposition: det -1
    assert det_sign(P) == -1 and det_sign(P @ P) == 1


def test_dense_certificates_agree_with_sparse_and_determinant():
    """The dense engine's certificates (numpy arrays) decide like the sparse ones and like det."""
    import scipy.sparse as sp

    rng = np.random.default_rng(11)
    for _ in range(200):
        n = int(rng.integers(1, 9))
        A = rng.normal(size=(n, n))
        assert det_sign(A) == det_sign(sp.csr_matrix(A)) == int(np.sign(np.linalg.det(A)))
        S = A @ A.T - rng.uniform(0.0, 1.0) * np.eye(n) + (A - A.T)  # skew part: no effect
        pd = bool(np.linalg.eigvalsh((S + S.T) / 2).min() > 0)
        assert sym_positive_definite(S) == sym_positive_definite(sp.csr_matrix(S)) == pd


def random_crank_rockers(n, seed):
    """Seeded random Grashof crank-rockers (crank shortest), lumped masses, speeds and angles."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        a = rng.uniform(0.04, 0.12)
        b, c, d = rng.uniform(0.18, 0.4, 3)
        if a + max(b, c, d) >= sum((b, c, d)) - max(b, c, d):  # Grashof with the crank shortest
            continue
        w, t = rng.uniform(0.004, 0.02), rng.uniform(0.003, 0.01)
        props = dict(youngs_modulus=2.07e11, density=7760.0, area=w * t, second_moment=t * w**3 / 12)
        masses = [(j, lk, m) for j, lk, m in (("A", "crank", rng.uniform(0, 3)), ("B", "follower", rng.uniform(0, 3)))
                  if m > 0.3]
        scene = four_bar((a, b, d), c, props, (2, 3, 3), masses=masses, cases=("full",), modes=4)
        speed, angle = rng.uniform(100, 3000), rng.uniform(0, 360)
        model = Model(scene)
        try:
            out.append((model, model.qep(model.pieces(np.radians(angle)), speed, "full")))
        except ValueError:  # this branch does not assemble at that angle
            continue
    return out


def _dense_has_real_positive(q):
    lam = all_eigenvalues(q)
    lam = lam[np.isfinite(lam)]
    return bool(np.any((np.abs(lam.imag) <= 1e-9 * np.abs(lam)) & (lam.real > 0)))


def test_divergence_verdicts_agree_on_random_crank_rockers():
    """SLEPc ≡ dense on every point, and both ≡ "the full QZ spectrum has a real λ > 0"."""
    eng = _slepc()
    n_div = 0
    for model, q in random_crank_rockers(16, seed=2026):
        d = postprocess(DenseEngine().solve(q, 4), 4)
        s = postprocess(eng.solve(q, 4), 4)
        truth = _dense_has_real_positive(q)
        assert (d.status == Status.DIVERGENT) == (s.status == Status.DIVERGENT) == truth, (d.message, s.message)
        np.testing.assert_allclose(s.divergent, d.divergent, rtol=1e-6)
        n_div += truth
    eng.close()
    assert 0 < n_div < 16  # the campaign has both kinds of points


def test_heavy_lumped_mass_divergence_beyond_the_requested_modes():
    """The real eigenvalues lie far above the 4 lowest modes, so SLEPc's pairs nearest 0 miss
    them; the whole-spectrum verdict still says divergent on both engines."""
    scene = four_bar((0.127, 0.2794, 0.2667), 0.254, STEEL, (2, 3, 3),
                     masses=(("A", "crank", 20.0), ("B", "follower", 20.0)), cases=("full",), modes=4)
    model = Model(scene)
    q = model.qep(model.pieces(np.radians(200.0)), 2000.0, "full")
    eng = _slepc()
    sol = eng.solve(q, 4)
    eng.close()
    s, d = postprocess(sol, 4), postprocess(DenseEngine().solve(q, 4), 4)
    assert d.status == s.status == Status.DIVERGENT
    lam = sol.eigenvalues
    found = lam[(np.abs(lam.imag) <= 1e-9 * np.abs(lam)) & (lam.real > 0)]
    assert d.divergent.max() > 2 * np.abs(s.eigenvalue[-1])  # beyond the 4th mode
    assert found.size == 0  # none among SLEPc's own pairs (the verdict of issue 9 before the fix)
    np.testing.assert_allclose(s.divergent, d.divergent, rtol=1e-6)
    assert s.max_real == pytest.approx(d.max_real, rel=1e-6)


def test_proven_stable_point_needs_no_eigenvalues():
    model = Model(bahgat_willmert(cases=("full",)))
    v = check_divergence(model.qep(model.pieces(np.radians(10.0)), 100.0, "full"))
    assert (v.divergent, v.proven) == (False, True) and "Cholesky" in v.method


DAMPED = """
[damping]
mass_proportional_1_s = 5.0
stiffness_proportional_s = 2e-6
"""


def test_damping_section_and_errors():
    text = open(os.path.join(ROOT, "runs", "bahgat-willmert-1976.toml")).read()
    s = parse_scene(text + DAMPED)
    assert s.damping == Damping(5.0, 2e-6) and s.damping.active
    assert not parse_scene(text).damping.active
    for bad, msg in (
        ("mass_proportional_1_s = -1.0", "damping.mass_proportional_1_s: must be >= 0.0 (got -1"),
        ("stiffness_proportional_s = 'x'", "damping.stiffness_proportional_s: must be a number"),
        ("alpha = 1.0", "damping.alpha: unknown key"),
    ):
        with pytest.raises(Exception) as err:
            parse_scene(text + "\n[damping]\n" + bad + "\n")
        assert msg in str(err.value)


def test_point_json_reports_damping_ratio_and_scope(tmp_path):
    scene = tmp_path / "bw.toml"
    scene.write_text(open(os.path.join(ROOT, "runs", "bahgat-willmert-1976.toml")).read() + DAMPED)
    env = dict(os.environ, PYTHONPATH=ROOT)
    out = subprocess.run([sys.executable, "-m", "fkev_slepc", "point", str(scene), "--case", "structure",
                          "--speed", "0", "--json"], capture_output=True, text=True, env=env, check=True)
    o = json.loads(out.stdout)
    z = np.array(o["damping_ratio"])
    w = np.abs(np.array(o["eigenvalue"]) @ [1, 1j])  # |λ| = ω of the undamped mode; Im λ = ω·sqrt(1-ζ²)
    np.testing.assert_allclose(z, 5.0 / (2 * w) + 2e-6 * w / 2, rtol=1e-6)
    assert o["status"] == "ok" and "whole spectrum" in o["stability_scope"]["divergence"]
    assert o["stability_scope"]["flutter"].startswith(f"modes 1-{len(w)}")


def test_archive_and_info_carry_damping_ratio(tmp_path):
    import h5py

    scene = tmp_path / "bw.toml"
    scene.write_text(open(os.path.join(ROOT, "runs", "bahgat-willmert-1976.toml")).read() + DAMPED)
    out = tmp_path / "bw.h5"
    env = dict(os.environ, PYTHONPATH=ROOT)
    subprocess.run([sys.executable, "-m", "fkev_slepc", "run", str(scene), "-o", str(out), "--quiet",
                    "--angles", "0,90", "--speeds", "0,1000", "--cases", "structure,full"], env=env, check=True)
    with h5py.File(out) as f:
        z, lam = f["damping_ratio"], f["eigenvalue"][()]
        assert z.shape == f["frequency_hz"].shape and z.attrs["units"] == "1" and "damping ratio" in z.attrs["long_name"]
        assert [d.label for d in z.dims] == [d.label for d in f["frequency_hz"].dims]
        np.testing.assert_allclose(z[()], -lam.real / np.abs(lam), rtol=1e-12)
        assert "whole spectrum" in f["status"].attrs["stability_scope"]
    info = subprocess.run([sys.executable, "-m", "fkev_slepc", "info", str(out)], env=env, check=True,
                          capture_output=True, text=True).stdout
    assert "damping ratio, smallest over the reported modes" in info and "damping_tol 1e-06" in info


def test_info_states_the_severity_of_unstable_regions(tmp_path):
    """Undamped Bahgat-Willmert at 1000 rad/s (case full) flutters at every angle: fkev info names
    the region with the smallest damping ratio of its points, as archived."""
    import h5py

    out = tmp_path / "bw.h5"
    env = dict(os.environ, PYTHONPATH=ROOT)
    subprocess.run([sys.executable, "-m", "fkev_slepc", "run", os.path.join(ROOT, "runs", "bahgat-willmert-1976.toml"),
                    "-o", str(out), "--quiet", "--angles", "0,90", "--speeds", "1000", "--cases", "full"],
                   env=env, check=True)
    with h5py.File(out) as f:
        zmin = np.nanmin(f["damping_ratio"][()])
    assert zmin < -1e-6
    info = subprocess.run([sys.executable, "-m", "fkev_slepc", "info", str(out)], env=env, check=True,
                          capture_output=True, text=True).stdout
    line = next(ln for ln in info.splitlines() if ln.strip().startswith("unstable  full at 1000 rad/s"))
    assert f"min damping ratio {zmin:.3g}," in line and "per revolution" in line and "None" not in info
