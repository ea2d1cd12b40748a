"""``fkev floquet`` and the scenes of the cycle (Floquet) verdict (docs/stability.md)."""

from __future__ import annotations

import math
from pathlib import Path

from clitools import edited

from fkev_slepc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "runs"
BENCH = RUNS / "slider-crank-benchmark.toml"


def test_benchmark_slider_crank_has_the_classical_proportions():
    """runs/slider-crank-benchmark.toml: steel crank 0.15 m and rod 0.3 m of solid Ø 6 mm circular
    section (A = πd²/4, I = πd⁴/64 to 1e-6), a massless in-line slider, driven at 150 rad/s."""
    sc = load_scene(BENCH)
    d = 0.006
    links = {link.name: link for link in sc.links}
    assert sorted(links) == ["crank", "rod"]
    assert (links["crank"].length, links["rod"].length) == (0.15, 0.3)
    for link in links.values():
        assert math.isclose(link.area, math.pi * d**2 / 4, rel_tol=1e-6)
        assert math.isclose(link.second_moment, math.pi * d**4 / 64, rel_tol=1e-6)
        assert (link.youngs_modulus, link.density) == (2.0e11, 7870.0)
    slider = [j for j in sc.joints if j.prismatic]
    assert len(slider) == 1 and slider[0].slider_mass == 0.0 and slider[0].guide_angle == 0.0
    assert 150.0 in sc.driver.speeds


def test_frozen_time_outputs_say_so_and_point_to_floquet():
    """fkev point labels its verdict frozen-time, prints no growth "per crank revolution" stretched
    from a frozen eigenvalue, and names the fkev floquet command of the cycle verdict; its JSON
    carries stability_scope.time and no growth_per_revolution; fkev critical's speeds are frozen-time."""
    import json

    from clitools import BW, fkev

    r = fkev("point", BW, "--angle", "10", "--speed", "1000", "--case", "full")
    assert r.returncode == 0, r.stderr
    assert "frozen-time status: unstable" in r.stdout and "per crank revolution is" not in r.stdout
    assert "per crank revolution)" not in r.stdout and " x1.0" not in r.stdout
    assert f"fkev floquet {BW} --speeds 1000 --case full" in r.stdout
    out = json.loads(fkev("point", BW, "--angle", "10", "--speed", "1000", "--case", "full", "--json").stdout)
    assert "growth_per_revolution" not in out and out["stability_scope"]["time"].startswith("frozen-time")
    rest = fkev("point", BW, "--angle", "10", "--speed", "0", "--case", "structure")
    assert rest.returncode == 0 and "fkev floquet" not in rest.stdout  # at rest the frozen verdict is exact
    crit = fkev("critical", RUNS / "turcic-midha-1984.toml", "--case", "full", "--angle", "10")
    assert "frozen-time flutter" in crit.stdout and "fkev floquet" in crit.stdout, crit.stderr


def test_info_labels_its_regions_frozen_time(tmp_path):
    """fkev info: the unstable regions are frozen-time, with no growth per revolution stretched from a
    frozen eigenvalue, and a 'cycle' line names the fkev floquet command of the archived speeds."""
    from clitools import BW, fkev

    out = tmp_path / "bw.h5"
    r = fkev("run", BW, "-q", "-o", out, "--angles", "0,10", "--speeds", "0,1000", "--cases", "full")
    assert r.returncode == 0, r.stderr
    info = fkev("info", out).stdout
    assert "unstable/divergent regions (frozen-time):" in info
    region = next(ln for ln in info.splitlines() if ln.strip().startswith("unstable  full at 1000 rad/s"))
    assert "frozen-time, not a growth per revolution" in region and " x1." not in region
    cycle = next(ln for ln in info.splitlines() if ln.strip().startswith("cycle"))
    assert cycle.endswith(f"fkev floquet {BW} --speeds 1000")


# --------------------------------------------------------------------------- fkev floquet
CANTILEVER = RUNS / "rotating-cantilever.toml"
OMEGA0 = 10.0  # rad/s: the Mathieu oscillator put through the run in place of the linkage monodromy


def mathieu_evaluator(model, case, tol, eps=0.2, calls=None):
    """evaluate(speed) of ẍ + ω₀²(1 - 2ε cos Ωt)x = 0 through fkev_slepc/periodic/magnus.py's monodromy (its
    bands: tests/test_floquet_bands.py), counting the speeds evaluated in ``calls``."""
    import numpy as np

    from fkev_slepc.periodic.magnus import monodromy
    from fkev_slepc.periodic.bands import SpeedPoint

    def evaluate(speed):
        if calls is not None:
            calls.append(speed)
        r = (OMEGA0 / speed) ** 2

        def gen(theta):
            A = np.zeros((theta.size, 2, 2))
            A[:, 0, 1] = 1.0
            A[:, 1, 0] = -r * (1.0 - 2.0 * eps * np.cos(theta))
            return A

        return SpeedPoint.of(speed, monodromy(gen, 2 * np.pi, tol=1e-12)), ""

    return evaluate


def mathieu_edges(n, eps=0.2):
    import numpy as np
    from scipy.optimize import brentq
    from scipy.special import mathieu_a, mathieu_b

    def speed(char):
        a = brentq(lambda a: a - char(n, eps * a), 0.5 * n * n, 2.0 * n * n + 1.0, xtol=1e-14)
        return 2.0 * OMEGA0 / np.sqrt(a)

    return sorted((speed(mathieu_a), speed(mathieu_b)))


def _request(tmp_path, speeds="8:26:0.4", **kw):
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.sweep.floquet_run import FloquetRequest
    from fkev_slepc.sweep.grid import configure

    scene = configure(with_elements(load_scene(CANTILEVER), 2), angles=[0, 180], speeds=speeds, cases=["full"])
    return FloquetRequest(scene, tmp_path / "fq.h5", **kw)


def test_floquet_run_archives_bands_resumes_and_opens_with_xarray(tmp_path, monkeypatch):
    """The whole run (frozen sweep, /floquet units, brackets refined, labels, finalize) with a
    Mathieu oscillator in place of the monodromy: both tongues in 8-26 rad/s found with edges
    within 1e-6 of the closed form and labelled 2ω̄1/1, 2ω̄1/2 (ω̄ patched to ω₀); the archive
    verifies and opens with xarray (dimension scales); a resume solves only the pending speeds
    and gives the same bands."""
    import h5py
    import numpy as np
    import xarray as xr

    from fkev_slepc.archive import products as P
    from fkev_slepc.archive.verify import verify
    from fkev_slepc.sweep import floquet_run as fr

    monkeypatch.setattr(fr, "_mean_frequencies", lambda part: (lambda w: [OMEGA0]))
    calls = []
    req = _request(tmp_path)
    out = fr.run_floquet(req, evaluator=lambda *a: mathieu_evaluator(*a, calls=calls))
    res = fr.read_floquet(out)
    assert verify(out).ok and len(res.speed_rad_s) == 46
    assert [b.resonance for b in res.bands] == ["2ω̄1/2", "2ω̄1/1"]
    for band, n in zip(res.bands, (2, 1)):
        lo, hi = mathieu_edges(n)
        assert abs(band.lower / lo - 1) < 1e-6 and abs(band.upper / hi - 1) < 1e-6, (band, lo, hi)
    d = res.as_dict()
    assert {"speed_rad_s", "multipliers", "max_abs_multiplier", "bands"} <= set(d)
    assert len(d["multipliers"][0]) == 2 and all(len(z) == 2 for z in d["multipliers"][0])
    assert set(d["bands"][0]) >= {"lower_rad_s", "upper_rad_s", "resonance"}
    # what a band is: a run of consecutive unstable grid speeds (listed) between two refined edges
    for b in d["bands"]:
        run = [w for w, st in zip(d["speed_rad_s"], d["status"]) if b["lower_rad_s"] <= w <= b["upper_rad_s"]]
        assert b["unstable_grid_speeds_rad_s"] == run and len(run) == b["grid_speeds_inside"] >= 1, (b, run)
        assert {d["status"][d["speed_rad_s"].index(w)] for w in run} == {"unstable"}
    from fkev_slepc.cli.floquet import lines

    text = "\n".join(lines(d))
    assert "between the grid speeds of a run the verdict is not sampled" in text
    narrow, wide = (b["unstable_grid_speeds_rad_s"] for b in d["bands"])  # the tongues n = 2 (one grid speed), 1
    assert len(narrow) == 1 and f"(unstable at the grid speed {narrow[0]:g})" in text, text
    assert len(wide) > 6 and f"(unstable at the grid speeds {wide[0]:g}, {wide[1]:g}, ..., {wide[-1]:g} ({len(wide)}); " \
        "between them not sampled)" in text, text
    with xr.open_dataset(out, group="floquet", engine="h5netcdf") as ds:
        assert ds.max_abs_multiplier.dims == ("speed_rad_s", "case") and ds.status.attrs["units"] == "1"
    with xr.open_dataset(out, group="floquet/bands", engine="h5netcdf") as ds:
        assert ds.sizes["band"] == 2 and ds.lower_rad_s.attrs["units"] == "rad/s"
    from fkev_slepc.plots.floquet import speed_map

    ax = speed_map(res).axes[0]  # the bands shaded, labelled with their resonance
    assert len(ax.patches) == 2 and {t.get_text() for t in ax.texts} == {"2ω̄1/1", "2ω̄1/2"}
    from clitools import fkev

    info = fkev("info", out).stdout
    assert "cycle       Floquet verdict of this archive (fkev floquet):" in info and "2ω̄1/1 = " in info
    # resume: three speeds back to pending are the only ones solved on the grid again
    with edited(out) as f:
        f[P.F_STATUS.path][[3, 20, 40], 0] = 0
    n_before = len(calls)
    again = fr.read_floquet(fr.run_floquet(_request(tmp_path, resume=True),
                                           evaluator=lambda *a: mathieu_evaluator(*a, calls=calls)))
    grid_again = [w for w in calls[n_before:] if np.any(np.isclose(w, res.speed_rad_s, rtol=0, atol=1e-12))]
    assert sorted(grid_again) == sorted(res.speed_rad_s[[3, 20, 40]].tolist())
    assert [(b.lower, b.upper) for b in again.bands] == [(b.lower, b.upper) for b in res.bands]


def test_floquet_run_over_two_ranks_gives_the_serial_bands(tmp_path):
    """mpiexec -n 2: the speeds and the brackets dealt to two ranks give the serial run's
    multipliers to 1e-12 and the same band edges."""
    import os
    import subprocess
    import sys

    import numpy as np

    from fkev_slepc.sweep import floquet_run as fr

    serial = fr.read_floquet(fr.run_floquet(_request(tmp_path / "s", speeds="8:26:1.0"), evaluator=mathieu_evaluator))
    script = tmp_path / "two_ranks_script"
    script.write_text(
        "import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1])\n"
        "from mpi4py import MPI\nimport test_floquet_cli as t\nfrom fkev_slepc.sweep import floquet_run as fr\n"
        "fr.run_floquet(t._request(Path(sys.argv[2]), speeds='8:26:1.0'), MPI.COMM_WORLD, evaluator=t.mathieu_evaluator)\n")
    (tmp_path / "p").mkdir()
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PYTHONPATH=str(ROOT),
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
    r = subprocess.run(["mpiexec", "-n", "2", sys.executable, str(script), str(ROOT / "tests"), str(tmp_path / "p")],
                       env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    par = fr.read_floquet(tmp_path / "p" / "fq.h5")
    np.testing.assert_allclose(par.max_abs, serial.max_abs, rtol=1e-12)
    assert len(par.bands) == len(serial.bands) == 2
    assert [(b.lower, b.upper) for b in par.bands] == [(b.lower, b.upper) for b in serial.bands]


def test_floquet_refuses_bad_flags_naming_them():
    """Speeds must be > 0 (at rest the frozen verdict is exact), tolerances in (0, 1), a range
    START:STOP:STEP well formed: exit 2, the flag named, nothing computed."""
    from clitools import BW, fkev

    for flags, name in ((("--speeds", "0,100"), "--speeds"), (("--speeds", "100:50:10"), "--speeds"),
                        (("--speeds", "100", "--tol", "2"), "--tol"), (("--speeds", "100", "--case", "9"), "--case")):
        r = fkev("floquet", BW, *flags, "-o", "/nonexistent/x.h5")
        assert r.returncode == 2 and name in r.stderr and "Traceback" not in r.stderr, (flags, r.stderr)


def test_fkev_floquet_json_on_the_undamped_four_bar(tmp_path):
    """fkev floquet with the linkage's own monodromy (exact periodic coefficients): undamped
    Bahgat-Willmert, case full, at 500 rad/s, where the frozen-time verdict calls most crank angles
    unstable, is Floquet-stable: max|μ| = 1 to 1e-8, the multiplier set closed under μ -> 1/μ̄."""
    import json

    import numpy as np

    from clitools import BW, fkev

    r = fkev("floquet", BW, "--speeds", "500", "--angles", "0:360:60", "--no-critical", "--json", "-o",
             tmp_path / "bw.h5")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["speed_rad_s"] == [500.0] and out["bands"] == [] and out["status"] == ["ok"]
    assert abs(out["max_abs_multiplier"][0] - 1.0) < 1e-8
    assert out["frozen_time_unstable_fraction"][0] > 0.5
    mu = np.array([complex(*z) for z in out["multipliers"][0]])
    assert mu.size == 30 and np.max(np.min(np.abs(mu[:, None] - 1 / mu.conj()[None, :]), axis=1)) < 1e-8


def test_interrupted_edge_refinement_resumes_where_it_stopped(tmp_path):
    """Every monodromy of the edge refinement is archived (/floquet/samples) as it is solved: a
    run stopped by Ctrl-C in the refinement (FKEV_PAUSE_AFTER: paused after the second round, no
    race) exits 130 with those speeds in the .part; --resume solves only the speeds it had not,
    and ends with the uninterrupted run's edges and samples, bit for bit; a resume with a tighter
    --rtol continues the bisection (no speed solved twice)."""
    import os
    import shutil
    import signal
    import subprocess
    import sys

    import h5py
    import numpy as np

    from test_cli_interrupt import interrupt_when_paused

    from fkev_slepc.sweep import floquet_run as fr
    from fkev_slepc.sweep.floquet_samples import read_samples
    from fkev_slepc.sweep.interrupt import PAUSE_VARIABLE

    calls = []
    ref = fr.run_floquet(_request(tmp_path, speeds="8:26:1.0"), evaluator=lambda *a: mathieu_evaluator(*a, calls=calls))
    first, ref_samples = fr.read_floquet(ref), read_samples(ref)
    assert len(first.bands) == 2 and first.samples == {"edge": len(ref_samples), "probe": 0} and len(ref_samples) > 8
    assert sorted(ref_samples) == sorted(calls[19:])  # after the 19 grid speeds, each refinement speed once
    run = tmp_path / "run"
    run.mkdir()
    shutil.copy(ref, run / "fq.h5")
    with edited(run / "fq.h5") as f:  # grid and frozen sweep done, refinement not started, in an
        del f["floquet/samples"]  # archive written before /floquet/samples existed (they are added)
    script = tmp_path / "interrupted_script"
    script.write_text(
        "import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1])\n"
        "import test_floquet_cli as t\nfrom fkev_slepc.sweep import floquet_run as fr\n"
        "from fkev_slepc.sweep.interrupt import SweepInterrupted\n"
        "try:\n    fr.run_floquet(t._request(Path(sys.argv[2]), speeds='8:26:1.0', resume=True), "
        "evaluator=t.mathieu_evaluator, notify=lambda m: print(m, file=sys.stderr, flush=True))\n"
        "except SweepInterrupted as e:\n    sys.exit(e.exit_code)\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), PAUSE_VARIABLE: "3", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, str(script), str(ROOT / "tests"), str(run)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    code, err, written = interrupt_when_paused(proc, sig=signal.SIGINT)
    assert code == 130 and written == 4 and "continue with: the same run with resume=True" in err, err
    kept = read_samples(run / "fq.h5.part")
    assert len(kept) == 4 and all(ref_samples[w][0].max_abs == p.max_abs for w, (p, _) in kept.items())
    calls.clear()
    again = fr.read_floquet(fr.run_floquet(_request(run, speeds="8:26:1.0", resume=True),
                                           evaluator=lambda *a: mathieu_evaluator(*a, calls=calls)))
    assert sorted(calls) == sorted(set(ref_samples) - set(kept))  # the grid and the 4 kept not solved again
    assert [(b.lower, b.upper, b.resonance) for b in again.bands] == [(b.lower, b.upper, b.resonance) for b in first.bands]
    done = read_samples(run / "fq.h5")
    assert sorted(done) == sorted(ref_samples)
    for w, (p, purpose) in done.items():
        assert purpose == "edge" and np.array_equal(p.multipliers, ref_samples[w][0].multipliers)
    calls.clear()  # a tighter --rtol on resume continues the bisection: no speed solved twice
    finer = fr.read_floquet(fr.run_floquet(_request(run, speeds="8:26:1.0", resume=True, rtol=1e-9),
                                           evaluator=lambda *a: mathieu_evaluator(*a, calls=calls)))
    assert calls and not set(calls) & set(done) and len(calls) <= 4 * 12  # 4 edges, log2(1e3) < 10 more each
    for b, c in zip(finer.bands, first.bands):
        assert abs(b.lower / c.lower - 1) < 1e-6 and abs(b.upper / c.upper - 1) < 1e-6


def test_a_band_open_at_both_ends_of_the_speeds_examined(tmp_path):
    """Undamped Bahgat-Willmert at 800 rad/s alone (inside the band 710-838 rad/s of
    docs/stability.md): unstable, a band open at both ends; its JSON edges are null, the grid
    ends that bound it are given; the text says "1 speed" and which edge was not located; a
    negative --resonance-order is refused naming the flag."""
    import json

    from clitools import BW, fkev

    args = ("floquet", BW, "--speeds", "800", "--angles", "0:360:60", "--no-critical", "-o", tmp_path / "bw.h5")
    r = fkev(*args, "--json")
    assert r.returncode == 0, r.stderr
    (band,) = json.loads(r.stdout)["bands"]
    assert (band["lower_rad_s"], band["upper_rad_s"], band["lower_open"], band["upper_open"]) == (None, None, True, True)
    assert band["unstable_down_to_rad_s"] == band["unstable_up_to_rad_s"] == 800.0 and band["peak_max_abs_multiplier"] > 1.01
    text = fkev(*args, "--resume").stdout  # nothing left to solve: the same archive as text
    assert ", 1 speed 800 rad/s;" in text and "1 of 1 grid speed unstable" in text, text
    assert "<= 800 to >= 800 rad/s, unstable at the lowest and the highest speed examined" in text
    bad = fkev("floquet", BW, "--speeds", "800", "--resonance-order", "-1", "-o", tmp_path / "x.h5")
    assert bad.returncode == 2 and "--resonance-order" in bad.stderr and "Traceback" not in bad.stderr, bad.stderr


def test_study_floquet_is_the_api_of_fkev_floquet(tmp_path):
    """Study.floquet (lost from Study when the running-speed methods moved to a mixin) runs the
    same analysis: undamped Bahgat-Willmert at 500 rad/s is Floquet-stable, max|μ| = 1 to 1e-8."""
    from fkev_slepc.api import load

    res = load(RUNS / "bahgat-willmert-1976.toml").floquet([500.0], "full", tmp_path / "bw.h5", angles_deg=[0, 90, 180, 270],
                                                         critical=False, resonance_order=2)
    assert res.bands == () and abs(res.max_abs[0] - 1.0) < 1e-8 and res.resonance_order == 2 and res.gaps == ()


def test_one_speed_on_two_ranks_splits_its_monodromy(tmp_path):
    """Fewer speeds than ranks: both ranks work on the one speed, each multiplying its own segment of the
    Magnus steps (fkev_slepc/periodic/magnus.py ``_product``); the multipliers equal the serial run's to 1e-12."""
    import os
    import subprocess
    import sys

    import numpy as np

    from clitools import BW, fkev
    from fkev_slepc.sweep.floquet_run import read_floquet

    args = ("floquet", BW, "--elements", "1", "--speeds", "650", "--angles", "0:360:90", "--no-critical")
    serial = fkev(*args, "-o", tmp_path / "s.h5")
    assert serial.returncode == 0, serial.stderr
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PYTHONPATH=str(ROOT),
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
    par = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-m", "fkev_slepc", *map(str, args), "-o",
                          str(tmp_path / "p.h5")], env=env, capture_output=True, text=True, timeout=600)
    assert par.returncode == 0, par.stderr
    assert "1 of 1 speed(s) to solve, each monodromy split over 2 ranks" in par.stderr
    a, b = read_floquet(tmp_path / "s.h5"), read_floquet(tmp_path / "p.h5")
    assert list(a.status) == list(b.status) and len(a.bands) == len(b.bands) == 1  # (w2-w1)/5 at 650 rad/s
    # the scene's title names its own 5 elements; the report and figure say the mesh analysed
    assert a.title.endswith("5 elements [re-meshed: 3 el (1+1+1)]") and a.title in serial.stdout
    mu_a, mu_b = (np.sort_complex(m[np.isfinite(m)]) for m in (a.multipliers[0], b.multipliers[0]))  # |μ| ties
    np.testing.assert_allclose(mu_b, mu_a, rtol=0, atol=1e-12 * np.nanmax(np.abs(mu_a)))
