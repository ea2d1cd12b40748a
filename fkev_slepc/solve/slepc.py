"""The SLEPc engine: smallest-|λ| eigenpairs of (λ²M + λC + K)x = 0 by PEP, or by EPS in μ = -λ².

One engine per rank holds one solver object per problem type (PEP general / gyroscopic, EPS
GHEP / GNHEP) on ``PETSc.COMM_SELF`` and one set of PETSc matrices
(:class:`~fkev_slepc.solve.petsc_backend.PetscOperators`), all created once and reused for every
grid point: values are copied in place and ``setOperators`` is called again (SLEPc 3.18 keeps
its *solved* state otherwise and returns the previous point's eigenvalues).

A solver object never changes its problem type: SLEPc 3.18 keeps the symmetric Krylov-Schur
variant, its projected-problem type and the B-inner product chosen at the first ``setUp``, so
an EPS that solved a GNHEP and is then told GHEP (a sweep over speeds 100, 0 of a case without
Coriolis; or cases ``full`` and ``no_tangential`` with a crank acceleration) crashed the process
with SIGSEGV (tests/test_stress.py).

Formulation (docs/theory.md §10):

* ``gyroscopic`` / ``general`` QEPs: PEP (TOAR), shift-and-invert about the real target 0,
  ``TARGET_MAGNITUDE``, ``nev = 2·n_modes + 2`` (a conjugate pair per frequency, plus room for a
  real divergence pair), an even ncv, and a scalar scale factor α ≈ |λ₁| (the caller's hint,
  else a few steps of inverse iteration with the ST's own factorization of K). SLEPc's default
  scaling returns wrong eigenvalues flagged as converged on refined models (docs/engine.md).
* ``linear_symmetric`` / ``linear`` (no C): EPS on K x = μ M x (GHEP / GNHEP), λ = ±sqrt(-μ):
  μ = ω² > 0 gives ±iω, μ < 0 a real pair (divergence).

Every pair gets :func:`~fkev_slepc.solve.acceptance.pair_error` (SLEPc's ``computeError`` reports ~1e-15 for
wrong pairs on these stiff models). Every setting can be overridden under ``-fkev_``.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from fkev_slepc.solve.petsc_backend import (  # noqa: F401 (OptionsError re-exported)
    PREFIX, FactoredSolve, OptionsError, PatternMismatch, PETSc, PetscOperators, describe_error, enum_name,
)
from fkev_slepc.solve.slepc_options import DEFAULTS, LU_PACKAGE, SLEPc, configured, factors_k, make_solver  # noqa: F401
from fkev_slepc.solve.polish import polish_reported
from fkev_slepc.solve.acceptance import check_pairs, pair_error
from fkev_slepc.solve.completeness import far_modes_possible, missed_modes, uncertified
from fkev_slepc.solve.dense import DenseEngine, all_eigenvalues, balanced
from fkev_slepc.solve.finite import require_finite
from fkev_slepc.solve.protocol import EigenSolution
from fkev_slepc.solve.stability import DENSE_LIMIT, check_divergence
from fkev_slepc.solve.thresholds import SolveSettings
from fkev_slepc.model.qep import GENERAL, GYROSCOPIC, LINEAR, LINEAR_SYMMETRIC, QEP

log = logging.getLogger(__name__)

_SCALE_KEYS = {"pep_scale", "pep_scale_factor"}
_SEED = 0x5EED
_MAX_RETRIES = 2  # enlarge nev when real (divergence) eigenvalues crowd out wanted modes


class SlepcEngine:
    """SLEPc PEP/EPS engine (implements :class:`~fkev_slepc.solve.protocol.Engine`).

    Parameters
    ----------
    petsc_options : iterable of (name, value)
        The scene's ``[solver.petsc]`` table; the command line overrides it, it overrides the
        code defaults (:data:`DEFAULTS`).
    max_pair_error : float, optional
        Code default of the option ``-fkev_max_pair_error`` (an fkev option, not PETSc's; the
        command line and the scene's ``[solver.petsc]`` override it). A solution whose reported pairs (the ``n_modes`` lowest frequencies and the real
        eigenvalues) have a larger :func:`~fkev_slepc.solve.acceptance.pair_error` is returned with
        ``converged=False`` and a message, even when SLEPc counted it converged.
    settings : SolveSettings, optional
        The run's thresholds (:meth:`SolveSettings.from_scene`); its ``max_pair_error`` is the code
        default of the option (which ``max_pair_error`` replaces when given).

    Examples
    --------
    >>> engine = SlepcEngine([("pep_type", "qarnoldi")])     # doctest: +SKIP
    >>> sol = engine.solve(qep, n_modes=4, hint=abs(lam1))  # doctest: +SKIP
    >>> engine.close()                                      # doctest: +SKIP
    """

    name = "slepc"

    def __init__(self, petsc_options=(), max_pair_error: float | None = None, settings: SolveSettings | None = None):
        settings = SolveSettings() if settings is None else settings
        code = settings.max_pair_error if max_pair_error is None else max_pair_error
        cfg = configured(petsc_options, code)
        self._options, self._user, self._sources, self._values = cfg.options, cfg.user, cfg.sources, cfg.values
        self._solvers: dict = cfg.solvers  # problem kind (qep.KINDS) -> its own PEP or EPS
        self.solve_settings = settings.replace(max_pair_error=cfg.max_pair_error)
        self._ops: PetscOperators | None = None
        self._ksp: PETSc.KSP | None = None  # K's own factorization, for the scale estimate of non-TOAR types
        self._last: dict = {}

    @property
    def max_pair_error(self) -> float:
        return self.solve_settings.max_pair_error

    @property
    def _pep(self):
        """The general-QEP PEP (settings and options are the same for every problem type)."""
        return self._solvers.get(GENERAL)

    def _solver_for(self, kind: str):
        """The PEP or EPS for problem ``kind``, created on first use with its problem type fixed."""
        if kind not in self._solvers:
            self._solvers[kind] = make_solver(self._options, self._user, kind)
        return self._solvers[kind]

    # -- the protocol ------------------------------------------------------------------------
    def solve(self, qep: QEP, n_modes: int, want_vectors: bool = False, hint: float | None = None, *,
              _report: int | None = None, _widened: int = 0) -> EigenSolution:
        """Eigenpairs of ``qep`` nearest 0, enough for the ``n_modes`` lowest frequencies.

        ``n_modes`` frequencies (each a conjugate pair); ``want_vectors``: return eigenvectors
        (one column per eigenvalue); ``hint``: |λ| of the lowest wanted mode (the PEP's scale).
        ``converged`` is False (with a message) when fewer pairs converged than asked or
        PETSc/SLEPc raised an error; the engine stays usable for the next point. Above 1000 DOFs
        a point whose lowest frequencies could lie outside the disc searched (completeness.py)
        is solved again for 3x, then 9x the frequencies (``_report``: those asked, ``_widened``).
        """
        if n_modes < 1:
            raise ValueError(f"n_modes must be >= 1 (got {n_modes})")
        linear = qep.kind in (LINEAR_SYMMETRIC, LINEAR)
        if linear and qep.damping is not None:
            raise ValueError(f"a {qep.kind!r} QEP must have no damping matrix")
        require_finite(qep)  # a point failure with the reason, not a PETSc error or a traceback
        try:
            # balanced like the dense engine: measured on random crank-rockers, the LU of an
            # unbalanced K cost SLEPc up to 60x the conditioning floor (scripts/stress.py random)
            work, d = balanced(qep)
            self._load(work)
            if linear:
                lam, X, ok, msg = self._solve_linear(qep, n_modes)
            else:
                lam, X, ok, msg = self._solve_quadratic(qep, n_modes, hint)
        except PETSc.Error as err:
            msg = f"PETSc/SLEPc error {err.ierr} at a {qep.kind} point ({describe_error(err)})"
            log.warning(msg)
            # The failed solver may keep a broken state (MUMPS: a PC "set up" around an invalid
            # factor; Linear: a scale factor it refuses to push again), so every later point would
            # fail too (measured): replace it by a new one with the same options.
            broken = self._solvers.pop(qep.kind, None)
            if broken is not None:
                broken.destroy()
            self._last = {"failed": msg}
            return EigenSolution(np.zeros(0, complex), np.zeros(0), None, False, self.name, msg)
        X = d[:, None] * X
        st = self.solve_settings
        err = pair_error(qep, lam, X) if lam.size else np.zeros(0)
        # TOAR's pairs are 2-3 digits short of their conditioning, and on fine meshes the assembled
        # K's round-off: made pairs of the accurate operator with K's factorization (refine.py),
        # the one SLEPc's shift-and-invert about 0 just computed, else the engine's own
        solver = self._solver_for(qep.kind)
        solve = FactoredSolve(solver.getST().getKSP() if factors_k(solver) else self._own_ksp(), d)
        lam, X, err, note = polish_reported(qep, lam, X, err, n_modes, st, by_floor=True, solve=solve, d=d)
        self._last["refine_solves"] = solve.solves
        worst, bad = check_pairs(qep, lam, X, err, n_modes, st)
        bad = "; ".join(m for m in (note, bad) if m)
        if ok and bad:
            # "converged" by SLEPc's own test, yet a pair the point reports does not satisfy the
            # QEP (measured: qarnoldi at divergent points; any method on over-refined models)
            ok, msg = False, bad
        self._last["max_pair_error"] = float(worst)
        whole: list = []  # the dense whole spectrum, computed at most once per point
        spectrum = lambda q: whole[0] if whole else whole.append(all_eigenvalues(q)) or whole[0]  # noqa: E731

        # Divergence is decided on the whole spectrum, not on the pairs nearest 0 (stability.py).
        verdict = check_divergence(qep, computed=lam, dense_spectrum=spectrum, imag_tol=st.imag_tol,
                                   dense_limit=DENSE_LIMIT)
        report = n_modes if _report is None else _report  # the frequencies the caller asked for
        if ok and (whole or far_modes_possible(lam, report, st.imag_tol)):  # completeness.py
            if not whole and qep.n > DENSE_LIMIT:
                if _widened < 2 and not {"pep_nev", "eps_nev"} & self._user:  # a wider disc
                    return self.solve(qep, 3 * n_modes, want_vectors, hint, _report=report, _widened=_widened + 1)
                ok, msg = False, uncertified(lam, report, st.imag_tol, qep.n, DENSE_LIMIT)
            elif missed_modes(lam, spectrum(qep), report, st.imag_tol):  # the dense engine solves it
                sol = DenseEngine(st).solve(qep, n_modes, want_vectors, hint)
                return dataclasses.replace(sol, solver=f"{sol.solver} (SLEPc missed the lowest modes)")
        return EigenSolution(lam, err, X if want_vectors else None, ok, self._last["method"], msg, verdict,
                             st.imag_tol)

    def solve_many(self, qeps: list, n_modes: int, want_vectors: bool = False, hints=None) -> list[EigenSolution]:
        """:meth:`solve` of each problem in turn (a Krylov solve gains nothing from batching)."""
        hints = [None] * len(qeps) if hints is None else list(hints)
        return [self.solve(q, n_modes, want_vectors, h) for q, h in zip(qeps, hints)]

    def settings(self) -> dict:
        """Effective settings (archived): solver objects, options and where each came from."""
        pep, eps = self._solver_for(GENERAL), self._solver_for(LINEAR_SYMMETRIC)
        pc = pep.getST().getKSP().getPC()
        out = {
            "engine": self.name,
            "petsc_version": "%d.%d.%d" % PETSc.Sys.getVersion(),
            "slepc_version": "%d.%d.%d" % SLEPc.Sys.getVersion(),
            "prefix": PREFIX,
            "pep_type": pep.getType(),
            "pep_tol": pep.getTolerances()[0],
            "pep_max_it": pep.getTolerances()[1] if pep.getTolerances()[1] > 0 else "default (set at setUp)",
            "pep_target": float(np.real(pep.getTarget())),
            "pep_which": enum_name(SLEPc.PEP.Which, pep.getWhichEigenpairs()),
            "eps_type": eps.getType(),
            "eps_tol": eps.getTolerances()[0],
            "st_type": pep.getST().getType(),
            "ksp_type": pep.getST().getKSP().getType(),
            "pc_type": pc.getType(),
            "factor_solver_type": self._values.get("st_pc_factor_mat_solver_type", ""),
            "max_pair_error": self.max_pair_error,
            "thresholds": self.solve_settings.as_dict(),
            "options": self._values,
            "option_sources": self._sources,
        }
        out.update({f"last_{k}": v for k, v in self._last.items()})
        return out

    def close(self) -> None:
        """Destroy the PETSc/SLEPc objects (explicitly: collection order is not collective-safe)."""
        for obj in (*getattr(self, "_solvers", {}).values(), getattr(self, "_ksp", None), getattr(self, "_ops", None)):
            if obj is not None:
                obj.destroy()
        self._solvers = {}
        self._ksp = self._ops = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- internals ---------------------------------------------------------------------------
    def _load(self, qep: QEP) -> None:
        """Copy the values of ``qep`` into the PETSc matrices (built on the first point)."""
        if self._ops is not None:
            try:
                self._ops.update(qep)
                return
            except PatternMismatch:
                # another model on the same engine: rebuild once for it (logged, not silent)
                log.info("new sparsity pattern (n = %d): rebuilding PETSc operators", qep.n)
                self._ops.destroy()
        self._ops = PetscOperators(qep)

    def _solve_quadratic(self, qep: QEP, n_modes: int, hint):
        pep, ops = self._solver_for(qep.kind), self._ops
        # Again at every point: the values changed in place (see module docstring).
        pep.setOperators([ops.K, ops.C, ops.M])
        alpha, source = self._scale(pep, hint)
        out = self._run(pep, "pep", n_modes, 2 * n_modes + 2, 2 * qep.n, 2, lambda lam, X: (lam, X))
        self._last.update(method=f"slepc-pep-{pep.getType()}", scale_alpha=alpha, scale_source=source)
        return out

    def _solve_linear(self, qep: QEP, n_modes: int):
        eps, ops = self._solver_for(qep.kind), self._ops
        eps.setOperators(ops.K, ops.M)
        sym = qep.kind == LINEAR_SYMMETRIC

        def to_lambda(mu, Y):  # μ = -λ²: ω² > 0 gives ±iω, μ < 0 a real pair
            root = np.sqrt(-mu.astype(complex))
            return np.concatenate([root, -root]), np.hstack([Y, Y])

        out = self._run(eps, "eps", n_modes, n_modes + 1, qep.n, 1, to_lambda)
        self._last["method"] = f"slepc-eps-{eps.getType()}-{'ghep' if sym else 'gnhep'}"
        return out

    def _run(self, solver, kind: str, n_modes: int, nev: int, size: int, per_mode: int, to_lambda):
        """Solve; while real eigenvalues crowd out wanted frequencies, solve again with a larger nev;
        when the solve stops short (e.g. DIVERGED_ITS), once more from another initial vector with
        twice the ncv (unless the user set ncv or nev).

        ``per_mode`` is the number of solver eigenvalues per frequency (2 for a PEP, 1 for the
        EPS in μ). Returns (λ, X, ok, message) and records the details in ``self._last``. The
        point is accepted when its ``n_modes`` frequencies converged, even if SLEPc converged fewer
        than the nev asked (nev has room for real pairs; what converged is the leading run nearest
        the target, and every reported pair is judged on its own afterwards).
        """
        user_nev = f"{kind}_nev" in self._user
        fixed = user_nev or bool({f"{kind}_ncv", f"{kind}_max_it"} & self._user)  # the user's subspace or limit
        seed, wide, restarts = _SEED, False, 0
        for attempt in range(_MAX_RETRIES + 2):
            if not user_nev:
                solver.setDimensions(nev=min(nev, size), **self._dims(kind, nev, size, wide))
            # same initial vector at every point, whatever was solved before (reproducible sweeps)
            solver.getBV().getRandomContext().setSeed(seed)
            solver.solve()
            values, Y, nconv = _pairs(solver, self._ops)
            lam, X = to_lambda(values, Y)
            wanted, reason = solver.getDimensions()[0], solver.getConvergedReason()
            found = _count_oscillating(lam, self.solve_settings.imag_tol)
            if found >= n_modes or nev >= size:
                break
            if nconv < wanted or reason <= 0:  # stopped short: change the start vector and the subspace
                if restarts or fixed:
                    break
                seed, wide, restarts = seed + 1, True, 1
                continue
            if user_nev:
                break
            # the converged set had too few oscillating modes: grow nev in proportion
            nev = max(nev + per_mode * (n_modes - found) + per_mode, -(-nconv * (n_modes + 1) // max(found, 1)))
        ok = found >= n_modes
        why = enum_name(type(solver).ConvergedReason, reason)
        self._last = {"nev": wanted, "nconv": nconv, "reason": why, "iterations": solver.getIterationNumber(),
                      "retries": attempt, "restarted": bool(restarts)}  # fmt: skip
        msg = "" if ok else (f"{found} of the {n_modes} frequencies asked converged ({nconv} of {wanted} "
                             f"eigenvalues, {why}" + (", also from another initial vector with a larger ncv" if restarts
                                                       else "") + ")")
        return lam, X, ok, msg

    def _dims(self, kind: str, nev: int, size: int, wide: bool = False) -> dict:
        """ncv and mpd for ``setDimensions`` (which resets what it is not given to PETSC_DEFAULT).

        The user's values if set; otherwise an even ncv = max(nev + 16, 2·nev). SLEPc's default
        nev + 15 is odd for our even nev, and measured on beam QEPs an odd ncv makes real
        TOAR stall for tens of restarts (a conjugate pair is split at every restart) while an
        even one converges in 1-3 (docs/engine.md). ``wide``: twice that (a second attempt).
        """
        out = {k: int(float(self._values[f"{kind}_{k}"])) for k in ("ncv", "mpd") if f"{kind}_{k}" in self._user}
        if "ncv" not in out:
            ncv = max(nev + 16, 2 * nev) + (nev % 2)
            out["ncv"] = min(2 * ncv if wide else ncv, size)
        return out

    def _scale(self, pep, hint):
        """Set the PEP's scalar scale factor α ≈ |λ₁|; returns (α, where it came from)."""
        if _SCALE_KEYS & self._user:
            return None, "options"
        # No memory of earlier points here: a point's result must not depend on which rank
        # solved it or what it solved before (the sweep passes the previous speed's |λ₁|).
        if hint is not None and np.isfinite(hint) and hint > 0:
            alpha, source = hint, "hint"
        else:
            alpha, source = self._estimate_lambda1(pep), "estimate"
        if alpha is None:
            pep.setScale(SLEPc.PEP.Scale.SCALAR)  # SLEPc's norm-based factor, as a last resort
            return None, "slepc"
        pep.setScale(SLEPc.PEP.Scale.SCALAR, alpha=float(alpha))
        return float(alpha), source

    def _estimate_lambda1(self, pep, its: int = 4) -> float | None:
        """|λ₁| by a few steps of inverse iteration on K⁻¹M (C ignored: an order of magnitude is enough).

        TOAR with shift-and-invert about 0 factorizes P(0) = K in ``setUp`` and its solve reuses
        that factorization, so the estimate costs a few triangular solves. Other types get a
        KSP of their own (3.18's Linear refuses a scale factor changed after ``setUp``).
        """
        M = self._ops.M
        st = pep.getST()
        if pep.getType() == SLEPc.PEP.Type.TOAR and st.getType() == SLEPc.ST.Type.SINVERT and pep.getTarget() == 0:
            pep.setUp()
            ksp = st.getKSP()
        else:
            ksp = self._own_ksp()
        x = M.createVecRight()
        x.set(1.0)
        Mx, y = x.duplicate(), x.duplicate()
        est = None
        for _ in range(its):
            M.mult(x, Mx)
            ksp.solve(Mx, y)
            num, den = x.dot(Mx), y.dot(Mx)
            if den == 0 or not np.isfinite(den):
                break
            est = float(np.sqrt(abs(num / den)))
            y.copy(x)
            x.scale(1.0 / x.norm())
        for v in (x, Mx, y):
            v.destroy()
        return est

    def _own_ksp(self) -> PETSc.KSP:
        if self._ksp is None:
            self._ksp = PETSc.KSP().create(PETSc.COMM_SELF)
            self._ksp.setType("preonly")
            pc = self._ksp.getPC()
            pc.setType("lu")
            pc.setFactorSolverType(self._values.get("st_pc_factor_mat_solver_type", LU_PACKAGE))
        self._ksp.setOperators(self._ops.K)  # values changed in place: refactorized on solve
        return self._ksp


def _pairs(solver, ops: PetscOperators):
    """Every converged (value, vector) of a PEP or EPS.

    SLEPc counts as converged a leading run of the sorted Ritz values, so the set is the
    nearest to the target without gaps; all of it is returned, not only the first nev.
    """
    nconv = solver.getConverged()
    xr, xi = ops.M.createVecs()
    values = np.empty(nconv, dtype=complex)
    X = np.empty((ops.n, nconv), dtype=complex)
    for i in range(nconv):
        values[i] = solver.getEigenpair(i, xr, xi)
        X[:, i] = xr.getArray(readonly=True) + 1j * xi.getArray(readonly=True)
    xr.destroy()
    xi.destroy()
    return values, X, nconv


def _count_oscillating(lam: np.ndarray, imag_tol: float) -> int:
    """Number of eigenvalues with Im λ > imag_tol·|λ| (one per frequency)."""
    return int(np.count_nonzero(lam.imag > imag_tol * np.abs(lam)))
