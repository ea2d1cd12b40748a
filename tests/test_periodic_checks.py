"""Errors before work in the periodic commands (issue 24 item 6, issue 27 item 3): ``fkev floquet``
and ``fkev response`` refuse a crank that cannot turn fully, harmonics below 2 and a dense harmonic
balance past its limit with one line and exit 2 before any sweep (nothing left on disk), and a
single-speed response whose error estimate misses its tolerance exits 3."""

from clitools import ROOT
from clitools import fkev as run_fkev

RUNS = ROOT / "runs"
BENCH = RUNS / "slider-crank-benchmark.toml"


def _non_turning(tmp_path):
    """Bahgat-Willmert with a 0.3 m crank: longer than the ground link, it cannot turn fully."""
    text = (RUNS / "bahgat-willmert-1976.toml").read_text().replace("length_m = 0.1270", "length_m = 0.3000", 1)
    path = tmp_path / "rocker.toml"
    path.write_text(text)
    return path


def test_a_crank_that_cannot_turn_is_refused_before_any_sweep(tmp_path):
    scene = _non_turning(tmp_path)
    out = tmp_path / "out"
    for args in (("floquet", scene, "--speeds", "100", "-o", out / "f.h5"),
                 ("response", scene, "--speed", "100"),
                 ("response", scene, "--speeds", "100,200", "-o", out / "r.h5")):
        r = run_fkev(*args)
        assert r.returncode == 2, (args, r.stderr)
        lines = [x for x in r.stderr.splitlines() if "driver.link" in x]
        assert len(lines) == 1 and "cannot turn fully" in lines[0] and "Traceback" not in r.stderr
    assert not out.exists() or not any(out.iterdir())  # no archive, .part or .lock


def test_harmonics_are_checked_before_the_balance():
    """H = 1 compared itself with itself (error 0.0 stated for an answer 280x too small): refused; a
    dense balance past its limit is refused with its size; a fixed H whose estimate misses --tol exits 3."""
    base = ("response", BENCH, "--speed", "150", "--elements", "1", "--angles", "0:180:90")
    one = run_fkev(*base, "--harmonics", "1")
    assert one.returncode == 2 and "--harmonics" in one.stderr and ">= 2" in one.stderr
    big = run_fkev(*base, "--harmonics", "100000")
    assert big.returncode == 2 and "unknowns" in big.stderr and "Traceback" not in big.stderr
    two = run_fkev(*base, "--harmonics", "2")
    assert two.returncode == 3 and "misses --tol" in two.stderr


def test_speeds_in_rpm_are_the_same_speeds():
    """--speed-rpm (response, loads) and --speeds-rpm (response, floquet, design) as point/run/margins:
    1432.39... rpm is 150 rad/s exactly; a bad rpm value is named by its own flag."""
    import json

    rpm = 150.0 * 30.0 / __import__("math").pi
    base = ("response", BENCH, "--elements", "1", "--angles", "0:180:90", "--harmonics", "64", "--json")
    a, b = (json.loads(run_fkev(*base, *s).stdout) for s in (("--speed", "150"), ("--speed-rpm", repr(rpm))))
    assert abs(b["speed_rad_s"] - 150.0) < 1e-12 and a["stations"] == b["stations"]
    la, lb = (run_fkev("loads", BENCH, "--angles", "0,90", *s).stdout for s in (("--speed", "150"),
                                                                              ("--speed-rpm", repr(rpm))))
    assert la.splitlines()[1:] == lb.splitlines()[1:]
    for cmd in ("floquet", "design", "response"):
        extra = ("--set", "links[0].length_m=0.15,0.16") if cmd == "design" else ()
        r = run_fkev(cmd, BENCH, *extra, "--speeds-rpm=-5")
        assert r.returncode == 2 and "--speeds-rpm" in r.stderr, (cmd, r.stderr)
