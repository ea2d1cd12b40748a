"""Mesh convergence of the Floquet verdict with the link-component reduction
(scripts/mesh_convergence.py, docs/stability.md "Mesh convergence of the cycle verdict").

Known answers: a Floquet frequency is defined modulo the crank speed Ω, and its folded value
|arg μ|·Ω/2π is the same for every branch kΩ ± f; the convergence table's arithmetic gives rate 4
and an exact order-4 Richardson prediction on frequencies f∞ + C·n⁻⁴. Physics: Bahgat–Willmert
at 500 rad/s with one fixed-interface mode per link (the same retained physics at every mesh:
7 vectors) is Floquet-stable (undamped |μ| = 1 to round-off) at 4, 8 and 16 elements per link,
where the full model at 4 elements per link is unstable through bands of high FE modes, and its
lowest four Floquet frequencies converge at the rate of cubic Euler–Bernoulli elements, h⁴
(measured 3.91–3.96; asserted within 4 ± 0.25).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "mesh_convergence.py"


@pytest.fixture(scope="module")
def mc():
    sys.path.insert(0, str(ROOT / "scripts"))  # benchlib, as the script finds it
    spec = importlib.util.spec_from_file_location("mesh_convergence", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def test_folded_frequency_is_branch_free(mc):
    """kΩ + f and kΩ - f fold to f ∈ [0, Ω/2]: the two branches the engine's unwrapping chose for
    the lowest Bahgat–Willmert pair at 4 and 8 elements per link (2909.96 = 6·500 - 90.04 and
    2592.70 = 5·500 + 92.70) fold to 90.04 and 92.70."""
    w = 500.0
    f = np.array([0.0, 37.5, 190.0, 250.0])
    for k in range(0, 9):
        np.testing.assert_allclose(mc.folded(k * w + f, w), f, atol=1e-9)
        np.testing.assert_allclose(mc.folded(np.abs(k * w - f), w), f, atol=1e-9)
    np.testing.assert_allclose(mc.folded([2909.96, 2592.70], w), [90.04, 92.70], atol=1e-9)


def test_convergence_table_measures_rate_four_and_richardson(mc):
    """On f(n) = f∞ + C/n⁴ (below Ω/2, so folding is the identity) the changes between doubled
    meshes shrink 16-fold (rate 4), and the order-4 Richardson prediction of an unequal step
    (32 -> 111) is exact."""
    w, n = 500.0, [4, 8, 16, 32, 111]
    f_inf, c = np.array([85.3, 115.4, 215.4, 183.1]), np.array([2e3, -5e3, 8e3, 1.2e4])
    points = [mc.MeshPoint(k, 9 * k, 7, 0.0, 1.0, 0.0, f_inf + c / k**4, 0.0, 0.0) for k in n]
    f, changes, rates, pred = mc.convergence(points, w)
    np.testing.assert_allclose(rates[1:3], 4.0, rtol=1e-9)
    assert np.isnan(rates[3]).all() and np.isnan(rates[0]).all()  # 16 -> 32 -> 111: unequal ratios
    np.testing.assert_allclose(pred[4], f[4], atol=1e-10)
    assert np.isnan(pred[:4]).all()
    np.testing.assert_allclose(changes[0], np.abs(c) * (1 / 4**4 - 1 / 8**4), rtol=1e-9)


def _run(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, env=env,
                          timeout=300)


def _rows(text: str, cells: int) -> list[list[float]]:
    """The rows of the printed markdown tables with ``cells`` cells, numbers (empty -> NaN)."""
    out = []
    for line in text.splitlines():
        c = [x.strip() for x in line.strip().strip("|").split("|")]
        if line.startswith("| ") and len(c) == cells and c[0].isdigit():
            out.append([float(x.split(",")[0]) if x else float("nan") for x in c])
    return out


def test_bahgat_willmert_floquet_frequencies_converge_at_h4_and_stay_stable():
    """Bahgat–Willmert, 500 rad/s, 1 fixed-interface mode per link at 4, 8, 16 elements per link
    (the script, one BLAS thread): the same 7-vector basis at every mesh, undamped |μ| = 1 to 1e-12
    (stable at every mesh), and the lowest four folded Floquet frequencies changing by less each
    doubling, at the rate log2(Δ₄₋₈/Δ₈₋₁₆) = 4 ± 0.25 (cubic elements: h⁴)."""
    out = _run("--scene", "bw", "--speed", "500", "--elements", "4,8,16", "--modes", "1", "--tol", "1e-8")
    assert out.returncode == 0, out.stderr[-2000:]
    meshes = np.array(_rows(out.stdout, 9))
    np.testing.assert_array_equal(meshes[:, :3], [[4, 36, 7], [8, 72, 7], [16, 144, 7]])
    assert np.all(np.abs(meshes[:, 4]) < 1e-12)
    cov = meshes[:, 3]
    assert cov[0] > cov[2] > 0.99 * cov[0]  # the same modes, their frequencies converging from above
    table = np.array(_rows(out.stdout, 13))
    assert table.shape == (3, 13) and np.all(table[:, 1:5] <= 250.0)  # folded: within [0, Ω/2]
    changes, rates = table[:2, 5:9], table[1, 9:13]
    assert np.all(changes[1] < changes[0] / 10) and np.all(changes[1] < 0.2)
    assert np.all(np.abs(rates - 4.0) < 0.25), rates


def test_script_rejects_bad_input_before_work():
    """One error naming the option and its value, exit 2."""
    for args, name in ((["--elements", "4,0"], "--elements"), (["--edge", "56:54"], "--edge")):
        out = _run(*args)
        assert out.returncode == 2, out.stderr
        assert f"error: {name}:" in out.stderr and args[1] in out.stderr
