"""Global flags, usage, --version, --modes, rpm and --resume's scene comparison (issue 12, Deliver 3).

Every refusal: exit 2, the one line that names the flag or field, and an existing archive left
bit-identical.
"""

import json
import math

import h5py
import numpy as np
import pytest

from clitools import BW, ROOT, SMALL, digest, fkev, problem_lines, small_archive

TM = ROOT / "runs/turcic-midha-1984.toml"  # 27 free DOFs


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    d = tmp_path_factory.mktemp("flags")
    scene = d / "bw.toml"
    scene.write_text(BW.read_text())
    return small_archive(d / "bw.h5", scene), scene


@pytest.mark.parametrize("argv", [["-vv", "check", TM], ["check", TM, "-v"], ["-q", "check", TM], ["check", "-q", TM]])
def test_global_flags_before_or_after_the_subcommand(argv):
    r = fkev(*argv)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"{TM}: ok (3 links")


def test_verbose_after_point_is_accepted():
    r = fkev("point", TM, "--solver", "dense", "--modes", "1", "-v")
    assert r.returncode == 0, r.stderr


def test_subcommand_errors_print_the_subcommand_usage():
    r = fkev("run", BW, "--angel", "3")
    assert r.returncode == 2
    assert r.stderr.startswith("usage: fkev run ")
    assert r.stderr.splitlines()[-1] == "fkev run: error: unrecognized arguments: --angel 3"


def test_version_names_package_petsc_slepc_and_mpi():
    r = fkev("--version")
    assert r.returncode == 0, r.stderr
    line = r.stdout.strip()
    assert "\n" not in line and line.startswith("fkev ")
    for word in ("PETSc 3.", "SLEPc 3.", "MPI: "):
        assert word in line


def test_modes_above_the_free_dofs_refused_up_front(archive):
    out, _ = archive
    before = digest(out)
    r = fkev("point", TM, "--modes", "200")
    assert r.returncode == 2 and r.stdout == ""
    line = ("--modes: 200 modes asked, but the model has 27 free DOFs, so at most 27 oscillating modes "
            "(refine with --elements or ask fewer)")
    assert problem_lines(r.stderr) == [line]
    # 5 elements -> 15 free DOFs: 16 modes is one too many; the archive stays as it was
    r = fkev("run", BW, *SMALL, "--modes", "16", "-o", out.with_name("other.h5"))
    assert r.returncode == 2
    assert problem_lines(r.stderr)[0].startswith("--modes: 16 modes asked, but the model has 15 free DOFs")
    assert digest(out) == before and not out.with_name("other.h5").exists()
    assert fkev("point", BW, "--modes", "15", "--solver", "dense", "--speed", "0").returncode == 0


def test_speed_in_rpm_equals_the_same_speed_in_rad_s():
    by_rpm = fkev("point", BW, "--angle", "10", "--speed-rpm", "9549.296585513720", "--case", "full", "--json",
                  "--solver", "dense")
    by_rad = fkev("point", BW, "--angle", "10", "--speed", "1000", "--case", "full", "--json", "--solver", "dense")
    assert by_rpm.returncode == by_rad.returncode == 0, by_rpm.stderr
    a, b = json.loads(by_rpm.stdout), json.loads(by_rad.stdout)
    assert a["speed_rad_s"] == pytest.approx(1000.0, rel=1e-14)
    assert a["speed_rpm"] == pytest.approx(9549.29658551372, rel=1e-14) and b["speed_rpm"] is None
    np.testing.assert_allclose(a["frequency_hz"], b["frequency_hz"], rtol=1e-12)
    text = fkev("point", BW, "--angle", "10", "--speed-rpm", "600", "--solver", "dense", "--modes", "1")
    assert "Ω = 62.8319 rad/s (600 rpm)" in text.stdout.splitlines()[0]


def test_speeds_rpm_on_run_and_rpm_scene_shown_in_point(tmp_path):
    scene = tmp_path / "rpm.toml"
    scene.write_text(BW.read_text().replace("speeds_rad_s = [0.0, 500.0, 1000.0]", "speeds_rpm = [0, 3000]"))
    r = fkev("point", scene, "--angle", "10", "--solver", "dense", "--modes", "1")  # first scene speed, 0 rpm
    assert r.returncode == 0, r.stderr
    assert "Ω = 0 rad/s (0 rpm)" in r.stdout
    out = tmp_path / "rpm.h5"
    r = fkev("run", BW, "--angles", "10", "--speeds-rpm", "0,600", "--cases", "full", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f:
        np.testing.assert_allclose(f["speed_rad_s"][()], [0.0, 600 * 2 * math.pi / 60], rtol=1e-15)
    r = fkev("run", BW, "--speeds", "1", "--speeds-rpm", "1", "-o", tmp_path / "x.h5")
    assert r.returncode == 2 and "not allowed with argument" in r.stderr


def test_resume_ignores_comments_and_names_the_first_changed_field(archive):
    out, scene = archive
    before = digest(out)
    text = scene.read_text()
    scene.write_text("# a new comment\n" + text.replace("length_m = 0.1270", "length_m   =   0.127   # O1-A"))
    r = fkev("run", scene, *SMALL, "-o", out, "--resume")
    assert r.returncode == 0, r.stderr
    assert f"fkev run: {out} is complete; nothing to do" in r.stderr
    scene.write_text(text.replace("length_m = 0.2794", "length_m = 0.28"))
    r = fkev("run", scene, *SMALL, "-o", out, "--resume")
    assert r.returncode == 2
    assert r.stderr.strip() == (f"fkev run: --resume: {out}: cannot resume: the scene changed since the archive "
                                "was written: links[1].length_m: archive has 0.2794, the scene now 0.28")
    assert digest(out) == before
    scene.write_text(text)
