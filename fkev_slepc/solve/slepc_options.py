"""The SLEPc engine's options: code defaults, checking, and configured solver objects.

The options database is read with the precedence command line > scene ``[solver.petsc]`` >
code default (:class:`~fkev_slepc.solve.petsc_backend.OptionsManager`); :func:`configured`
checks them and builds one PEP and one EPS with them (so that bad values and option names no
object reads are reported before the first point), :func:`check_options` does the same and keeps
nothing (the dense engine's check when PETSc options are given).
"""

from __future__ import annotations

from typing import NamedTuple

from fkev_slepc.model.qep import GENERAL, GYROSCOPIC, LINEAR, LINEAR_SYMMETRIC
from fkev_slepc.solve.petsc_backend import (
    PREFIX, OptionsError, OptionsManager, PETSc, describe_error, listing_options, positive_option,
    unknown_option_problems,
)
from fkev_slepc.solve.petsc_init import command_line_options
from fkev_slepc.solve.thresholds import MAX_PAIR_ERROR

from slepc4py import SLEPc  # noqa: E402  (PETSc is initialised by backend)

# Chosen by measurement (scripts/bench_large.py --lu, numbers in docs/engine.md): on refined
# four-bar and cantilever models UMFPACK is as accurate as MUMPS (both best of five packages)
# and about twice as fast per point; SuperLU loses digits on higher modes, KLU on the first,
# PETSc's own LU does not pivot. All five agree to 1e-9 on the thesis meshes.
LU_PACKAGE = "umfpack"

# Code defaults (lowest precedence), option names without the prefix.
DEFAULTS = {
    "pep_type": "toar",
    "pep_tol": "1e-14",
    "eps_type": "krylovschur",
    "eps_tol": "1e-12",
    "st_type": "sinvert",
    "st_ksp_type": "preonly",
    "st_pc_type": "lu",
    "st_pc_factor_mat_solver_type": LU_PACKAGE,
}

# SLEPc's problem-type flags (-fkev_pep_general, ...) and whether a user may force them: only the
# types valid for every point (M is symmetric positive definite). Otherwise the engine sets each
# point's type from its matrices (a gyroscopic PEP only when C is skew and K symmetric, a GHEP only
# for a symmetric K); a structured type forced on a point without that structure returns wrong
# eigenvalues, so it is refused, not silently overridden.
TYPE_FLAGS = {
    "pep": {"pep_general": True, "pep_hermitian": False, "pep_hyperbolic": False, "pep_gyroscopic": False},
    "eps": {"eps_gen_non_hermitian": True, "eps_pos_gen_non_hermitian": True, "eps_hermitian": False,
            "eps_gen_hermitian": False, "eps_non_hermitian": False, "eps_gen_indefinite": False},
}
_FALSE = ("0", "false", "no", "off")


class _Configured(NamedTuple):
    options: OptionsManager
    user: set
    sources: dict
    values: dict
    max_pair_error: float
    solvers: dict


def configured(petsc_options=(), max_pair_error: float = MAX_PAIR_ERROR) -> _Configured:
    """The options (precedence command line > scene > code default) checked, and one PEP and one
    EPS configured with them (so that bad options, and option names no object reads, are
    reported before the first point).

    Raises
    ------
    OptionsError
        Rejected values, names no solver object reads, or a problem type that cannot be forced.
    """
    om = OptionsManager({**DEFAULTS, "max_pair_error": repr(float(max_pair_error))}, petsc_options)
    user, sources, values = om.user_keys(), om.sources(), om.effective_values()
    worst = positive_option(values["max_pair_error"], "max_pair_error")
    forced = _forced_types(user, sources, values)
    if forced:
        raise OptionsError("; ".join(f"{p}: {m}" for p, m in forced), problems=forced)
    solvers: dict = {}
    try:
        with listing_options() as known:
            for kind in (GENERAL, LINEAR_SYMMETRIC):
                solvers[kind] = make_solver(om, user, kind)
    except PETSc.Error as err:  # e.g. a misspelt type in [solver.petsc] or on the command line
        _destroy(solvers)
        chosen = ", ".join(f"{k} = {v!r}" for k, v in values.items() if k in user)
        raise OptionsError(f"PETSc/SLEPc rejected the {PREFIX} options ({chosen or 'defaults'}): "
                           f"{describe_error(err)}") from None
    unknown = unknown_option_problems(om.scene_names, command_line_options(), known)
    if unknown:  # PETSc would silently ignore them (and run with its defaults)
        _destroy(solvers)
        raise OptionsError("; ".join(f"{p}: {m}" for p, m in unknown), problems=unknown)
    return _Configured(om, user, sources, values, worst, solvers)


def check_options(petsc_options=()) -> None:
    """Raise OptionsError when the options are invalid (:func:`configured`); nothing is kept."""
    _destroy(configured(petsc_options).solvers)


def _destroy(solvers: dict) -> None:
    for obj in solvers.values():
        obj.destroy()
    solvers.clear()


def _forced_types(user: set, sources: dict, values: dict) -> list[tuple[str, str]]:
    """(path, message) for each problem type the user forces that is not valid for every point."""
    out = []
    for family, flags in TYPE_FLAGS.items():
        ok = " or ".join(f"-{PREFIX}{k}" for k, allowed in flags.items() if allowed)
        for key, allowed in flags.items():
            if key in user and values.get(key, "").lower() not in _FALSE and not allowed:
                path = f"-{PREFIX}{key}" if sources.get(key) == "command_line" else f"solver.petsc.{key}"
                out.append((path, f"a problem type fkev cannot force (only {ok}, valid for every point): fkev "
                                  "sets each point's type from its matrices (gyroscopic only for a skew C and a "
                                  "symmetric K, gen_hermitian only for a symmetric K), and a structured type "
                                  "forced on a point without that structure gives wrong eigenvalues"))
    return out


def _forced(user: set, values: dict, family: str) -> bool:
    """Whether the user forces an (allowed) problem type of ``family`` ("pep" or "eps")."""
    return any(k in user and values.get(k, "").lower() not in _FALSE for k in TYPE_FLAGS[family])


def make_solver(options: OptionsManager, user: set, kind: str):
    """A PEP or EPS for problem ``kind`` with its problem type fixed (or the user's forced one,
    when :func:`configured` allowed it)."""
    linear = kind in (LINEAR_SYMMETRIC, LINEAR)
    cls = SLEPc.EPS if linear else SLEPc.PEP
    obj = cls().create(PETSc.COMM_SELF)
    obj.setOptionsPrefix(PREFIX)
    obj.setTarget(0.0)
    obj.setWhichEigenpairs(cls.Which.TARGET_MAGNITUDE)
    with options.inserted():  # the single setFromOptions of this object
        obj.setFromOptions()
    gyro = kind == GYROSCOPIC
    if gyro and obj.getType() == SLEPc.PEP.Type.LINEAR and not obj.getLinearExplicitMatrix():
        gyro = False  # 3.18's Linear refuses a structured type without explicit matrices
    types = cls.ProblemType
    if not _forced(user, options.effective_values(), "eps" if linear else "pep"):  # a forced one is honoured
        obj.setProblemType({LINEAR_SYMMETRIC: types.GHEP, LINEAR: types.GNHEP}.get(kind) if linear
                           else (types.GYROSCOPIC if gyro else types.GENERAL))
    return obj


# Solver types whose shift-and-invert about 0 factorizes K itself (P(0) = K; EPS: K - 0·M)
_K_FACTORING = {"PEP": ("toar", "stoar", "qarnoldi"), "EPS": ("krylovschur", "arnoldi", "lanczos")}


def factors_k(solver) -> bool:
    """Whether ``solver`` (a PEP or EPS after its solve) holds the factorization of K in its ST's
    KSP: one of the types above, shift-and-invert about 0, a direct solve (preonly, LU or Cholesky)."""
    st = solver.getST()
    ksp = st.getKSP()
    return (solver.getType() in _K_FACTORING.get(type(solver).__name__, ()) and st.getType() == SLEPc.ST.Type.SINVERT
            and solver.getTarget() == 0 and ksp.getType() == "preonly" and ksp.getPC().getType() in ("lu", "cholesky"))
