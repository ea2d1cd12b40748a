"""The first-hour frictions of issue 20 item 5, each as a user meets it on the command line."""

import os
import re
import subprocess
import sys

import pytest

from clitools import BW, ROOT, fkev, small_archive
from fkev_slepc.sweep.grid import parse_angles, parse_speeds, parse_speeds_rpm

MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}  # only so that the test runs as root on 2 cores


def to_closed_pipe(*args) -> subprocess.CompletedProcess:
    """``fkev ARGS`` writing into a pipe whose reader is already gone (as after ``| head -1``
    once head has exited): every write to stdout fails, deterministically."""
    r, w = os.pipe()
    os.close(r)
    try:
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        return subprocess.run([sys.executable, "-m", "fkev_slepc", *map(str, args)], stdout=w,
                              stderr=subprocess.PIPE, text=True, env=env, timeout=300)
    finally:
        os.close(w)


@pytest.mark.parametrize("command", ["export", "info", "point"])
def test_a_closed_stdout_ends_quietly_with_141(tmp_path, command):
    """`fkev export ... | head -3` ended in PETSc's "Caught signal number 13 Broken Pipe" and
    MPI_ABORT (exit 59); now like `yes | head -1`: nothing on stderr but the scene's warnings (the
    slenderness check of fkev_slepc/scene/validity.py), exit 128 + SIGPIPE."""
    args = [BW, "--angle", "10", "--speed", "0"] if command == "point" else [small_archive(tmp_path / "a.h5")]
    r = to_closed_pipe(command, *args)
    assert r.returncode == 141, r.stderr
    assert all(line.startswith("warning: ") for line in r.stderr.splitlines()), r.stderr  # the scene's own warnings only


def test_speeds_take_ranges_like_angles():
    assert parse_speeds("0:300:100") == (0.0, 100.0, 200.0, 300.0)
    assert parse_speeds("0:1000:50") == tuple(float(v) for v in range(0, 1001, 50))
    assert parse_speeds_rpm("0:60:60") == pytest.approx((0.0, 6.283185307179586))
    with pytest.raises(ValueError, match="STEP must be > 0"):
        parse_speeds("0:300:0")
    with pytest.raises(ValueError, match="speeds must be >= 0"):
        parse_speeds("-100:300:100")


def test_every_grid_in_the_docs_parses_as_typed():
    """The README's own `--speeds 0,50,...,1000` failed as typed: every --angles/--speeds value
    in README.md and docs/*.md (outside refusal examples) is a grid fkev accepts."""
    texts = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    seen = 0
    for path in texts:
        for flag, value in re.findall(r"(--angles|--speeds-rpm|--speeds)[ =]([^\s`'\"|\])]+)", path.read_text()):
            if re.search(r"[A-DF-Za-df-z]", value) or not re.search(r"\d", value):
                continue  # a syntax description (START:STOP:STEP, a,b,c, ...), not a grid
            parse = {"--angles": parse_angles, "--speeds": parse_speeds, "--speeds-rpm": parse_speeds_rpm}[flag]
            parse(value.rstrip(".,;:"))  # raises on a grid the docs show but fkev refuses
            seen += 1
    assert seen > 10


def test_speed_with_an_exponent_and_a_minus_sign_is_a_value(tmp_path):
    """argparse read `--speed -5e2` as an unknown option (only -5 and -0.5 look like numbers to
    it); now it is the same point as `--speed=-5e2`."""
    a = fkev("point", BW, "--angle", "10", "--speed", "-5e2", "--case", "full", "--json")
    b = fkev("point", BW, "--angle", "10", "--speed=-5e2", "--case", "full", "--json")
    assert a.returncode == 0, a.stderr
    assert a.stdout == b.stdout and '"speed_rad_s": -500.0' in a.stdout


def test_unknown_case_suggests_the_close_name():
    r = fkev("point", BW, "--angle", "10", "--case", "Full")
    assert r.returncode == 2
    assert "--case: unknown case 'Full'; did you mean 'full'?" in r.stderr


def test_no_negative_zero_in_point_output():
    """The structure at rest has Re λ = -0.0 exactly: printed as 0, never -0 or -0.0."""
    r = fkev("point", BW, "--angle", "10", "--speed", "0", "--case", "structure")
    assert r.returncode == 0, r.stderr
    assert "max Re λ = 0.0 1/s" in r.stdout
    assert not re.search(r"(^|\s)-0(\.0)?(\s|$)", r.stdout), r.stdout
    j = fkev("point", BW, "--angle", "10", "--speed", "0", "--case", "structure", "--json")
    assert "-0.0" not in j.stdout


def test_point_under_mpirun_prints_once():
    """`mpirun -n 2 fkev point` printed the result twice: a command that is not collective runs
    on rank 0 only."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), **MPI_ENV}
    r = subprocess.run(["mpirun", "-n", "2", sys.executable, "-m", "fkev_slepc", "point", str(BW), "--angle", "10",
                        "--speed", "500", "--case", "full"], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("Bahgat-Willmert") == 1 and r.stdout.count("max Re λ") == 1


def test_readme_quick_start_says_how_to_get_fkev():
    """A new user with only the README: `make setup` is documented, and the quick start says
    how plain `fkev` gets onto PATH (or to type .venv/bin/fkev)."""
    text = (ROOT / "README.md").read_text()
    quick = text[text.index("## Quick start"):]
    quick = quick[:quick.index("\n## ", 3)]
    assert "make setup" in text and "setup:" in (ROOT / "Makefile").read_text()
    assert ". .venv/bin/activate" in quick and ".venv/bin/fkev" in quick
