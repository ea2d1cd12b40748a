"""PETSc side of the SLEPc engine: operators updated in place, and the options database.

Two jobs, both about *reuse across grid points*:

* :class:`PetscOperators` turns the CSR matrices of a model (``qep.py``: K, C and M share one
  sparsity pattern) into three PETSc AIJ matrices on ``PETSc.COMM_SELF``, created once, whose
  values are overwritten in place for every point (``setValuesCSR`` on the same pattern).
  Solvers built on them keep their objects; only ``setOperators`` is called again.
* :class:`OptionsManager` applies code defaults and the scene's ``[solver.petsc]`` table under
  the prefix ``fkev_`` with the precedence command line > scene > code default (DOLFINx
  ``LinearProblem`` / petsctools ``OptionsManager``): a value is inserted into
  ``PETSc.Options()`` only when the database does not already hold the key (i.e. the user did
  not give it on the command line), ``setFromOptions`` runs once per object, and every inserted
  key is deleted afterwards so the global table does not grow.
"""

from __future__ import annotations

import ctypes
import difflib
import io
import os
import re
import sys
import tempfile
from collections.abc import Iterable, Mapping
from contextlib import contextmanager

import numpy as np

from fkev_slepc.solve.petsc_init import command_line_options, init_petsc
from fkev_slepc.model.qep import QEP

init_petsc()  # no-op when the CLI already initialised PETSc with the command-line options
from petsc4py import PETSc  # noqa: E402

PREFIX = "fkev_"
FKEV_KEYS = frozenset({"max_pair_error"})  # read by our engines under the prefix, not by PETSc
# Read by the LU package when it factorizes (after setFromOptions): these cannot be checked up front.
_LATE = re.compile(r"(^|_)mat_(mumps|superlu|superlu_dist|umfpack|klu|cholmod|strumpack|mkl_c?pardiso|pastix)_")
# Families of options that belong under our prefix when given bare on the command line.
_SOLVER_FAMILIES = ("pep_", "eps_", "st_", "ksp_", "pc_", "bv_", "ds_", "rg_", "fn_")
KNOWN_OPTIONS: set[str] = set()
"""Option names (without the prefix) that the solver objects configured in this process queried."""


class PatternMismatch(ValueError):
    """A QEP whose matrices are not on the sparsity pattern the operators were built for."""


class PetscOperators:
    """K, C and M of one model as PETSc AIJ matrices on ``COMM_SELF`` (built once, updated in place).

    Parameters
    ----------
    qep : QEP
        Any QEP of the model; its mass matrix defines the pattern (shared by K and C).

    Notes
    -----
    ``update`` writes values into the existing matrices, so the nonzero structure (and with it
    the symbolic factorization of a direct solver) never changes between points. After an
    update the solver must be given the operators again (``setOperators``): SLEPc 3.18 keeps
    its ``solved`` state otherwise and returns the previous point's eigenvalues.
    """

    def __init__(self, qep: QEP):
        A = qep.mass
        self.n = A.shape[0]
        self.indptr = np.ascontiguousarray(A.indptr, dtype=PETSc.IntType)
        self.indices = np.ascontiguousarray(A.indices, dtype=PETSc.IntType)
        self._zeros = np.zeros(self.indices.size)
        self.K, self.C, self.M = (self._create() for _ in range(3))
        self.has_damping = False
        self.update(qep)

    def _create(self) -> PETSc.Mat:
        mat = PETSc.Mat().createAIJ(
            size=(self.n, self.n), csr=(self.indptr, self.indices, self._zeros), comm=PETSc.COMM_SELF
        )
        # Any entry outside the pattern is a bug in the caller: fail instead of reallocating.
        mat.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        mat.assemble()
        return mat

    def matches(self, qep: QEP) -> bool:
        """True when every matrix of ``qep`` lies on this pattern (same indptr and indices)."""
        mats = [m for m in (qep.mass, qep.damping, qep.stiffness) if m is not None]
        return all(m.shape == (self.n, self.n) and self._same_pattern(m) for m in mats)

    def _same_pattern(self, A) -> bool:
        if A.indices is self.indices or A.indptr is self.indptr:  # the model's shared arrays
            return True
        return (
            A.indptr.size == self.indptr.size
            and A.indices.size == self.indices.size
            and np.array_equal(A.indptr, self.indptr)
            and np.array_equal(A.indices, self.indices)
        )

    def update(self, qep: QEP) -> None:
        """Overwrite the values of K, C, M with those of ``qep`` (same pattern, no re-creation).

        Raises
        ------
        PatternMismatch
            If ``qep`` is not on this pattern.
        """
        if not self.matches(qep):
            raise PatternMismatch(
                f"QEP matrices (n = {qep.n}) are not on the {self.n}-DOF pattern these operators were built for"
            )
        self._set(self.K, qep.stiffness.data)
        self._set(self.M, qep.mass.data)
        self.has_damping = qep.damping is not None
        self._set(self.C, qep.damping.data if self.has_damping else self._zeros)

    def _set(self, mat: PETSc.Mat, data: np.ndarray) -> None:
        mat.setValuesCSR(self.indptr, self.indices, np.ascontiguousarray(data, dtype=PETSc.ScalarType))
        mat.assemble()

    def destroy(self) -> None:
        for mat in (self.K, self.C, self.M):
            mat.destroy()


class FactoredSolve:
    """K⁻¹B for a real or complex (n, k) block B, with a KSP that holds the factorization of the
    balanced K_b = D K D (``d`` its diagonal): K⁻¹ = D K_b⁻¹ D. PETSc here has real scalars, so a
    complex column is two solves. Used by solve/refine.py, with the factorization SLEPc's
    shift-and-invert about 0 already computed (no new factorization). Raises RuntimeError when
    PETSc fails (the caller's fallback, as for an exactly singular SuperLU factor).
    """

    def __init__(self, ksp: PETSc.KSP, d: np.ndarray):
        self.ksp, self.d = ksp, np.asarray(d, dtype=float)
        self.solves = 0

    def __call__(self, B: np.ndarray) -> np.ndarray:
        B = np.asarray(B)
        k = B.shape[1]
        cols = np.hstack([B.real, B.imag]) if np.iscomplexobj(B) else B
        b, x = self.ksp.getOperators()[0].createVecs()
        out = np.empty(cols.shape)
        try:
            for j in range(cols.shape[1]):
                b.setArray(self.d * cols[:, j])
                self.ksp.solve(b, x)
                out[:, j] = self.d * x.getArray(readonly=True)
        except PETSc.Error as err:  # e.g. a zero pivot: the caller falls back (as for scipy's splu)
            raise RuntimeError(f"solve with the factorization of K failed ({describe_error(err)})") from None
        finally:
            b.destroy()
            x.destroy()
        self.solves += cols.shape[1]
        return out[:, :k] + 1j * out[:, k:] if np.iscomplexobj(B) else out


def _option_key(name: str) -> str:
    """``-fkev_pep_type`` / ``fkev_pep_type`` / ``pep_type`` -> ``pep_type``."""
    return name.lstrip("-").removeprefix(PREFIX)


def command_line_keys(args: Iterable[str] | None = None) -> set[str]:
    """Option names (without ``-fkev_``) given on the command line under our prefix."""
    args = command_line_options() if args is None else args
    return {_option_key(a) for a in args if a.startswith("-" + PREFIX)}


class OptionsManager:
    """Precedence and hygiene of the PETSc options under the prefix ``fkev_``.

    Parameters
    ----------
    defaults : mapping
        Code defaults, option name (without prefix) -> string value.
    scene : iterable of (name, value) pairs
        The scene's ``[solver.petsc]`` table (``Solver.petsc``); names may carry a leading
        ``-`` or ``fkev_``.

    Examples
    --------
    >>> om = OptionsManager({"pep_type": "toar"}, [("pep_tol", "1e-12")])
    >>> with om.inserted():                # doctest: +SKIP
    ...     pep.setFromOptions()           # the one call per object
    >>> om.sources()["pep_tol"]
    'scene'
    """

    def __init__(self, defaults: Mapping[str, str] = (), scene: Iterable[tuple[str, str]] = ()):
        self.defaults = {_option_key(k): str(v) for k, v in dict(defaults).items()}
        scene = list(scene)
        self.scene = {_option_key(k): str(v) for k, v in scene}
        self.scene_names = [str(k) for k, _ in scene]  # as written, for messages
        self.cmdline = command_line_keys()
        self._inserted_now: frozenset[str] = frozenset()

    def user_keys(self) -> set[str]:
        """Keys the user chose (command line, anything already in the database, or scene)."""
        opts = PETSc.Options()
        in_db = {k for k in (*self.defaults, *self.scene) if opts.hasName(PREFIX + k)}
        return self.cmdline | in_db | set(self.scene)

    def sources(self) -> dict[str, str]:
        """Where each key's effective value comes from: ``command_line`` | ``scene`` | ``default``."""
        opts = PETSc.Options()
        out = {}
        for k in sorted({*self.defaults, *self.scene, *self.cmdline}):
            external = k in self.cmdline or (opts.hasName(PREFIX + k) and k not in self._inserted_now)
            out[k] = "command_line" if external else ("scene" if k in self.scene else "default")
        return out

    @contextmanager
    def inserted(self):
        """Insert scene and default values the database does not already hold; delete them on exit.

        Wrap exactly one ``setFromOptions()`` per PETSc object in this context.
        """
        opts = PETSc.Options()
        merged = {**self.defaults, **self.scene}
        mine = [k for k in merged if not opts.hasName(PREFIX + k)]
        for k in mine:
            opts[PREFIX + k] = merged[k]
        self._inserted_now = frozenset(mine)
        try:
            yield
        finally:
            for k in mine:
                opts.delValue(PREFIX + k)
            self._inserted_now = frozenset()

    def effective_values(self) -> dict[str, str]:
        """Value of every key as ``setFromOptions`` sees it (command line > scene > default)."""
        opts = PETSc.Options()
        out = {**self.defaults, **self.scene}
        for k, src in self.sources().items():
            if src == "command_line":
                out[k] = opts.getString(PREFIX + k, "") or ""
        return dict(sorted(out.items()))


class OptionsError(ValueError):
    """The PETSc options (scene ``[solver.petsc]`` or ``-fkev_`` on the command line) are invalid.

    ``problems`` lists (path, message) pairs; the path names the offending option as the user
    wrote it (``solver.petsc.pep_tyep`` or ``-fkev_pep_tpe``).
    """

    def __init__(self, message: str, path: str = "solver.petsc", problems: list[tuple[str, str]] | None = None):
        super().__init__(message)
        self.problems = list(problems) if problems else [(path, message)]


# ------------------------------------------------------------------ unknown option names
@contextmanager
def listing_options():
    """Record the names of the options that ``setFromOptions`` calls inside the block query.

    PETSc has no API listing the options an object reads, but with ``-help`` in the database
    every ``setFromOptions`` prints each option it queries (for the types actually selected)
    to stdout. The block runs with ``-help`` set and file descriptor 1 redirected to a
    temporary file; the names printed under our prefix are added to :data:`KNOWN_OPTIONS`
    (which accumulates: PETSc prints one object family's list once per process).
    """
    opts = PETSc.Options()
    had_help = opts.hasName("help")
    sys.stdout.flush()
    saved, py_stdout = os.dup(1), sys.stdout
    with tempfile.TemporaryFile() as tmp:
        # PETSc prints through C stdio to fd 1, or through Python's sys.stdout when that is not
        # the process's stdout (petsc4py redirects it then, e.g. under pytest): catch both.
        os.dup2(tmp.fileno(), 1)
        sys.stdout = io.StringIO()
        if not had_help:
            opts["help"] = ""
        try:
            yield KNOWN_OPTIONS
        finally:
            if not had_help:
                opts.delValue("help")
            ctypes.CDLL(None).fflush(None)
            os.dup2(saved, 1)
            os.close(saved)
            text, sys.stdout = sys.stdout.getvalue(), py_stdout
            tmp.seek(0)
            text += tmp.read().decode("utf-8", "replace")
    KNOWN_OPTIONS.update(re.findall(r"-" + PREFIX + r"([A-Za-z0-9_]+)", text))


def unknown_option_problems(scene_keys: Iterable[str], cmdline: Iterable[str], known: set[str]) -> list[tuple[str, str]]:
    """(path, message) for every option no configured solver object reads.

    Parameters
    ----------
    scene_keys : names as written in the scene's ``[solver.petsc]`` table
    cmdline : the PETSc command-line tokens (``-fkev_pep_type``, ``toar``, ``-log_view``...)
    known : names (without prefix) the objects queried (:func:`listing_options`)
    """
    valid = set(known) | FKEV_KEYS
    out = []

    def check(key: str, path: str) -> None:
        if key in valid or _LATE.search(key):
            return
        close = difflib.get_close_matches(key, sorted(valid), n=1, cutoff=0.8)
        hint = f"did you mean {close[0]}?" if close else "misspelt, or meant for another solver type"
        hint = _HINTS.get(key, hint)
        out.append((path, f"unknown PETSc/SLEPc option: no solver object reads it ({hint})"))

    for name in scene_keys:
        check(_option_key(name), f"solver.petsc.{name}")
    for tok in cmdline:
        if not tok.startswith("-") or _is_number(tok):
            continue
        bare = tok.lstrip("-")
        if bare.startswith(PREFIX):
            check(bare.removeprefix(PREFIX), tok)
        elif bare.startswith(_SOLVER_FAMILIES):
            out.append((tok, f"fkev's solver options carry the prefix {PREFIX} (did you mean -{PREFIX}{bare}?)"))
    return out


_HINTS = {  # options users try that SLEPc spells otherwise
    "pep_problem_type": f"SLEPc sets it by a flag; fkev lets you force only -{PREFIX}pep_general",
    "eps_problem_type": f"SLEPc sets it by a flag; fkev lets you force only -{PREFIX}eps_gen_non_hermitian "
                        f"or -{PREFIX}eps_pos_gen_non_hermitian",
}


def _is_number(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


# ----------------------------------------------------------------- option and error text
def positive_option(text: str, name: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0:
        raise OptionsError(f"{PREFIX}{name}: must be a number > 0 (got {text!r})")
    return value


def enum_name(enum, value) -> str:
    names = [k for k, v in vars(enum).items() if v == value and not k.startswith("_")]
    return names[0] if names else str(value)


def describe_error(err: PETSc.Error) -> str:
    """The message lines of a PETSc error (petsc4py's text is the code, a call stack, then them)."""
    lines = [ln.removeprefix("[0] ").strip() for ln in str(err).splitlines()[1:]]
    text = "; ".join(ln for ln in lines if ln and not re.search(r"\(\) at \S+:\d+$", ln))
    return text or ERROR_TEXT.get(getattr(err, "ierr", None), "no message")


ERROR_TEXT = {55: "out of memory", 56: "operation not supported", 58: "operation done in wrong order",
               62: "invalid argument", 71: "zero pivot in LU factorization (singular matrix)",
               72: "floating point exception", 73: "object in wrong state", 76: "error in an external library",
               77: "inconsistent data in PETSc", 81: "zero pivot in Cholesky factorization",
               82: "iterative method failed", 91: "solver did not converge"}  # fmt: skip
