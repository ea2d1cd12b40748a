"""The benchmark scripts still run: each in its smallest configuration (no timing asserted).

The README and docs quote numbers from these scripts; a script broken by an API change (as
``scripts/bench_small.py`` was once, silently) would make those numbers unreproducible.
``bench_mpi_scaling.py`` is left out: it times pairs of ``mpirun`` sweeps of the full grid.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FLOAT = r"[0-9.]+(?:e[-+]?[0-9]+)?"


def run_script(name: str, *args: str) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, str(ROOT / "scripts" / name), *args], capture_output=True,
                         text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


def test_bench_small_compares_the_sweep_with_bare_qz():
    out = run_script("bench_small.py", "--angles", "0:20:10", "--repeats", "1")
    assert "54 points (3 angles x 3 speeds x 6 cases)" in out
    ratio = float(re.search(rf"ratio sweep / bare QZ: ({FLOAT})", out).group(1))
    assert 0 < ratio < 100


def test_bench_crossover_and_reuse_run():
    out = run_script("bench_crossover.py", "--elements", "2", "--repeats", "1")
    assert re.search(rf"^\s+2\s+18\s+{FLOAT}", out, re.M)
    out = run_script("bench_reuse.py", "--elements", "2", "--angles", "2", "--repeats", "1")
    assert re.search(rf"^\s+2\s+18\s+{FLOAT}\s+{FLOAT}", out, re.M)


def test_bench_pieces_compares_vectorised_and_scalar_pieces():
    out = run_script("bench_pieces.py", "--elements", "2", "--angles", "6", "--repeats", "1")
    rows = re.findall(rf"^\s+2\s+18\s+(1|default)\s+({FLOAT})\s+({FLOAT})\s+({FLOAT})\s+({FLOAT})$", out, re.M)
    assert [r[0] for r in rows] == ["1", "default"], out
    assert all(float(v) > 0 for r in rows for v in r[1:])


def test_bench_large_runs():
    out = run_script("bench_large.py", "--elements", "8", "--repeats", "1")
    assert re.search(rf"whole point / bare solve = {FLOAT}", out)


@pytest.mark.slow
def test_bench_time_vs_error_writes_json_and_figure(tmp_path):
    js, fig = tmp_path / "tve.json", tmp_path / "tve.png"
    out = run_script("bench_time_vs_error.py", "--max-mesh", "8", "--floor-meshes", "8", "--repeats", "1",
                     "--json", str(js), "--figure", str(fig))
    assert f"wrote {js} and {fig}" in out
    assert js.stat().st_size > 0 and fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bench_floquet_compares_the_monodromy_with_the_frozen_sweep():
    out = run_script("bench_floquet.py", "--repeats", "1", "--angles", "36", "--large-elements", "0",
                     "--tol", "1e-8")
    assert "frozen sweep of 36 angles" in out
    ratio = float(re.search(rf"ratio monodromy / frozen sweep: ({FLOAT})", out).group(1))
    assert 0 < ratio < 1000
    err = float(re.search(rf"multiplier error vs tol/1000 run: ({FLOAT})", out).group(1))
    assert err < 1e-6


def test_bench_floquet_table_runs():
    """``--table-steps``: at 1 element per link every level from 2 modes per link is the whole space,
    whose least step count is the full model's; ``--table``: the link components beside the full model
    (whole space again: the same max|μ| to 1e-8); ``--table-structure``: each by the generic and the
    structured Hamiltonian steps, whose monodromies agree to round-off (1e-12)."""
    out = run_script("bench_floquet.py", "--table", "bw:1:500", "--table-steps")
    cells = [c.strip() for c in out.strip().splitlines()[-1].strip("|").split("|")]
    full = int(cells[4].replace(",", ""))
    last = int(cells[-1].split(":")[1].split("(")[0].replace(",", ""))
    assert cells[2] == "9" and cells[-1].startswith("9:") and abs(last - full) <= 0.01 * full
    out = run_script("bench_floquet.py", "--table", "bw:1:500", "--table-methods", "full,links", "--repeats", "1",
                     "--angles", "36", "--table-structure")
    delta = float(re.search(rf"Δ ({FLOAT}) \(9\)", out).group(1))
    assert delta < 1e-8
    cells = [c.strip() for c in out.strip().splitlines()[-1].strip("|").split("|")]
    assert all(float(c.split(", ")[1]) <= 1e-12 for c in cells[-3:-1])  # full, links: Φ of both steps


def test_bench_floors_time_the_accepted_step_counts():
    """``bench_floquet.py --table-floor`` and ``bench_response.py --floor`` on the thesis mesh at
    500 rad/s: the Floquet's accepted step count (1,024) is the one whose bare products are timed,
    and the response, which shoots there (4,096 steps: its state needs its phases), gets a floor."""
    out = run_script("bench_floquet.py", "--table", "bw:1:500", "--table-floor", "--repeats", "1", "--angles", "36")
    cells = [c.strip() for c in out.strip().splitlines()[-1].strip("|").split("|")]
    assert cells[4] == "1,024" and all(float(c.split()[0]) > 0 for c in cells[5:9])
    out = run_script("bench_response.py", "--rows", "bw:1:500", "--repeats", "1", "--floor")
    cells = [c.strip() for c in out.strip().splitlines()[-1].strip("|").split("|")]
    assert cells[4] == "shooting, 4096 steps" and cells[10] == "1,024" and float(cells[11]) > 0


def test_bench_moving_prints_the_converged_moving_basis_beside_the_full_model():
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "bench_moving.py"), "--elements", "1",
                        "--full-max", "9"], capture_output=True, text=True, timeout=600,
                       env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr
    row = r.stdout.strip().splitlines()[-1].split("|")
    assert row[1].strip() == "1" and row[2].strip() == "9"
    moving, full = float(row[4]), float(row[7].split(",")[0])
    assert moving == pytest.approx(full, rel=1e-3, abs=1e-9)
