"""The package layout stays a pipeline: no import cycles, small modules, cited files exist."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "fkev_slepc"
MAX_LINES = 400


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PKG.rglob("*.py")}


def _imports(path: Path, name: str, known: set[str]) -> set[str]:
    """Package modules imported anywhere in ``path`` (function-level imports included)."""
    is_pkg = path.name == "__init__.py"
    here = name if is_pkg else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = here.split(".")[: len(here.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            # ``from pkg import submodule`` depends on the submodule, ``from mod import name`` on mod
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        else:
            continue
        out.update(t for t in targets if t in known and t != name)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    known = set(mods)
    return {m: _imports(p, m, known) for m, p in mods.items()}


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state and (cyc := visit(n)):
                return cyc
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (cyc := visit(m)):
            return cyc
    return None


def test_cycle_finder_finds_a_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycles():
    graph = _graph()
    assert "fkev_slepc.model.operators" in graph and graph["fkev_slepc.model.operators"]
    assert _find_cycle(graph) is None, " -> ".join(_find_cycle(graph))


STAGES = ["status", "scene", "model", "solve", "periodic", "archive", "sweep", "design", "plots", "api", "cli"]


def _stage(mod: str) -> int | None:
    parts = mod.split(".")
    return STAGES.index(parts[1]) if len(parts) > 1 and parts[1] in STAGES else None


def test_lower_stages_never_import_higher_ones():
    """status < scene < model < solve < periodic < archive < sweep < design < plots < api < cli."""
    bad = []
    for mod, deps in _graph().items():
        s = _stage(mod)
        for d in deps:
            t = _stage(d)
            if s is not None and t is not None and t > s:
                bad.append(f"{mod} -> {d}")
    assert not bad, bad


@pytest.mark.parametrize("path", sorted(PKG.rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_are_small(path):
    assert len(path.read_text().splitlines()) <= MAX_LINES


# --- cited files exist ------------------------------------------------------------------------
# Every file a comment or a document names must be in the repository: a stale path (a module
# that moved, a note that was never committed) sends readers nowhere.

CITING = ("fkev_slepc/**/*.py", "scripts/*", "tests/*.py", "runs/*.toml", "runs/*.md", "docs/*.md",
          "README.md", "Makefile")
# a path with a file extension we cite (not archives or other outputs), optionally with folders
_PATH = re.compile(r"(?<![\w./@:-])((?:[\w.-]+/)*[\w-]+(?:\.[\w-]+)*\.(?:md|py|sh|toml|png))(?![\w/-])")
_MODULE = re.compile(r"\bfkev_slepc((?:\.\w+)+)")
# a test named in a document (`test_x`, or a test file followed by ::test_x), not a test file
_TEST = re.compile(r"(?<![\w/])(test_\w+)(?![\w.])")


def _citing_files(root: Path) -> list[Path]:
    files = {p for pattern in CITING for p in root.glob(pattern) if p.is_file()}
    return sorted(p for p in files if "__pycache__" not in p.parts)


def _exported(pkg: Path) -> set[str]:
    """Names the package exports (``fkev_slepc.load``, ``fkev_slepc.open``: the Python API)."""
    init = pkg / "__init__.py"
    if not init.is_file():
        return set()
    for node in ast.walk(ast.parse(init.read_text())):
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return set(ast.literal_eval(node.value))
    return set()


def _missing_citations(root: Path) -> list[str]:
    """``file: cited`` for every cited path that exists neither from ``root`` nor next to the file.

    A ``.py`` or ``.md`` name without a folder (``engines.py``) only has to match the name of
    some file in the repository (other bare names are examples: ``scene.toml``, ``freq.png``). A
    path with folders is checked when its first folder is in the repository (from the root, or
    next to the citing file as in a Markdown link); ``runs/out/`` holds outputs, never committed.
    ``fkev_slepc.<module>...`` must start with an existing module or subpackage, and a test a
    Markdown file names must be defined in ``tests/``.
    """
    names = {p.name for p in root.rglob("*") if ".git" not in p.parts and ".venv" not in p.parts}
    tests = set()
    for t in root.glob("tests/*.py"):
        tests.update(re.findall(r"^\s*def (test_\w+)", t.read_text(), flags=re.M))
    bad = []
    for f in _citing_files(root):
        text = f.read_text(errors="replace")
        for cited in sorted(set(_PATH.findall(text))):
            first = cited.split("/")[0]
            if "/" not in cited:
                ok = cited in names or not cited.endswith((".py", ".md"))
            elif (root / first).is_dir() or (f.parent / first).is_dir():
                ok = (root / cited).exists() or (f.parent / cited).exists() or cited.startswith("runs/out/")
            else:
                ok = True  # an example path (out/freq.png, dir/scene.toml)
            if not ok:
                bad.append(f"{f.relative_to(root)}: {cited}")
        for dotted in sorted(set(_MODULE.findall(text))):
            first = dotted.split(".")[1]
            pkg = root / "fkev_slepc"
            if not ((pkg / first).is_dir() or (pkg / f"{first}.py").is_file() or first in _exported(pkg)):
                bad.append(f"{f.relative_to(root)}: fkev_slepc{dotted}")
        if f.suffix == ".md":
            bad.extend(f"{f.relative_to(root)}: {t}" for t in sorted(set(_TEST.findall(text)) - tests))
    return bad


_LINK = re.compile(r"\]\(([\w./-]*?)#([^)\s]+)\)")


def _anchors(md: Path) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces to hyphens."""
    out, fenced = set(), False
    for line in md.read_text().splitlines():
        fenced ^= line.startswith("```")
        if not fenced and (m := re.match(r"#{1,6} +(.*)", line)):
            out.add(re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-"))
    return out


def _broken_anchors(root: Path) -> list[str]:
    """``file: target#anchor`` for every Markdown link to a heading that does not exist."""
    bad = []
    for f in sorted(root.glob("*.md")) + sorted(root.glob("*/*.md")):
        for target, anchor in _LINK.findall(f.read_text()):
            md = (f.parent / target) if target else f
            if md.suffix == ".md" and md.is_file() and anchor not in _anchors(md):
                bad.append(f"{f.relative_to(root)}: {target}#{anchor}")
    return bad


def test_missing_citations_are_found(tmp_path):
    """The check itself: a moved module and a note that is not in the repository are reported."""
    (tmp_path / "docs").mkdir()
    (tmp_path / "fkev_slepc" / "solve").mkdir(parents=True)
    (tmp_path / "fkev_slepc" / "solve" / "slepc.py").write_text("")
    (tmp_path / "docs" / "engine.md").write_text("see docs/engine.md\n")
    # the stale names are split so that this file does not cite them itself
    stale = ["docs/nowhere" + ".md", "fkev_slepc/eigen" + ".py", "backend" + ".py",
             "fkev_slepc" + ".eigen.Engine"]
    fine = "`fkev_slepc/solve/slepc.py`, slepc.py, fkev_slepc.solve.slepc, out/freq.png, scene.toml\n"
    (tmp_path / "README.md").write_text(fine + ", ".join(stale))
    (tmp_path / "tests").mkdir()
    test_file, doc = "test_a" + ".py", "tests" + ".md"
    (tmp_path / "tests" / test_file).write_text("def test_here():\n    pass\n")
    (tmp_path / "docs" / doc).write_text(f"tests/{test_file}::test_here, `test_" + f"gone`, {test_file}\n")
    assert _missing_citations(tmp_path) == ["README.md: " + c for c in sorted(stale[:3]) + stale[3:]] + [
        f"docs/{doc}: test_" + "gone"
    ]
    engine = "## Options (`-fkev_`)\n```\n# not a heading\n```\n[a](#options--fkev_)"
    (tmp_path / "docs" / "engine.md").write_text(engine)
    links = "[a](docs/engine.md#options--fkev_) [b](docs/engine.md#not-a-heading) [c](#gone)\n"
    (tmp_path / "README.md").write_text("# Top\n" + links)
    assert _broken_anchors(tmp_path) == ["README.md: docs/engine.md#not-a-heading", "README.md: #gone"]


def _theory_sections(theory: Path) -> set[str]:
    """Section numbers of docs/theory.md: ``## 10. Title`` -> 10, ``### 10.3 Title`` -> 10.3."""
    return set(re.findall(r"^#{2,3} (\d+(?:\.\d+)?)\.? ", theory.read_text(), flags=re.M))


def _unknown_sections(root: Path) -> list[str]:
    """``file: §N`` for every section a line citing docs/theory.md names that does not exist."""
    sections = _theory_sections(root / "docs" / "theory.md")
    bad = []
    for f in _citing_files(root):
        for line in f.read_text(errors="replace").splitlines():
            if "theory.md" in line:
                bad.extend(f"{f.relative_to(root)}: §{n}" for n in re.findall(r"§(\d+(?:\.\d+)?)", line)
                           if n not in sections)
    return bad


def test_theory_section_citations_resolve(tmp_path):
    """Code and docs cite `docs/theory.md §N`: the section must exist (and the check must work)."""
    assert {"1", "5.4", "10.3", "17"} <= _theory_sections(ROOT / "docs" / "theory.md")
    bad = _unknown_sections(ROOT)
    assert not bad, "sections of docs/theory.md that do not exist:\n" + "\n".join(bad)
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "theory.md").write_text("## 1. One\n### 1.2 Two\n")
    cites = "docs/theory.md §1, §" + "1.2 and §" + "3\n§4 (no citation here)\n"
    (tmp_path / "README.md").write_text(cites)
    assert _unknown_sections(tmp_path) == ["README.md: §" + "3"]


# Cited by work in progress (the CLI notes) that is being written now; drop an entry as soon as
# its file is in the repository.
PENDING: set[str] = set()


def test_cited_files_exist():
    assert (ROOT / "docs" / "theory.md").is_file()
    missing = [m for m in _missing_citations(ROOT) if m.split(": ")[1] not in PENDING]
    assert not missing, "cited but not in the repository:\n" + "\n".join(missing)


def test_links_to_headings_resolve():
    broken = _broken_anchors(ROOT)
    assert not broken, "links to headings that do not exist:\n" + "\n".join(broken)


# the speed-weighted pieces of the periodic coefficients (model/periodic.py, PeriodicPieces): summed into
# the coefficients at a speed in one place, PeriodicPieces.at_speed, which PeriodicSystem calls
SPEED_PIECES = {"gyro", "speed_stiffness", "potential", "coupling", "damping_stiffness", "accel_stiffness"}
OMEGA_SUM_HOME = PKG / "model" / "periodic.py"


def _piece_reads(tree: ast.AST) -> list[tuple[int, str]]:
    return [(n.lineno, n.attr) for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr in SPEED_PIECES]


def test_periodic_coefficients_are_summed_in_one_place():
    """No module but model/periodic.py reads a speed-weighted piece of the periodic coefficients:
    every Ω-sum goes through PeriodicPieces.at_speed (issue 34: three copies before)."""
    found = {str(p.relative_to(ROOT)): hits for p in sorted(PKG.rglob("*.py")) if p != OMEGA_SUM_HOME
             for hits in [_piece_reads(ast.parse(p.read_text()))] if hits}
    assert found == {}
    home = ast.parse(OMEGA_SUM_HOME.read_text())
    methods = {f.name for c in ast.walk(home) if isinstance(c, ast.ClassDef) and c.name == "PeriodicPieces"
               for f in c.body if isinstance(f, ast.FunctionDef)
               and any(_piece_reads(b) for b in ast.walk(f) if isinstance(b, ast.BinOp))}
    assert methods == {"at_speed"}  # within its home, one method does arithmetic on them


def test_the_one_sum_check_sees_a_second_sum():
    bad = ast.parse("def coefficients(p, w):\n    return p.stiffness + w * w * p.speed_stiffness\n")
    assert _piece_reads(bad) == [(2, "speed_stiffness")]


PLANE_NAMES = {"in", "out"}


def _plane_compares(source: str) -> list[int]:
    """Lines of ``source`` comparing a value with a plane's name, the literal "in" or "out" alone or
    in a tuple, list or set (``plane == "out"``, ``plane != 'in'``, ``p in ("in", "out")``)."""
    def literals(side):
        items = side.elts if isinstance(side, (ast.Tuple, ast.List, ast.Set)) else [side]
        return {c.value for c in items if isinstance(c, ast.Constant) and isinstance(c.value, str)}

    return sorted({node.lineno for node in ast.walk(ast.parse(source)) if isinstance(node, ast.Compare)
                   and any(literals(side) & PLANE_NAMES for side in [node.left, *node.comparators])})


def test_planes_are_not_compared_by_name():
    """What differs between the two planes is asked of fkev_slepc/model/plane.py's objects, never by
    testing the name: a new branch on "in"/"out" belongs there as an attribute."""
    own = PKG / "model" / "plane.py"
    bad = [f"{p.relative_to(ROOT)}:{line}" for p in sorted(PKG.rglob("*.py")) if p != own
           for line in _plane_compares(p.read_text())]
    assert not bad, bad


def test_the_plane_check_sees_a_comparison():
    source = ('if plane == "out":\n    pass\nx = "in" if a else "out"\nok = a != "inch"\n'
              "y = o['plane'] != 'in'\nz = p in ('in', 'out')\nw = plane == other\n")
    assert _plane_compares(source) == [1, 5, 6]


# the first-order generator of M q̈ + C q̇ + K q: a linkage's is PeriodicSystem.generator_of (periodic/system.py),
# the one Floquet, shooting and the response take; the generic adapters of (M, C, K) -> (q, q') serve only
# systems that are not a PeriodicSystem (closed-form oscillators), in shooting.py and response.py's generic branch
GENERATOR_BUILDERS = {"state_matrix", "second_order", "second_order_forcing", "adapters"}
GENERATOR_HOMES = {("periodic/system.py", "generator_of", "state_matrix"),
                   ("periodic/shooting.py", "adapters", "second_order"),
                   ("periodic/shooting.py", "adapters", "second_order_forcing"),
                   ("periodic/shooting.py", "shooting", "adapters"),
                   ("periodic/response.py", "_shot", "adapters")}


def _generator_calls(tree: ast.AST, where: str) -> set[tuple[str, str, str]]:
    """(module, enclosing function, builder) of every call of a generator builder in ``tree``."""
    out = set()
    for f in ast.walk(tree):
        if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for c in ast.walk(f):
                if isinstance(c, ast.Call):
                    name = getattr(c.func, "id", getattr(c.func, "attr", None))
                    if name in GENERATOR_BUILDERS:
                        out.add((where, f.name, name))
    return out


def test_one_generator_for_every_periodic_analysis():
    """No module builds a first-order generator of the periodic coefficients but PeriodicSystem; the
    (q, q') adapters of (M, C, K) are called only on the generic (non-linkage) paths (issue 34: the
    response's --shooting took its multipliers from a second generator of (Ω²M, ΩC, K))."""
    found = set()
    for p in sorted(PKG.rglob("*.py")):
        if p.name != "magnus.py":  # where the generic builders are defined
            found |= _generator_calls(ast.parse(p.read_text()), str(p.relative_to(PKG)))
    assert found == GENERATOR_HOMES


def test_the_one_generator_check_sees_a_second_generator():
    bad = ast.parse("def shoot(s, w):\n    return magnus.second_order(lambda th: s.mck(th))\n")
    assert _generator_calls(bad, "periodic/other.py") == {("periodic/other.py", "shoot", "second_order")}


def test_one_verdict_rule():
    """SAFETY·error enters a verdict in periodic/verdict.py alone (issue 34: two rules, in bands.py and
    response.py, with two forms of the allowance)."""
    def periodic_safety(tree):  # the module takes the verdict's SAFETY (solve/accuracy.py has its own)
        return any(isinstance(n, ast.ImportFrom) and n.module == "fkev_slepc.periodic.settings"
                   and any(a.name == "SAFETY" for a in n.names) for n in ast.walk(tree))

    trees = {str(p.relative_to(PKG)): ast.parse(p.read_text()) for p in sorted(PKG.rglob("*.py"))}
    uses = {name for name, tree in trees.items() if periodic_safety(tree) or name == "periodic/settings.py"
            for n in ast.walk(tree)
            if isinstance(n, ast.BinOp) and any(getattr(x, "id", None) == "SAFETY" for x in (n.left, n.right))}
    assert uses == {"periodic/verdict.py"}


def _private_imports(source: str) -> list[str]:
    """``module.name`` of every private name (a leading underscore) that ``source`` imports from a
    package module (``from fkev_slepc.periodic.floquet import _name``; dunders such as ``__version__`` are public), at
    module level or inside a function; the
    package's own private modules (``fkev_slepc._version``, ``fkev_slepc._threads``) are whole modules."""
    return [f"{node.module}.{a.name}" for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("fkev_slepc.")
            for a in node.names if a.name.startswith("_") and not a.name.startswith("__")]


def test_no_private_names_are_imported_across_modules():
    """What another module needs is public (issue 34 item 8): a private helper used elsewhere is renamed,
    not imported past its underscore."""
    bad = [f"{p.relative_to(ROOT)}: {name}" for p in sorted(PKG.rglob("*.py")) for name in _private_imports(p.read_text())]
    assert not bad, bad


def test_the_private_import_check_sees_one():
    source = ("from fkev_slepc.periodic.floquet import _unwrapped, public\nimport fkev_slepc._version\n"
              "from fkev_slepc import _threads\ndef f():\n    from fkev_slepc.periodic.magnus import _product\n")
    assert _private_imports(source) == ["fkev_slepc.periodic.floquet._unwrapped", "fkev_slepc.periodic.magnus._product"]
