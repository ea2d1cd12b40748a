"""The archive's products are declared once (fkev_slepc/archive/products.py).

- no dataset name is spelled outside the product tables (the layout rule);
- docs/archive.md's dataset tables are the generated ones, and the tables describe a real
  archive written by ``fkev run`` dataset by dataset (dimensions, dtype, units, long name);
- a new product is one more table: a toy product with (speed, case) units is created in an
  archive, solved unit by unit through the sweep's distributed loop, resumed and finalised.
"""

from __future__ import annotations

import ast
from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from clitools import BW, fkev
from fkev_slepc.archive import products as P
from fkev_slepc.archive import store
from fkev_slepc.archive.groups import h5_dtype
from fkev_slepc.archive.products_doc import generated
from fkev_slepc.archive.writer import Block, Writer
from fkev_slepc.status import RETRYABLE, Status
from fkev_slepc.sweep.units import assign, pending, run_units

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "fkev_slepc"
TABLES = {PKG / "archive" / name for name in ("products.py", "product_types.py", "products_floquet.py",
                                                  "products_response.py", "products_planes.py")}
# where datasets are read and written (the archive stage, the sweep and plots modules that use
# the archive, the commands that read archives, any module importing h5py): every root dataset
# or group name used as a key there must come from the tables. Elsewhere "case" or "modes" are
# ordinary words (the JSON of `fkev point`, argument names).
ARCHIVE_COMMANDS = ("info.py", "export.py", "verify.py", "plot.py")


def _touches_archive(path: Path) -> bool:
    rel, text = path.relative_to(PKG).parts, path.read_text()
    return (rel[0] == "archive" or (rel[0] == "cli" and rel[-1] in ARCHIVE_COMMANDS)
            or (rel[0] in ("sweep", "plots") and "fkev_slepc.archive" in text) or "import h5py" in text)


def _docstrings(tree) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and body and \
                isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            out.add(id(body[0].value))
    return out


def _keys(tree) -> set[int]:
    """String constants used as a subscript, a membership test or a dict-literal key."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
            out.add(id(node.slice))
        elif isinstance(node, ast.Compare) and isinstance(node.left, ast.Constant) and \
                any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops):
            out.add(id(node.left))
        elif isinstance(node, ast.Dict):
            out.update(id(k) for k in node.keys if isinstance(k, ast.Constant))
    return out


def spelled_dataset_names(files, archive_files) -> list[str]:
    """``file:line: 'name'`` for every dataset path of the tables spelled in ``files`` (a path with
    a group, or a group with a leading slash), and every root dataset or group name used as a key
    in ``archive_files``. Docstrings do not count."""
    paths = {v.path for v in P.datasets()}
    groups = {v.group for v in P.datasets() if v.group} | {g for p in P.PRODUCTS for g in p.groups}
    anywhere = {p for p in paths if "/" in p} | {"/" + p for p in paths} | {"/" + g for g in groups}
    as_key = {p for p in paths if "/" not in p} | groups
    bad = []
    for f in files:
        tree = ast.parse(f.read_text())
        docs, keys = _docstrings(tree), _keys(tree)
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Constant) and isinstance(node.value, str)) or id(node) in docs:
                continue
            if node.value in anywhere or (f in archive_files and id(node) in keys and node.value in as_key):
                bad.append(f"{f.relative_to(f.parents[2]) if len(f.parents) > 2 else f}:{node.lineno}: {node.value!r}")
    return bad


def test_the_layout_rule_finds_a_spelled_name(tmp_path):
    (tmp_path / "a" / "b").mkdir(parents=True)
    f = tmp_path / "a" / "b" / ("m" + ".py")
    f.write_text('"""Reads ``/tracking/signature``."""\nx = f["tracking/' + 'signature"]\ny = d["frequency' + '_hz"]\n'
                 'z = ("case", "status")\n')
    assert [b.split(": ")[1] for b in spelled_dataset_names([f], {f})] == ["'tracking/signature'", "'frequency_hz'"]
    assert [b.split(": ")[1] for b in spelled_dataset_names([f], set())] == ["'tracking/signature'"]


def test_no_dataset_name_is_spelled_outside_the_product_tables():
    files = sorted(p for p in PKG.rglob("*.py") if p not in TABLES)
    archive = {p for p in files if _touches_archive(p)}
    bad = spelled_dataset_names(files, archive)
    assert not bad, "dataset names spelled outside fkev_slepc/archive/products.py:\n" + "\n".join(bad)


def test_docs_archive_md_is_generated_from_the_tables():
    text = (ROOT / "docs" / "archive.md").read_text()
    assert generated() in text, "docs/archive.md is out of date: run python scripts/archive_doc.py"


@pytest.fixture(scope="module")
def real_archive(tmp_path_factory):
    """A real sweep with every optional group: mode shapes, tracking refined at a 30° grid."""
    out = tmp_path_factory.mktemp("layout") / "bw.h5"
    r = fkev("run", BW, "--angles", "0:360:30", "--speeds", "1000", "--cases", "full", "--modes", "3",
             "--mode-shapes", "--solver", "dense", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    return out


def test_the_tables_describe_a_real_archive(real_archive):
    found = {}
    with h5py.File(real_archive, "r") as f:
        f.visititems(lambda name, obj: found.update({name: obj}) if isinstance(obj, h5py.Dataset) else None)
        assert P.R_ANGLE in found, "the 30° grid must refine (tracking/refined present)"
        undeclared = sorted(set(found) - {v.path for v in P.datasets()})
        assert not undeclared, f"datasets of a real archive missing from the tables: {undeclared}"
        for name, ds in found.items():
            v = P.find(name)
            assert ds.attrs["units"] == v.units and ds.attrs["long_name"] == v.long_name, name
            want = np.dtype(h5_dtype(v))
            assert ds.dtype == want or (want.kind == "O" and ds.dtype.kind == "O"), (name, ds.dtype, want)
            if v.scale:
                assert ds.attrs["NAME"].decode() == v.name and ds.attrs["CLASS"] == b"DIMENSION_SCALE", name
            else:
                got = tuple(ds.dims[i][0].name.lstrip("/") for i in range(ds.ndim))
                assert got == v.dims, (name, got)
        assert P.NODE_AXIS.path in found and f.attrs["speed_unit"] == "rad/s"
        for a in ("title", "element", "damping_alpha", "damping_beta"):
            assert a in f.attrs, a
        declared = {a.name for a in P.ROOT_ATTRS}
        assert set(f.attrs) <= declared, sorted(set(f.attrs) - declared)
    text = (ROOT / "docs" / "archive.md").read_text()
    for name in found:
        assert f"`/{name}`" in text, name


# ------------------------------------------------------------------- a product of its own
DEMO_VALUE = "demo/value"
DEMO = P.Product(
    name="demo", unit_dims=(P.SPEED, P.CASE), point_dims=(), status="demo/status",
    variables=(P.Var(DEMO_VALUE, (P.SPEED, P.CASE, P.MODE), "f8", "1", "a value per mode", np.nan, source="value"),
               P.Var("demo/status", (P.SPEED, P.CASE), P.STATUS, "1", "outcome of the unit", 0, source="status"))
    + P.error_table("demo/errors", ("speed", "case")).rows,
    errors=P.error_table("demo/errors", ("speed", "case")),
    groups={"demo": "a product with (speed, case) units, as Floquet analyses have"},
)


def test_assign_over_two_unit_axes():
    todo = np.ones((3, 4), bool)
    todo[1, 2] = False
    parts = [assign(todo, r, 2, n_unit_axes=2) for r in range(2)]
    assert {n for _, n in parts} == {6}
    assert sorted(np.concatenate([p for p, _ in parts]).tolist()) == [0, 1, 2, 3, 4, 5, 7, 8, 9, 10, 11]


def test_a_new_product_is_one_table_solved_unit_by_unit_and_resumed(tmp_path, monkeypatch):
    monkeypatch.setattr(P, "PRODUCTS", P.PRODUCTS + (DEMO,))  # registered, as a real product would be
    grid = P.Grid(np.array([0.0, 10.0]), np.array([0.0, 100.0, 200.0]), ("structure", "full"), 2)
    part = store.partial_path(tmp_path / "d.h5")
    store.create(part, grid, {"scene_toml": "x"})
    store.add_product(part, DEMO, {})
    with h5py.File(part, "r") as f:  # the root scales are shared, not copied
        assert f[DEMO_VALUE].shape == (3, 2, 2) and f[DEMO_VALUE].dims[0][0].name == "/" + P.SPEED
        assert np.all(f["demo/status"][()] == 0)

    def solve(unit, mask):
        js, jc = unit
        bad = (js, jc) == (2, 1)
        status = np.array(Status.FAILED.code if bad else Status.OK.code, np.uint8)
        errors = [((js, jc), Status.FAILED.code, "injected")] if bad else []
        return Block(unit, mask, {DEMO_VALUE: np.array([js + 0.1 * jc, -1.0])}, status, errors)

    todo = pending(store.read_status(part, DEMO))
    todo[0, 0] = False  # as if done before
    w = Writer(part, MPI.COMM_SELF, parallel=False, product=DEMO)
    assert run_units(todo, solve, w, MPI.COMM_SELF, n_unit_axes=2) == 5
    w.close()
    status = store.read_status(part, DEMO)
    assert status[0, 0] == Status.PENDING.code and status[2, 1] == Status.FAILED.code
    with h5py.File(part, "r") as f:
        assert f[DEMO_VALUE][1, 1].tolist() == [1.1, -1.0] and np.all(np.isnan(f[DEMO_VALUE][0, 0]))
        assert f["demo/errors/index"][()].tolist() == [[2, 1]]
    again = pending(status, RETRYABLE)
    assert np.argwhere(again).tolist() == [[0, 0], [2, 1]]
    out = store.finalize(part, tmp_path / "d.h5", {})
    from fkev_slepc.archive.verify import verify

    assert verify(out, isolate=False).ok  # in this process: the child would not see the registration
    monkeypatch.setattr(P, "PRODUCTS", P.PRODUCTS[:-1])
    assert any("/demo/value is not one of the format's" in p for p in verify(out, isolate=False).problems)


# ------------------------------------------------------------- facts the figures read, archived
def test_figures_read_the_archived_node_axes_units_and_damping(tmp_path):
    """The slider's guide and DOF direction come from /mesh/node_axis (Mechanism.node_axis), not
    from the scene text; rpm display from speed_unit; the damping label from damping_alpha/beta."""
    from dataclasses import replace

    from matplotlib.patches import Rectangle

    from fkev_slepc.archive.reader import load
    from fkev_slepc.model.mechanism import build_mechanism
    from fkev_slepc.plots import maps, shapes
    from fkev_slepc.scene import load_scene

    scene = ROOT / "runs" / "slider-crank.toml"
    out = tmp_path / "sc.h5"
    r = fkev("run", scene, "--angles", "0,30", "--speeds", "0,100", "--cases", "structure,full", "--modes", "2",
             "--mode-shapes", "--solver", "dense", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    res = load(out)
    mech = build_mechanism(load_scene(scene))
    assert np.array_equal(res.mesh.node_axis, mech.node_axis)
    slider = np.flatnonzero((res.mesh.node_dofs[:, 0] >= 0) & (res.mesh.node_dofs[:, 1] < 0))
    assert slider.size == 1 and np.linalg.norm(res.mesh.node_axis[slider[0]]) == pytest.approx(1.0)
    blind = replace(res, scene_toml="")  # nothing to guess from: the archive alone draws the guide
    fig = shapes.mode_shape(blind, angle=30, speed=100)
    blocks = [p for p in fig.axes[0].patches if isinstance(p, Rectangle) and p.get_label() == "_slider"]
    axis = res.mesh.node_axis[slider[0]]
    assert len(blocks) == 1 and blocks[0].angle == pytest.approx(np.degrees(np.arctan2(axis[1], axis[0])))
    assert res.speeds_in_rpm == (res.attrs["speed_unit"] == "rpm")  # the scene gives speeds_rpm
    for unit in ("rpm", "rad/s"):  # the attribute decides, not the scene text or the command line
        assert replace(res, attrs=dict(res.attrs, speed_unit=unit)).speeds_in_rpm == (unit == "rpm")
    assert maps._damping_label(res) == ""
    damped = replace(res, scene_toml="", attrs=dict(res.attrs, damping_alpha=40.0, damping_beta=1e-6))
    assert maps._damping_label(damped) == ", Rayleigh damping α = 40 1/s, β = 1e-06 s"
    assert res.title == str(res.attrs["title"])


def test_the_speed_unit_archived_is_how_the_speeds_were_given():
    from fkev_slepc.scene import load_scene
    from fkev_slepc.sweep.grid import configure
    from fkev_slepc.sweep.session import display_facts

    bw, sc = load_scene(BW), load_scene(ROOT / "runs" / "slider-crank.toml")  # rad/s, rpm scenes
    assert display_facts(bw)["speed_unit"] == "rad/s" and display_facts(sc)["speed_unit"] == "rpm"
    assert display_facts(configure(bw, speeds_rpm="0,3000"))["speed_unit"] == "rpm"  # --speeds-rpm
    assert display_facts(configure(sc, speeds="0,100"))["speed_unit"] == "rad/s"  # --speeds overrides
