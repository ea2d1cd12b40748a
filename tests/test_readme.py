"""The README's new-user design-study path (issue 20), run as written.

The "## Design studies" section of README.md is read here, not copied: its ```sh block (fkev
check, fkev point --sensitivity, fkev run, fkev margins, fkev design on the slider-crank
benchmark) is run command by command in a temporary directory holding the scene at the path the
README types, every output block the README quotes must appear in what the commands print, and
its ```python block (Study.replace, PointResult.sensitivity) must print what its comments say.
So the test breaks when the README drifts from the program, or the program from the README.

Quoted numbers are compared to their printed digits (tests/numtext.py): text and integers
exactly, a decimal number to within 3 units of its last quoted digit, since the last digit of a
finite-difference or solver result moves with the CPU (the sensitivity -66.1246 printed -66.1245
on an AMD EPYC). To regenerate a quoted block after a change of the program, run the ```sh block
of the section from the repository root as written (``PYTHONPATH=$PWD .venv/bin/python -m
fkev_slepc check ...`` and so on, each command once) and paste what it prints.
"""

import os
import re
import shlex
import shutil
import subprocess
import sys
from contextlib import redirect_stdout
from io import StringIO
from pathlib import Path

import pytest

from numtext import line_in, same_text

ROOT = Path(__file__).resolve().parents[1]
SCENE = "runs/slider-crank-benchmark.toml"


def section() -> str:
    text = (ROOT / "README.md").read_text()
    found = re.search(r"^## Design studies\n(.*?)(?=^## )", text, re.S | re.M)
    assert found, "README.md has no '## Design studies' section"
    return found.group(1)


def blocks(kind: str) -> list[str]:
    """The section's fenced blocks of a language (``""`` for the bare output blocks)."""
    found, lang, body = [], None, []
    for line in section().splitlines():
        if line.startswith("```"):
            if lang is None:
                lang, body = line[3:].strip(), []
            else:
                found += ["\n".join(body)] if lang == kind else []
                lang = None
        elif lang is not None:
            body.append(line)
    return found


def commands() -> list[list[str]]:
    (sh,) = blocks("sh")
    lines = [ln.split("  #")[0].strip() for ln in sh.splitlines()]
    return [shlex.split(ln) for ln in lines if ln and not ln.startswith("#")]


def normal(text: str) -> str:
    """Whitespace collapsed; θ 360 and θ 0 are one crank angle (a margin tie may print either)."""
    return re.sub(r"\s+", " ", text).replace("(θ 360)", "(θ 0)").strip()


def run_fkev(argv: list[str], cwd: Path) -> subprocess.Popen:
    assert argv[0] == "fkev", argv
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMPI_ALLOW_RUN_AS_ROOT": "1",
           "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    return subprocess.Popen([sys.executable, "-m", "fkev_slepc", *argv[1:]], cwd=cwd, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """{command name: stdout} of the section's commands, run in a directory laid out like the
    repository root (the design study, independent of the others, runs beside them)."""
    cwd = tmp_path_factory.mktemp("readme")
    (cwd / "runs").mkdir()
    shutil.copy(ROOT / SCENE, cwd / SCENE)
    cmds = commands()
    names = [c[1] for c in cmds]
    assert names == ["check", "point", "run", "margins", "design"], names
    design = run_fkev(cmds[names.index("design")], cwd)
    out = {}
    for argv in cmds:
        if argv[1] != "design":
            p = run_fkev(argv, cwd)
            stdout, stderr = p.communicate(timeout=600)
            assert p.returncode == 0, (argv, stderr)
            out[argv[1]] = stdout
    stdout, stderr = design.communicate(timeout=600)
    assert design.returncode == 0, stderr
    out["design"] = stdout
    out["cwd"] = cwd
    return out


def test_section_has_the_new_user_path():
    text = section()
    for needle in ("fkev check", "--sensitivity", "fkev margins", "fkev design", ".replace(", ".sensitivity("):
        assert needle in text, needle


def printed_lines(outputs) -> list[str]:
    return [normal(ln) for k, v in outputs.items() if k != "cwd" for ln in v.splitlines()]


def test_every_quoted_output_is_printed(outputs):
    printed = printed_lines(outputs)
    quoted = blocks("")
    assert len(quoted) >= 4
    for block in quoted:
        for line in block.splitlines():
            if line.strip():
                assert line_in(normal(line), printed), f"README quotes a line no command printed:\n{line}"


@pytest.mark.parametrize("line, wrong", [
    ("   1         -66.1246      -0.3305     -2.0431e-02", "   1         -66.1276      -0.3305     -2.0431e-02"),
    ("   1         -66.1246      -0.3305     -2.0431e-02", "   1         -66.1246      -0.3305     -2.0431e-03"),
    ("   1         -66.1246      -0.3305     -2.0431e-02", "   2         -66.1246      -0.3305     -2.0431e-02"),
    ("              0.25       63.493       195.05       755.86       856.85                731.972",
     "              0.25       63.493       195.09       755.86       856.85                731.972"),
    ("   1     60.03-90.90                  3       3Ω    0.0%  39.5, 115.8, 244.2, 320.5    2Ω 20.5 % (θ 70)",
     "   1     60.03-90.90                  3       4Ω    0.0%  39.5, 115.8, 244.2, 320.5    2Ω 20.5 % (θ 70)"),
])
def test_a_wrong_quote_is_caught(outputs, line, wrong):
    """The comparison to printed digits still fails a wrong number: 4 units of the last digit off,
    a wrong exponent, a wrong mode or crank order (the right line, quoted in the README, passes)."""
    printed = printed_lines(outputs)
    assert any(line in block for block in blocks("")), line
    assert line_in(normal(line), printed)
    assert not line_in(normal(wrong), printed)


def test_key_numbers(outputs):
    """The numbers the prose quotes are the ones in the printed tables."""
    text = section()
    mode1 = next(ln for ln in outputs["margins"].splitlines() if re.match(r"\s+1\s+60\.03-90\.90", ln))
    assert "2Ω 20.5 %" in mode1 and "39.5, 115.8, 244.2, 320.5" in mode1
    assert "2Ω stays 20.5 % below" in text and "60.0–90.9 Hz" in text
    rows = [ln.split() for ln in outputs["design"].splitlines() if re.match(r"\s+0\.[234]", ln)]
    assert [r[0] for r in rows] == ["0.25", "0.3", "0.35", "0.4"]
    prose = normal(text)
    assert ", ".join(r[2] for r in rows) in prose  # mode 2's cycle minimum, 195.05 ... 77.674
    assert ", ".join(f"{float(r[5]):.2f}" for r in rows) in prose  # buckling speeds, 731.97 ... 360.17
    assert (outputs["cwd"] / "sc-bands.png").stat().st_size > 0
    assert (outputs["cwd"] / "rod-design.h5").exists()


def test_python_block_prints_what_its_comments_say(outputs, monkeypatch):
    (code,) = blocks("python")
    monkeypatch.chdir(outputs["cwd"])
    buf = StringIO()
    with redirect_stdout(buf):
        exec(compile(code, "README.md", "exec"), {})
    expected = [m.group(1) for m in re.finditer(r"print\(.*\)\s+# (\[.*?\])", code)]
    assert len(expected) == 2
    got = [normal(ln) for ln in buf.getvalue().splitlines()]
    assert len(got) == len(expected)
    for g, e in zip(got, expected):  # rounded values: one unit of their last digit (a rounding tie)
        assert same_text(e, g, units=1, rtol=0.0), (g, e)


def test_api_refusal_names_api_arguments(tmp_path):
    """A user re-running a Python snippet (Study.sweep or Study.design into an existing archive)
    was told to pass `--resume` or `--force`, flags of the command line: the API names its own
    arguments, the command line its flags."""
    import fkev_slepc as fk
    from fkev_slepc.sweep.session import OutputError

    study, out = fk.load(ROOT / "runs/bahgat-willmert-1976.toml"), tmp_path / "bw.h5"
    grid = dict(angles_deg=[0, 10], speeds_rad_s=[0], cases=["structure"], output=out)
    study.sweep(**grid)
    with pytest.raises(OutputError, match=r"continue it with resume=True .* replace it with force=True$"):
        study.sweep(**grid)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "-m", "fkev_slepc", "run", str(ROOT / "runs/bahgat-willmert-1976.toml"),
                        "--angles", "0,10", "--speeds", "0", "--cases", "structure", "-o", str(out)],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 2 and "continue it with --resume" in r.stderr and "with --force" in r.stderr
