"""PETSc/SLEPc option names are checked like scene keys: a name no solver object reads
(misspelt, or without our prefix) is refused up front with "did you mean", exit 2, and an
existing archive is left bit-identical (issue 12, Deliver 2)."""

from pathlib import Path

import pytest

from clitools import BW, SMALL, digest, fkev, problem_lines, small_archive


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    return small_archive(tmp_path_factory.mktemp("opts") / "bw.h5")


def test_check_rejects_a_misspelt_option_in_the_scene(tmp_path):
    text = BW.read_text() + '\n[solver.petsc]\npep_tyep = "qarnoldi"\nst_pc_factor_mat_solver_type = "umfpack"\n'
    scene = tmp_path / "bw.toml"
    scene.write_text(text)
    r = fkev("check", scene)
    assert r.returncode == 2 and r.stdout == ""
    assert problem_lines(r.stderr) == ["solver.petsc.pep_tyep: unknown PETSc/SLEPc option: no solver object reads it "
                                       "(did you mean pep_type?)"]
    assert "Traceback" not in r.stderr


def test_check_accepts_options_the_objects_read(tmp_path):
    # pep_toar_restart is read only because the type is toar; the MUMPS key is read at
    # factorization time (after setFromOptions) and therefore let through
    text = BW.read_text() + ('\n[solver.petsc]\npep_type = "toar"\npep_toar_restart = 0.4\n'
                             'st_mat_mumps_icntl_14 = 40\nmax_pair_error = 1e-6\n')
    scene = tmp_path / "bw.toml"
    scene.write_text(text)
    r = fkev("check", scene)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("argv,line", [
    (["-fkev_pep_tpe", "toar"], "-fkev_pep_tpe: unknown PETSc/SLEPc option: no solver object reads it "
                                "(did you mean pep_type?)"),
    (["-pep_type", "toar"], "-pep_type: fkev's solver options carry the prefix fkev_ (did you mean -fkev_pep_type?)"),
    (["-fkev_pep_type", "qarnoldi", "-fkev_pep_toar_restart", "0.4"],
     "-fkev_pep_toar_restart: unknown PETSc/SLEPc option: no solver object reads it "
     "(misspelt, or meant for another solver type)"),
])
def test_run_rejects_unknown_command_line_options_before_solving(archive, argv, line):
    before, listing = digest(archive), sorted(archive.parent.iterdir())
    new = archive.with_name("new.h5")
    r = fkev("run", BW, *SMALL, "-o", new, *argv)
    assert r.returncode == 2
    assert problem_lines(r.stderr) == [line]
    assert digest(archive) == before and sorted(archive.parent.iterdir()) == listing  # nothing written


def test_point_rejects_a_misspelt_option_even_with_the_dense_engine():
    r = fkev("point", BW, "--solver", "dense", "-fkev_pep_tpe", "toar")
    assert r.returncode == 2 and r.stdout == ""
    assert "did you mean pep_type?" in r.stderr


def test_valid_options_still_change_the_solver():
    """A correctly spelt option is applied (not merely accepted): the archived settings show it."""
    import json

    r = fkev("point", BW, "--solver", "slepc", "--json", "-fkev_pep_type", "qarnoldi", "--angle", "10",
             "--speed", "500", "--case", "full", "--modes", "2")
    assert r.returncode in (0, 3), r.stderr
    assert json.loads(r.stdout)["solver"] == "slepc-pep-qarnoldi"
