"""The README's quoted runs and the worked design study, run as written (issues 20 and 34).

Two kinds of quoted output are checked against what the commands print, numbers to their printed
digits (tests/numtext.py: text and integers exactly, a decimal number to within 3 units of its last
quoted digit, since the last digit of a finite-difference or solver result moves with the CPU; the
sensitivity -66.1246 printed -66.1245 on an AMD EPYC; an ``…`` in a quoted line stands for printed
text left out, such as round-off digits, a timing or the rest of a long line):

- **Quoted runs.** A fenced block directly after the line ``<!-- output checked by
  tests/test_readme.py -->`` in README.md or a docs/ page holds ``$ fkev ...`` (or ``$ mpirun -n
  2 fkev ...``) lines, each followed by lines of what it prints. The commands of one page run in
  order in one temporary directory laid out like the repository root (``runs/*.toml``), so a later
  one reads the archive an earlier one wrote; every quoted line must occur in the stdout of its
  command. Every ``$ `` block of README.md must carry the mark (the tour is checked whole).
- **The worked design study** ("## Worked example" of docs/design.md, moved there from the
  README): its ```sh block (fkev check, fkev point --sensitivity, fkev run, fkev margins, fkev
  design on the slider-crank benchmark) is run command by command, every output block it quotes
  must appear in what the commands print, and its ```python block (Study.replace,
  PointResult.sensitivity) must print what its comments say.

So the test breaks when the documents drift from the program, or the program from them. To
regenerate a quoted block after a change of the program, run its commands from the repository
root as written (``PYTHONPATH=$PWD .venv/bin/python -m fkev_slepc check ...`` for ``fkev check
...``, each command once, in order) and paste what they print.
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
STUDY_PAGE, STUDY_HEADING = ROOT / "docs" / "design.md", "## Worked example: the slider-crank benchmark"
MARK = "<!-- output checked by tests/test_readme.py -->"
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
       "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def section() -> str:
    text = STUDY_PAGE.read_text()
    found = re.search(rf"^{re.escape(STUDY_HEADING)}\n(.*?)(?=^## )", text, re.S | re.M)
    assert found, f"{STUDY_PAGE.name} has no '{STUDY_HEADING}' section"
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


def program(argv: list[str]) -> list[str]:
    """``fkev ARGS`` or ``mpirun -n N fkev ARGS`` as typed, with this checkout's package."""
    launcher = argv[:3] if argv[0] in ("mpirun", "mpiexec") else []
    assert launcher == [] or (argv[1] == "-n" and argv[2].isdigit()), argv
    assert argv[len(launcher)] == "fkev", argv
    return [*launcher, sys.executable, "-m", "fkev_slepc", *argv[len(launcher) + 1:]]


def run_fkev(argv: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(program(argv), cwd=cwd, env=ENV, text=True, stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def repository_like(cwd: Path) -> Path:
    """A directory laid out like the repository root for the scenes the documents type."""
    (cwd / "runs").mkdir()
    for scene in (ROOT / "runs").glob("*.toml"):
        shutil.copy(scene, cwd / "runs" / scene.name)
    return cwd


# --- quoted runs ------------------------------------------------------------------------------

def quoted_runs(text: str) -> list[tuple[str, list[str]]]:
    """(command, quoted output lines) of every marked block of a page, in page order."""
    runs, lines = [], text.splitlines()
    for i, line in enumerate(lines):
        if line.strip() != MARK:
            continue
        assert lines[i + 1] == "```", f"the line after {MARK!r} opens no bare fenced block: {lines[i + 1]!r}"
        end = lines.index("```", i + 2)
        assert lines[i + 2].startswith("$ "), f"a marked block starts with a '$ ' command: {lines[i + 2]!r}"
        for body in lines[i + 2:end]:
            if body.startswith("$ "):
                runs.append((body[2:], []))
            elif body.strip():
                runs[-1][1].append(body)
    return runs


def unmarked_runs(text: str) -> list[str]:
    """The first line of every bare fenced block that starts with '$ ' but carries no mark."""
    lines, bad, inside = text.splitlines(), [], False
    for i, line in enumerate(lines):
        if line.startswith("```"):
            if not inside and line == "```" and lines[i + 1].startswith("$ ") and lines[i - 1].strip() != MARK:
                bad.append(lines[i + 1])
            inside = not inside
    return bad


def pages_with_runs() -> list[Path]:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    return [p for p in pages if MARK in p.read_text()]


_printed: dict[tuple[str, ...], str] = {}


def printed_by(argv: list[str], cwd: Path) -> str:
    """stdout of one quoted command; a command that reads and writes no file but the scenes of
    runs/ is run once per session (the README tour and a docs page may quote the same one)."""
    key = tuple(argv)
    pure = not any(re.search(r"\.(h5|png|pdf|svg|gif|csv|json)$", a) for a in argv) and "-o" not in argv
    if pure and key in _printed:
        return _printed[key]
    p = run_fkev(argv, cwd)
    stdout, stderr = p.communicate(timeout=600)
    assert p.returncode == 0, (argv, stderr[-2000:])
    if pure:
        _printed[key] = stdout
    return stdout


@pytest.fixture(scope="module", params=pages_with_runs(), ids=lambda p: str(p.relative_to(ROOT)))
def page_runs(request, tmp_path_factory):
    """[(command, quoted lines, printed lines)] of a page's quoted runs, run in page order."""
    cwd = repository_like(tmp_path_factory.mktemp("runs"))
    out = []
    for command, quoted in quoted_runs(request.param.read_text()):
        printed = printed_by(shlex.split(command), cwd)
        out.append((command, quoted, [normal(ln) for ln in printed.splitlines()]))
    return out


def test_every_quoted_run_prints_what_is_quoted(page_runs):
    assert page_runs
    for command, quoted, printed in page_runs:
        assert quoted, f"quotes no output: {command}"
        for line in quoted:
            assert line_in(normal(line), printed), f"{command}\nquotes a line it does not print:\n{line}"


def test_the_readme_tour_is_checked_whole():
    """Every '$ ' block of the README is a checked one, and the tour covers the main commands."""
    text = (ROOT / "README.md").read_text()
    assert unmarked_runs(text) == []
    commands = [shlex.split(c) for c, _ in quoted_runs(text)]
    names = {c[c.index("fkev") + 1] for c in commands}
    assert {"check", "point", "run", "floquet", "response", "loads", "design", "design-check", "margins", "info",
            "verify"} <= names, names
    assert any(c[0] == "mpirun" for c in commands)


def test_the_block_reader_finds_marks_and_misses():
    text = "\n".join(["x", MARK, "```", "$ fkev check a.toml", "  ok", "", "$ fkev info b.h5", "  one",
                      "```", "", "```", "$ fkev verify b.h5", "```", "```sh", "$ fkev run", "```"])
    assert quoted_runs(text) == [("fkev check a.toml", ["  ok"]), ("fkev info b.h5", ["  one"])]
    assert unmarked_runs(text) == ["$ fkev verify b.h5"]
    assert program(["mpirun", "-n", "2", "fkev", "run", "s.toml"])[:4] == ["mpirun", "-n", "2", sys.executable]
    printed = ["fkev run: wrote bw.h5: 234 points (ok 159, unstable 75) in 0.5 s on 1 rank(s)",
               "  divergence (K singular): from 4434.596506 rad/s (42347.3 rpm) at θ = 180°"]
    assert line_in("fkev run: wrote bw.h5: 234 points (ok 159, unstable 75) in … s on 1 rank(s)", printed)
    assert not line_in("fkev run: wrote bw.h5: 234 points (ok 159, unstable 76) in … s on 1 rank(s)", printed)
    assert line_in("divergence (K singular): from 4434.5965… rad/s", printed)  # the left-out digits
    assert not line_in("divergence (K singular): from 4434.5975… rad/s", printed)


# --- the worked design study -------------------------------------------------------------------


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """{command name: stdout} of the section's commands, run in a directory laid out like the
    repository root (the design study, independent of the others, runs beside them)."""
    cwd = repository_like(tmp_path_factory.mktemp("study"))
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
                assert line_in(normal(line), printed), f"{STUDY_PAGE.name} quotes a line no command printed:\n{line}"


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
    a wrong exponent, a wrong mode or crank order (the right line, quoted in docs/design.md, passes)."""
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
        exec(compile(code, str(STUDY_PAGE), "exec"), {})
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
