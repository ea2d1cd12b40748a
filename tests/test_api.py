"""The Python API (fkev_slepc.load/open, Study, PointResult, SweepResults) and its documentation:
the docstring examples of the package and the README's "Python API" example are executed here."""

from __future__ import annotations

import doctest
import importlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import fkev_slepc as fk
from numtext import same_text
from fkev_slepc.cli import main
from fkev_slepc.archive.reader import ArchiveError
from fkev_slepc.scene import SceneError
from fkev_slepc.status import STATUS_CODES, Status

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "runs"
BW = RUNS / "bahgat-willmert-1976.toml"
PKG = ROOT / "fkev_slepc"
DOCTEST_MODULES = sorted(
    ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
    for p in PKG.rglob("*.py") if ">>>" in p.read_text()
)


# ----------------------------------------------------------------------------- doctests
class NumericChecker(doctest.OutputChecker):
    """Doctest output with the same text and numbers to their printed digits (tests/numtext.py):
    integers exactly, a decimal number within one unit of its last digit (a rounded value at a
    tie) plus 1e-9 of its value (a full-precision repr of a solver result, e.g. ``to_csv``'s
    228.6885738113997, whose last bits move with the CPU; the solvers' pair-error acceptance is
    1e-8, so a wrong eigenvalue is far outside). The exact check is tried first."""

    def check_output(self, want, got, optionflags):
        return super().check_output(want, got, optionflags) or same_text(want, got, units=1, rtol=1e-9)


def test_numeric_checker_catches_a_wrong_number():
    c, flags = NumericChecker(), doctest.NORMALIZE_WHITESPACE
    assert c.check_output("0.0,0.0,structure,1,228.6885738113997,0.0,ok\n", "0.0,0.0,structure,1,228.68857381140312,0.0,ok\n", flags)
    assert not c.check_output("0.0,0.0,structure,1,228.6885738113997,0.0,ok\n", "0.0,0.0,structure,1,228.6886,0.0,ok\n", flags)
    assert c.check_output("array([ 362.71,  652.08])\n", "array([362.72, 652.08])\n", flags)
    assert not c.check_output("array([ 362.71,  652.08])\n", "array([362.73, 652.08])\n", flags)
    assert not c.check_output("('thesis', 7, (7, 7, 7), True)\n", "('thesis', 8, (7, 7, 7), True)\n", flags)
    assert not c.check_output("(66.6916, 10.0)\n", "(66.6916, 10.0, 1)\n", flags)


@pytest.mark.parametrize("name", DOCTEST_MODULES)
def test_docstring_examples(name):
    """numpydoc Examples run as doctests (``RUNS`` is the repository's runs/ folder), numbers
    compared to their printed digits (:class:`NumericChecker`)."""
    mod = importlib.import_module(name)
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(checker=NumericChecker(), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for t in finder.find(mod, name, globs={**vars(mod), "RUNS": RUNS}):
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed"
    if result.attempted == 0:
        pytest.skip("every example of this module is marked +SKIP (needs a large model)")


def test_doctests_are_collected():
    assert {"fkev_slepc.api.study", "fkev_slepc.api.results", "fkev_slepc.status", "fkev_slepc.sweep.grid"} <= set(DOCTEST_MODULES)


def readme_api_example() -> str:
    text = (ROOT / "README.md").read_text()
    section = re.search(r"^## Python API\n(.*?)(?=^## )", text, re.S | re.M)
    assert section, "README.md has no '## Python API' section"
    blocks = re.findall(r"```python\n(.*?)```", section.group(1), re.S)
    assert blocks, "README's Python API section has no ```python block"
    return "\n".join(blocks)


def test_readme_python_api_example_runs(tmp_path, monkeypatch):
    """The README example as a user runs it from the repository root (here: its scene paths made
    absolute, its outputs written in a temporary directory)."""
    code = readme_api_example().replace('"runs/', f'"{RUNS}/')
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    res = namespace["res"]
    assert (tmp_path / "out" / "bw.h5").exists() and (tmp_path / "bw-freq.png").stat().st_size > 0
    assert res.status.shape == (36, 2, 2) and np.all(res.converged)
    # 10° is on the swept grid: the sweep's point equals the single point solved above
    np.testing.assert_allclose(res.frequency("full", 1000)[1], namespace["r"].frequency_hz, rtol=1e-12)


# ----------------------------------------------------------------------------- Status
def test_status_is_a_string_with_fixed_archive_codes():
    assert Status.UNSTABLE == "unstable" and f"{Status.NOT_CONVERGED}" == "not_converged"
    assert {s.value: s.code for s in Status} == {"pending": 0, "ok": 1, "not_converged": 2, "unstable": 3,
                                                  "divergent": 4, "failed": 5}
    assert all(Status.from_code(c) is s for s, c in STATUS_CODES.items())
    assert json.dumps({"s": Status.OK}) == '{"s": "ok"}'


# ------------------------------------------------------------------------------- point
def test_point_matches_fkev_point_and_the_thesis_values(capsys):
    r = fk.load(BW).point(10, 1000, "full")
    assert main(["point", str(BW), "--angle", "10", "--speed", "1000", "--case", "full", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert cli["frequency_hz"] == r.frequency_hz.tolist() and cli["status"] == r.status == "unstable"
    np.testing.assert_allclose(r.frequency_hz, [362.71, 652.08, 1078.94, 2898.89], atol=0.01)  # runs/README.md
    lam = r.eigenvalues
    np.testing.assert_allclose(r.damping_ratio, -lam.real / np.abs(lam), rtol=1e-15)
    assert r.max_real == pytest.approx(lam.real.max()) and np.all(r.pair_error < 1e-10)
    assert "unstable" in repr(r) and "362.708" in repr(r) and len(repr(r)) < 200


def test_point_bad_arguments_are_named():
    s = fk.load(BW)
    with pytest.raises(SceneError, match="modes: must be >= 1 .got 0."):
        s.point(10, 0, modes=0)
    with pytest.raises(SceneError, match="case: unknown case 'nope'"):
        s.point(10, 0, "nope")
    with pytest.raises(SceneError, match="speed_rad_s: must be finite"):
        s.point(10, float("nan"))


def test_mode_shape_is_the_eigenvector_at_the_nodes():
    """Node displacements satisfy the QEP: the free-DOF vector gathered back from the nodes is
    an eigenvector with a pair error at round-off (docs/theory.md §10)."""
    from fkev_slepc.model.operators import Model
    from fkev_slepc.solve.acceptance import pair_error

    study = fk.load(BW)
    r = study.point(30, 500, "full", shapes=True, solver="dense")
    model = Model(study.scene, cases=("full",))
    qep = model.qep(model.pieces(np.radians(30)), 500.0, "full")
    dofs = model.mechanism.node_dofs
    for k in (1, 2, 3, 4):
        m = r.mode_shape(k)
        assert m.frequency_hz == r.frequency_hz[k - 1] and m.node_xy.shape == (dofs.shape[0], 2)
        q = np.zeros(model.n_free, complex)
        q[dofs[dofs >= 0]] = m.displacement[dofs >= 0]
        assert np.all(m.displacement[dofs < 0] == 0) and np.abs(m.displacement).max() == pytest.approx(1.0)
        assert pair_error(qep, np.array([m.eigenvalue]), q[:, None])[0] < 1e-10
    np.testing.assert_allclose(m.node_xy, model.node_positions(np.radians(30)))
    fig = r.plot()
    assert len(fig.axes) == 4 and "θ = 30°" in fig._suptitle.get_text()
    with pytest.raises(ValueError, match="shapes=True"):
        study.point(30, 500).mode_shape(1)


# ------------------------------------------------------------------------------- sweep
GRID = dict(angles="0:90:30", speeds="0,1000", cases="full,structure,no_coriolis")
# times, command lines, and the digest of the root attributes (which include them)
VARYING_ATTRS = {"created", "wall_time_s", "command_line", "last_command_line", "attrs_sha256"}


def archive_contents(path) -> tuple[dict, dict]:
    """Every dataset (by path) and every attribute (root, groups, datasets) of an archive."""
    data, attrs = {}, {}

    def plain(v, f):  # HDF5 object references (dimension scales) -> the referenced object's name
        if isinstance(v, h5py.Reference):
            return f[v].name
        if isinstance(v, (np.ndarray, np.void, tuple, list)) and np.asarray(v, dtype=object).dtype == object:
            return repr([plain(x, f) for x in (v.tolist() if isinstance(v, np.ndarray) else list(v))])
        return v

    with h5py.File(path, "r") as f:
        def visit(name, obj):
            attrs.update({f"{name}@{k}": plain(v, f) for k, v in obj.attrs.items()})
            if isinstance(obj, h5py.Dataset):
                data[name] = obj[()]

        attrs.update({f"@{k}": v for k, v in f.attrs.items() if k not in VARYING_ATTRS})
        f.visititems(visit)
    return data, attrs


def assert_same_archive(a, b) -> None:
    (da, aa), (db, ab) = archive_contents(a), archive_contents(b)
    assert sorted(da) == sorted(db) and sorted(aa) == sorted(ab)
    for k in da:
        x, y = np.asarray(da[k]), np.asarray(db[k])
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind in "fc"), k
    for k in aa:
        assert np.array_equal(np.asarray(aa[k]), np.asarray(ab[k])), k


def test_study_sweep_writes_the_archive_fkev_run_writes(tmp_path, capsys):
    """In-process, one rank: Study.sweep and `fkev run` (same grid) give identical archives."""
    cli, api = tmp_path / "cli.h5", tmp_path / "api.h5"
    assert main(["run", str(BW), "-o", str(cli), "--quiet", "--angles", GRID["angles"], "--speeds", GRID["speeds"],
                 "--cases", GRID["cases"]]) == 0
    res = fk.load(BW).sweep(GRID["angles"], [0, 1000], GRID["cases"].split(","), output=api)
    assert isinstance(res, fk.SweepResults) and res.path == api
    assert_same_archive(cli, api)
    f = res.frequency("full", 1000)
    assert f.shape == (4, 4) and np.all(np.isfinite(f)) and res.errors() == []
    s = res.settings()
    assert s["solver"]["engine"] == "dense" and s["elements"] == (1, 2, 2) and s["n_ranks"] == 1
    ds = res.to_xarray()
    assert set(ds.status.values.ravel()) <= {"ok", "unstable", "divergent"}
    np.testing.assert_array_equal(ds.frequency_hz.sel(case="full", speed_rad_s=1000).values, f)


def test_study_sweep_rel_error_and_element_write_what_fkev_run_writes(tmp_path):
    """Study.sweep(rel_error=, element=) and `fkev run --rel-error/--element`: the same plan, mesh and
    archive (the plan archived as `accuracy`); bad values name the argument, before anything is written."""
    import json

    grid = ["--angles", "0,90", "--speeds", "0,1000", "--cases", "structure,full"]
    cli, api = tmp_path / "cli.h5", tmp_path / "api.h5"
    assert main(["run", str(BW), "-o", str(cli), "--quiet", *grid, "--rel-error", "1e-3"]) == 0
    res = fk.load(BW).sweep("0,90", [0, 1000], ["structure", "full"], output=api, rel_error=1e-3)
    assert_same_archive(cli, api)
    plan = json.loads(res.attrs["accuracy"])
    assert plan["rel_error"] == 1e-3 and plan["predicted_rel_error"] <= 1e-3
    assert res.settings()["elements"] == (plan["elements_per_link"],) * 3 != (1, 2, 2)  # re-meshed
    assert res.attrs["element"] == plan["element"]
    # --element alone: the scene's mesh with the cubic element (5 free DOFs per element instead of 3)
    cli, api = tmp_path / "cli-cubic.h5", tmp_path / "api-cubic.h5"
    assert main(["run", str(BW), "-o", str(cli), "--quiet", *grid, "--element", "cubic"]) == 0
    res = fk.load(BW).sweep("0,90", [0, 1000], ["structure", "full"], output=api, element="cubic")
    assert_same_archive(cli, api)
    assert res.attrs["element"] == "cubic" and "accuracy" not in res.attrs
    assert res.settings()["n_free"] == 15 + 2 * 5  # the thesis mesh's 15 DOFs plus 2 axial bubbles per element
    bad = tmp_path / "bad.h5"
    with pytest.raises(SceneError, match=r"rel_error: must be a number in \(0, 1\) \(got 2\)") as err:
        fk.load(BW).sweep([0], [0], ["full"], output=bad, rel_error=2, element="quad")
    assert "element: must be one of thesis, cubic, timoshenko (got 'quad')" in str(err.value) and not bad.exists()


def test_sweep_refusals_are_exceptions(tmp_path):
    study = fk.load(BW)
    out = tmp_path / "a.h5"
    study.sweep([0, 10], [0], ["structure"], output=out)
    from fkev_slepc.sweep.session import RunRefused

    with pytest.raises(RunRefused, match="archive has 0,10, this run 0,10,20") as err:
        study.sweep([0, 10, 20], [0], ["structure"], output=out, resume=True)
    assert err.value.exit_code == 2
    with pytest.raises(SceneError, match="angles_deg: a value is listed twice"):
        study.sweep([0, 0], output=out)
    with pytest.raises(SceneError, match="output: required"):
        fk.Study.from_text(BW.read_text()).sweep([0])
    before = out.read_bytes()
    with pytest.raises(RunRefused, match="a.h5") as err:  # a finished archive is never replaced silently
        study.sweep([0], [0], ["structure"], output=out)
    assert err.value.exit_code == 2 and out.read_bytes() == before
    replaced = study.sweep([0], [0], ["structure"], output=out, force=True)
    assert replaced.crank_angle_deg.tolist() == [0.0]
    (tmp_path / "file").write_text("")
    with pytest.raises(RunRefused, match="file/a.h5: .*file is not a directory"):  # an OSError, refused on every rank
        study.sweep([0], [0], ["structure"], output=tmp_path / "file" / "a.h5")


@pytest.mark.mpi
def test_two_rank_study_sweep_equals_fkev_run(tmp_path):
    """`mpirun -n 2 python -c "...Study.sweep(..., comm=MPI.COMM_WORLD)"` and `mpirun -n 2 fkev run`
    write identical archives (datasets equal; attributes equal but times and command lines)."""
    import os
    import shutil
    import subprocess
    import sys

    if shutil.which("mpiexec") is None:  # pragma: no cover - part of the stack
        pytest.skip("mpiexec not found")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
    cli, api = tmp_path / "cli.h5", tmp_path / "api.h5"
    mpi = ["mpiexec", "-n", "2", sys.executable]
    r = subprocess.run([*mpi, "-m", "fkev_slepc", "run", str(BW), "-o", str(cli), "--quiet",
                        "--angles", GRID["angles"], "--speeds", GRID["speeds"], "--cases", GRID["cases"]],
                       env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    code = ("from mpi4py import MPI; import fkev_slepc as fk; "
            f"res = fk.load({str(BW)!r}).sweep({GRID['angles']!r}, [0, 1000], {GRID['cases'].split(',')!r}, "
            f"output={str(api)!r}, comm=MPI.COMM_WORLD); "
            f"open({str(tmp_path)!r} + f'/rank{{MPI.COMM_WORLD.rank}}', 'w').write("
            "f'{res.status.shape} {int(res.converged.sum())}')")
    r = subprocess.run([*mpi, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    for rank in (0, 1):  # every rank gets the results
        assert (tmp_path / f"rank{rank}").read_text() == "(4, 2, 3) 24"
    assert_same_archive(cli, api)


def test_slider_node_moves_along_its_inclined_guide():
    """On a prismatic joint the slider node's one translational DOF runs along the guide: its
    (x, y) displacement in mode_shape is parallel to the guide (here inclined at 30°)."""
    text = (RUNS / "slider-crank.toml").read_text().replace("guide_angle_deg = 0.0", "guide_angle_deg = 30.0")
    study = fk.Study.from_text(text)
    r = study.point(40, 0, "structure", shapes=True, solver="dense")
    dofs = r.mode_shape(1).displacement, r.mesh.node_dofs
    slider = np.flatnonzero((dofs[1][:, 0] >= 0) & (dofs[1][:, 1] < 0))
    assert slider.size == 1
    t = np.array([np.cos(np.radians(30)), np.sin(np.radians(30))])
    moved = 0.0
    for k in range(1, len(r.frequency_hz) + 1):
        d = r.mode_shape(k).displacement[slider[0], :2]
        assert abs(t[0] * d[1] - t[1] * d[0]) <= 1e-12 * max(abs(d).max(), 1e-300)
        moved = max(moved, abs(d).max())
    assert moved > 1e-3  # some mode moves the slider


def test_point_result_is_plain_data_that_pickles():
    """Issue 17 item 4: a PointResult holds arrays, numbers and the frozen scene, no live Model or
    solver: it pickles, and the copy answers as the original (mode shapes on the exact node axes)."""
    import pickle

    r = fk.load(RUNS / "slider-crank.toml").point(40, 100, "full", shapes=True, solver="dense")
    assert not any(name.startswith("_") for name in vars(r))
    back = pickle.loads(pickle.dumps(r))
    np.testing.assert_array_equal(back.frequency_hz, r.frequency_hz)
    np.testing.assert_array_equal(back.mode_shape(2).displacement, r.mode_shape(2).displacement)
    assert back.as_dict() == r.as_dict() and repr(back) == repr(r)
    np.testing.assert_array_equal(back.mesh.node_axis, r.mesh.node_axis)


def test_study_reuses_models_by_terms_and_one_engine_per_model():
    """Issue 17 item 4: models are kept by the motion terms they assemble (a no_coriolis point
    reuses the full model; the same frequencies as a model of its own, to 1e-12), and one engine
    serves every call on a model."""
    from fkev_slepc.model.operators import Model

    study = fk.load(BW)
    full = study.point(10, 500, "full")
    models = dict(study.pool._models)
    part = study.point(10, 500, "no_coriolis")
    assert study.pool._models == models and len(study.pool._engines) == 1  # nothing new built
    alone = fk.Study(study.scene).pool  # a fresh study: a model built for no_coriolis alone
    assert alone.model("no_coriolis").terms != study.pool.model("no_coriolis").terms
    own = fk.Study(study.scene).point(10, 500, "no_coriolis")
    np.testing.assert_allclose(part.frequency_hz, own.frequency_hz, rtol=1e-12)
    assert full.frequency_hz[0] != part.frequency_hz[0]
    assert isinstance(study.pool.model("structure"), Model)
    study.close()


def test_study_sweeps_take_their_model_from_the_pool(tmp_path):
    """Issue 27 (design review): Study.sweep, the base sweep of Study.design (and the frozen sweep, work
    check and frozen-time scan of Study.floquet) take their model from the study's pool, whose models
    serve every grid of the scene (``ModelPool.for_scene``): two sweeps and a design study build one
    model, and a no_coriolis sweep on the pool's full model gives the frequencies of a model of
    no_coriolis alone (``run_sweep``, fkev run's) to 1e-12."""
    from fkev_slepc.scene import with_elements
    from fkev_slepc.sweep.grid import configure
    from fkev_slepc.sweep.session import SweepRequest, run_sweep

    study = fk.load(BW, elements=1)
    study.sweep([0, 90], [0, 300], ["full"], tmp_path / "a.h5", modes=2)
    res = study.sweep([45, 135], [200, 400], ["no_coriolis"], tmp_path / "b.h5", modes=2)
    assert len(study.pool) == 1  # the full model served the second sweep too
    scene = configure(study.scene, angles=[45, 135], speeds=[200, 400], cases=["no_coriolis"], modes=2)
    own = fk.open(run_sweep(SweepRequest(scene, tmp_path / "c.h5")).output)
    np.testing.assert_allclose(res.frequency("no_coriolis"), own.frequency("no_coriolis"), rtol=1e-12)
    assert study.pool.for_scene(scene).model("full") is study.pool.model("full") and len(study.pool) == 1
    assert len(study.pool.for_scene(with_elements(scene, 2))) == 0  # another mesh: a pool of its own
    ds = study.design({"links[coupler].length_m": "0.2794,0.28"}, [150], ["full"], [0], tmp_path / "d.h5")
    assert len(study.pool) == 1 and ds.sizes["links[coupler].length_m"] == 2  # its base sweep: the same model
    study.close()


def test_study_running_speed_methods_take_their_model_from_the_pool(tmp_path, monkeypatch):
    """Issue 27 (design review): Study.response, response_vs_speed (archived or not), design_check (in
    plane and out of plane), the sensitivity of a point the study solved and the out-of-plane half of a
    two-plane sweep take their models from the study's pool, and loads needs none: called in turn they build one model of the study's scene per
    plane (every Model construction counted; before, every call built its own). The answers are those of
    models of their own: a no_coriolis response on the pool's full model, the design check and the
    sensitivity (an unpickled copy builds its own model) agree with fresh ones to 1e-12."""
    import pickle

    from fkev_slepc.api.pool import model_facts
    from fkev_slepc.api.response import study_response
    from fkev_slepc.design.check import design_check
    from fkev_slepc.model.operators import Model

    study = fk.load(RUNS / "flat-rod-slider-crank.toml", elements=1).replace("analysis.crank_angles_deg", [0.0, 90.0])
    facts, built, real = model_facts(study.scene), [], Model.__init__

    def counted(self, scene, *args, **kwargs):
        real(self, scene, *args, **kwargs)
        if model_facts(scene) == facts:  # the scenes moved by a sensitivity's key are other scenes
            built.append(self.plane)

    monkeypatch.setattr(Model, "__init__", counted)
    w, angles = 2000 * np.pi / 30, [0.0, 90.0]
    study.response(w, "full", angles, harmonics=2)
    nc = study.response(w, "no_coriolis", angles, harmonics=2)
    loads = study.loads(w, angles)
    check = study.design_check(w, angles_deg=angles, harmonics=2)
    r = study.point(30, w, "full")
    s = r.sensitivity("links[rod].length_m")
    study.response_vs_speed([w], "full", angles_deg=angles, harmonics=2)
    study.response_vs_speed([w], "full", tmp_path / "r.h5", angles_deg=angles, harmonics=2, modes=2)
    both = study.sweep(angles, [w], ["full"], tmp_path / "s.h5", modes=2)  # plane both: in, then /planes/out
    assert sorted(built) == ["in", "out"] and len(study.pool) == 2  # one model per plane, all from the pool
    assert both.planes == ("in", "out")
    assert loads.power_residual < 1e-12 and check.out_of_plane is not None
    del built[:]
    own = study_response(study.scene, w, "no_coriolis", angles, harmonics=2)
    np.testing.assert_allclose(nc.q, own.q, rtol=1e-12, atol=1e-12 * np.abs(own.q).max())
    fresh = design_check(study.scene, w, angles_deg=angles, harmonics=2).as_dict()
    np.testing.assert_allclose(check.out_of_plane.f1_hz, fresh["out_of_plane"]["f1_hz"], rtol=1e-12)
    assert [lk["peak_stress_pa"] for lk in check.as_dict()["links"].values()] == pytest.approx(
        [lk["peak_stress_pa"] for lk in fresh["links"].values()], rel=1e-12)
    copy = pickle.loads(pickle.dumps(r))
    assert copy.pool_ref is None and r.pool_ref() is study.pool
    np.testing.assert_allclose(copy.sensitivity("links[rod].length_m").eigenvalue, s.eigenvalue, rtol=1e-12)
    assert built.count("in") == 3 and built.count("out") == 1  # each fresh call: models of its own
    study.close()


def test_sweep_results_to_csv_is_the_export_table(tmp_path):
    res = fk.load(BW).sweep([0, 90], [0], ["structure"], tmp_path / "a.h5", modes=2)
    text = res.to_csv()
    r = subprocess.run([sys.executable, "-m", "fkev_slepc", "export", str(tmp_path / "a.h5")], capture_output=True,
                       text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}, check=True)
    assert text == r.stdout and text.count("\n") == 1 + 2 * 2
    res.to_csv(tmp_path / "a.csv")
    assert (tmp_path / "a.csv").read_text() == text


def test_api_errors_name_api_arguments_not_flags(tmp_path):
    """Issue 20: the library spoke CLI (`--angle`, `--elements`); the flags are the CLI's alone."""
    res = fk.load(BW).sweep([0, 90], [0, 100], ["structure"], tmp_path / "a.h5", modes=2)
    with pytest.raises(ArchiveError, match="^angle: 20 deg is not on") as e1:
        res.angle_index(20.0)
    with pytest.raises(ArchiveError, match="^angles: this kind takes one value") as e2:
        res.plot("campbell", angles=[0, 90])
    with pytest.raises(SceneError, match="elements: needs 1 or 3 values") as e3:
        fk.load(BW, elements=(1, 2))
    for e in (e1, e2, e3):
        assert "--" not in str(e.value)
    with pytest.warns(UserWarning, match="from 2 crank speed"):
        assert res.plot("campbell", angles=90, orders=1) is not None  # one angle: drawn
