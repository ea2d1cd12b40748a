"""One set of thresholds decides everywhere: imag_tol reaches the divergence verdict, the pairs
accepted and polished, and mode selection; every engine implements the Engine protocol."""

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from fkev_slepc.model.qep import LINEAR, QEP
from fkev_slepc.scene import load_scene
from fkev_slepc.solve.dense import DenseEngine
from fkev_slepc.solve.engines import CrossCheckEngine, make_engine
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.solve.protocol import Engine
from fkev_slepc.solve.thresholds import SolveSettings
from fkev_slepc.status import Status

BW = "runs/bahgat-willmert-1976.toml"


def near_real_qep(s: float = 2e-7) -> QEP:
    """M = I, K with a circulatory coupling s between two negative stiffnesses and a third DOF of
    stiffness 4: λ² = 1 ∓ i s, so λ ≈ ±(1 ∓ i s/2) (|Im λ|/|λ| ≈ s/2 = 1e-7), and λ = ±2i."""
    K = sp.csr_matrix(np.array([[-1.0, s, 0.0], [-s, -1.0, 0.0], [0.0, 0.0, 4.0]]))
    M = K.copy()  # on K's pattern, as a model's matrices are
    M.data = (np.repeat(np.arange(3), np.diff(K.indptr)) == K.indices).astype(float)
    return QEP(M, None, K, LINEAR)


def _engines(settings):
    from fkev_slepc.solve.slepc import SlepcEngine

    return [DenseEngine(settings), SlepcEngine(settings=settings)]


@pytest.mark.parametrize("which", [0, 1], ids=["dense", "slepc"])
def test_imag_tol_decides_divergence_selection_and_acceptance_alike(which):
    q = near_real_qep()
    lam = np.sqrt(np.array([1 - 2e-7j, 1 + 2e-7j], complex))
    assert np.all((1e-9 < np.abs(lam.imag) / np.abs(lam)) & (np.abs(lam.imag) / np.abs(lam) <= 1e-6))
    strict_engine, lax_engine = _engines(SolveSettings())[which], _engines(SolveSettings(imag_tol=1e-6))[which]
    try:
        strict, lax = strict_engine.solve(q, 1, want_vectors=True), lax_engine.solve(q, 1, want_vectors=True)
    finally:
        strict_engine.close(), lax_engine.close()
    # imag_tol 1e-9: the pairs are oscillations (f = 1.6e-8 Hz growing with ζ = -1), no divergence
    assert strict.converged and not strict.divergence.divergent and strict.imag_tol == 1e-9
    r = postprocess(strict, 1)
    assert r.status == Status.UNSTABLE and r.frequency_hz[0] == pytest.approx(1e-7 / (2 * np.pi), rel=1e-6)
    # imag_tol 1e-6: they are real everywhere: divergence located, not reported as a mode, accepted
    assert lax.converged and lax.divergence.divergent and lax.imag_tol == 1e-6
    assert lax.divergence.real_eigenvalues == pytest.approx([1.0, 1.0], rel=1e-12)
    r = postprocess(lax, 1)
    assert r.status == Status.DIVERGENT and r.frequency_hz[0] == pytest.approx(1 / np.pi, rel=1e-12)
    assert r.max_real == pytest.approx(1.0, rel=1e-12) and r.divergent.size == 2
    near = np.flatnonzero(np.abs(lax.eigenvalues.real) > 0.5)
    assert near.size == 4 and np.all(lax.errors[near] < 1e-12)  # the real pairs were judged, and pass
    # mode selection cannot use another imag_tol than the verdict and the acceptance did
    with pytest.raises(ValueError, match="imag_tol 1e-09 differs from the 1e-06 the engine decided with"):
        postprocess(lax, 1, imag_tol=1e-9)


def test_settings_come_from_the_scene_and_reach_every_engine():
    scene = load_scene(BW)
    scene = dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, imag_tol=1e-6, damping_tol=1e-4))
    st = SolveSettings.from_scene(scene)
    assert (st.imag_tol, st.damping_tol, st.max_pair_error) == (1e-6, 1e-4, 1e-3)
    with pytest.raises(ValueError, match="imag_tol must be < 1"):
        SolveSettings(imag_tol=1.0)
    dense = make_engine("dense", 10, settings=st)
    slepc = make_engine("slepc", 10, [("max_pair_error", "1e-5")], settings=st)
    cross = CrossCheckEngine(dense, slepc)
    for e in (dense, slepc, cross):
        assert isinstance(e, Engine) and e.solve_settings.imag_tol == 1e-6
    assert slepc.max_pair_error == 1e-5 and slepc.settings()["thresholds"]["imag_tol"] == 1e-6
    q = near_real_qep()
    sols = cross.solve_many([q, q], 1)
    assert [s.divergence.divergent for s in sols] == [True, True] and cross.n_points == 2
    assert cross.max_rel_diff < 1e-12
    cross.close()


def test_dense_engine_needs_no_petsc_without_petsc_options():
    """make_engine("dense") checks PETSc options only when some are given (no SLEPc engine built)."""
    import subprocess
    import sys

    code = ("import sys; from fkev_slepc.solve.engines import make_engine; e = make_engine('dense', 10, "
            "[('max_pair_error', '1e-4')]); assert e.max_pair_error == 1e-4; "
            "print('petsc4py.PETSc' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_a_forced_problem_type_is_honoured_or_refused():
    """-fkev_pep_general (valid for every point) is honoured, not overridden by the engine's choice;
    a structured type (gyroscopic, hermitian) is refused with the option named, whichever engine."""
    from fkev_slepc.scene import SceneError
    from test_eigen import beam_qep

    q = beam_qep(20, 20.0)  # gyroscopic
    with make_engine("slepc", 100, [("pep_general", "true")]) as e:
        sol = e.solve(q, 4)
        assert e._solver_for(q.kind).getProblemType() == e._pep.ProblemType.GENERAL
    with make_engine("slepc", 100) as e:
        e.solve(q, 4)
        assert e._solver_for(q.kind).getProblemType() == e._pep.ProblemType.GYROSCOPIC
    got, ref = postprocess(sol, 4).frequency_hz, postprocess(DenseEngine().solve(q, 4), 4).frequency_hz
    assert np.max(np.abs(got / ref - 1)) < 1e-9
    with pytest.raises(SceneError, match=r"solver.petsc.pep_gyroscopic: a problem type fkev cannot force "
                                         r"\(only -fkev_pep_general"):
        make_engine("slepc", 100, [("pep_gyroscopic", "true")])
    with pytest.raises(SceneError, match=r"eps_gen_hermitian: a problem type fkev cannot force"):
        make_engine("dense", 10, [("eps_gen_hermitian", "1")])
    with pytest.raises(SceneError, match=r"pep_problem_type: .*force only -fkev_pep_general"):
        make_engine("slepc", 100, [("pep_problem_type", "general")])


def test_blas_is_pinned_to_one_thread_on_the_command_line_and_overridable():
    import os
    import subprocess
    import sys

    from fkev_slepc._threads import BLAS_THREAD_VARIABLES, blas_environment, is_cli

    assert is_cli("/usr/bin/fkev") and is_cli("-m") and is_cli("/x/fkev_slepc/__main__.py") and not is_cli("pytest")
    assert blas_environment({}) == {v: "1" for v in BLAS_THREAD_VARIABLES}
    assert "OPENBLAS_NUM_THREADS" not in blas_environment({"OPENBLAS_NUM_THREADS": "4"})  # the user's is kept
    assert set(blas_environment({"OPENBLAS_NUM_THREADS": "4", "FKEV_BLAS_THREADS": "2"}).values()) == {"2"}
    assert blas_environment({"FKEV_BLAS_THREADS": "default"}) == {}
    code = "import sys; sys.argv = ['fkev']; import fkev_slepc, os; print(os.environ.get('OPENBLAS_NUM_THREADS'))"
    env = {k: v for k, v in os.environ.items() if k not in (*BLAS_THREAD_VARIABLES, "FKEV_BLAS_THREADS")}
    for extra, want in (({}, "1"), ({"FKEV_BLAS_THREADS": "3"}, "3"), ({"OPENBLAS_NUM_THREADS": "2"}, "2")):
        out = subprocess.run([sys.executable, "-c", code], env={**env, **extra}, capture_output=True, text=True)
        assert out.stdout.strip() == want, out.stderr


def test_completeness_of_the_lowest_frequencies():
    """A mode far from 0 (|Re λ| >> Im λ) can hide below the reported frequencies: suspected when
    converged real parts reach the radius searched; decided against the whole spectrum."""
    from fkev_slepc.solve.completeness import far_modes_possible, missed_modes, uncertified

    calm = np.array([-1e-3 + 10j, -1e-3 - 10j, 20j, -20j, 30j, -30j])
    assert not far_modes_possible(calm, 2, 1e-9)
    wild = np.array([300 + 40j, 300 - 40j, 100 + 50j, 100 - 50j, 320.0, -320.0])
    assert far_modes_possible(wild, 2, 1e-9)
    whole = np.concatenate([wild, [900 + 5j, 900 - 5j]])  # f = 5/2π, far outside |λ| <= 320
    assert "has f1 = 0.795775 Hz, SLEPc 6.3662 Hz" in missed_modes(wild, whole, 2, 1e-9)
    assert missed_modes(wild, wild, 2, 1e-9) == ""
    assert "not certified" in uncertified(wild, 2, 1e-9, 5000, 1000)
