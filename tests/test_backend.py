"""PETSc operators updated in place, and the options database (precedence and hygiene)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fkev_slepc.solve.petsc_backend import PREFIX, OptionsManager, PatternMismatch, PETSc, PetscOperators, command_line_keys
from fkev_slepc.model.qep import GYROSCOPIC, LINEAR_SYMMETRIC, QEP


def random_qep(n=12, seed=0, damping=True) -> QEP:
    """K, C, M with values drawn at random on one banded pattern (explicit zeros included)."""
    rng = np.random.default_rng(seed)
    band = sp.diags([np.ones(n - abs(k)) for k in (-2, -1, 0, 1, 2)], [-2, -1, 0, 1, 2], format="csr")
    band.sort_indices()

    def on_pattern(values):
        return sp.csr_matrix((values, band.indices, band.indptr), shape=(n, n))

    data = lambda: rng.standard_normal(band.nnz)  # noqa: E731
    K = on_pattern(data())
    K.data[::5] = 0.0  # explicit zeros must stay in the pattern
    return QEP(on_pattern(data()), on_pattern(data()) if damping else None, K, GYROSCOPIC if damping else LINEAR_SYMMETRIC)


def to_scipy(mat: PETSc.Mat) -> sp.csr_matrix:
    indptr, indices, data = mat.getValuesCSR()
    return sp.csr_matrix((data, indices, indptr), shape=mat.getSize())


def test_operators_hold_the_qep_values():
    q = random_qep()
    ops = PetscOperators(q)
    for mat, ref in ((ops.K, q.stiffness), (ops.C, q.damping), (ops.M, q.mass)):
        got = to_scipy(mat)
        assert got.nnz == ref.nnz  # explicit zeros kept: the pattern is the model's
        assert np.array_equal(got.toarray(), ref.toarray())
    ops.destroy()


def test_update_writes_in_place_without_new_matrices():
    q1, q2 = random_qep(seed=1), random_qep(seed=2, damping=False)
    ops = PetscOperators(q1)
    handles = [m.handle for m in (ops.K, ops.C, ops.M)]
    ops.update(q2)
    assert [m.handle for m in (ops.K, ops.C, ops.M)] == handles
    assert np.array_equal(to_scipy(ops.K).toarray(), q2.stiffness.toarray())
    assert np.array_equal(to_scipy(ops.M).toarray(), q2.mass.toarray())
    assert not to_scipy(ops.C).toarray().any()  # no damping matrix: C holds zeros
    assert not ops.has_damping
    ops.destroy()


def test_update_refuses_another_pattern():
    ops = PetscOperators(random_qep(n=12))
    with pytest.raises(PatternMismatch, match="12-DOF pattern"):
        ops.update(random_qep(n=13))
    ops.destroy()


def test_command_line_keys_keep_only_our_prefix():
    assert command_line_keys(["-fkev_pep_type", "toar", "-log_view", "-fkev_st_pc_factor_mat_solver_type",
                              "mumps", "-pep_tol", "1e-3"]) == {"pep_type", "st_pc_factor_mat_solver_type"}  # fmt: skip


def test_precedence_command_line_over_scene_over_default():
    opts = PETSc.Options()
    # what `fkev ... -fkev_ksp_rtol 1e-3` leaves in the database (slepc4py.init)
    opts[PREFIX + "ksp_rtol"] = "1e-3"
    try:
        om = OptionsManager(
            {"ksp_type": "cg", "ksp_rtol": "1e-9", "ksp_max_it": "7"},
            [("fkev_ksp_type", "bcgs"), ("-ksp_atol", "1e-20")],
        )
        ksp = PETSc.KSP().create(PETSc.COMM_SELF)
        ksp.setOptionsPrefix(PREFIX)
        with om.inserted():
            assert opts.getString(PREFIX + "ksp_type") == "bcgs"  # scene over default
            ksp.setFromOptions()
        assert ksp.getType() == "bcgs"
        rtol, atol, _, max_it = ksp.getTolerances()
        assert (rtol, atol, max_it) == (1e-3, 1e-20, 7)  # command line > scene > default
        assert om.sources() == {"ksp_atol": "scene", "ksp_max_it": "default", "ksp_rtol": "command_line",
                                "ksp_type": "scene"}  # fmt: skip
        assert om.effective_values() == {"ksp_atol": "1e-20", "ksp_max_it": "7", "ksp_rtol": "1e-3",
                                         "ksp_type": "bcgs"}  # fmt: skip
        # hygiene: what we inserted is gone, the user's own option is untouched
        for k in ("ksp_type", "ksp_max_it", "ksp_atol"):
            assert not opts.hasName(PREFIX + k)
        assert opts.getString(PREFIX + "ksp_rtol") == "1e-3"
        assert om.user_keys() == {"ksp_rtol", "ksp_type", "ksp_atol"}
        ksp.destroy()
    finally:
        opts.delValue(PREFIX + "ksp_rtol")


def test_options_deleted_even_when_set_from_options_fails():
    om = OptionsManager({"ksp_type": "no_such_krylov_method"})
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    ksp.setOptionsPrefix(PREFIX)
    with pytest.raises(PETSc.Error):
        with om.inserted():
            ksp.setFromOptions()
    assert not PETSc.Options().hasName(PREFIX + "ksp_type")
    ksp.destroy()
