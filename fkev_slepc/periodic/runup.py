"""The run-up in time: the elastic coordinates along a prescribed crank history integrated by PETSc
TS (docs/theory.md §20).

``integrate(system, history, ...) -> Runup``: the second-order system of a
:class:`~fkev_slepc.periodic.motion.MotionSystem`, M q̈ + C q̇ + K q = f, as the I2 residual
F(t, q, q̇, q̈) = M q̈ + C q̇ + K q − f with its Jacobian shift_a M + shift_v C + K (dense PETSc
matrices), integrated by ``TSALPHA2`` (generalised-α) by default with fixed steps of 2π/(|Ω|max ·
``steps_per_revolution``); the TS type, its steps, adaptivity and solvers can be changed through the
PETSc options database under ``options_prefix`` (``-fkev_runup_ts_type``, ``-fkev_runup_ts_adapt_type
basic``, ``-fkev_runup_ts_alpha_radius``, …; ts.setFromOptions() comes last). The defaults are a
Newton solver with a basic line search, one step of an exact LU (the system is linear: one
iteration converges; ``ksponly`` is not used, it does not solve TSALPHA2's stage correctly in
PETSc 3.18).

The start is the rest deflection (``start="static"``: q₀ = K⁻¹f at the first instant, q̇₀ = 0) or
zero. A post-step hook gathers the samples of each crank revolution; when a revolution ends
``on_revolution(Revolution)`` is called with its samples (time, angle, q, q̇ on the model's DOFs),
and the last revolution's samples and every revolution's end state are kept. ``progress(t,
duration)`` is called after each step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fkev_slepc.periodic.motion import TWO_PI

DEFAULT_STEPS_PER_REVOLUTION = 256
OPTIONS_PREFIX = "fkev_runup_"
STARTS = ("static", "zero")


@dataclass
class Revolution:
    """The samples of one crank revolution (the steps whose time falls in it, its start included)."""

    index: int
    t: np.ndarray  # (k,) s
    theta: np.ndarray  # (k,) rad
    eta: np.ndarray  # (k, n) the system's coordinates
    eta_dot: np.ndarray  # (k, n)
    q: np.ndarray  # (k, n_free) the model's DOFs


@dataclass
class Runup:
    """What ``integrate`` returns: the end state of every revolution and the last revolution."""

    history: object
    steps: int
    ts_type: str
    end_t: list = field(default_factory=list)  # time of each revolution's end, s
    end_state: list = field(default_factory=list)  # (η, η̇) at each revolution's end
    last: Revolution | None = None
    rejected: int = 0


def _mat(n: int):
    from petsc4py import PETSc

    A = PETSc.Mat().createDense((n, n), comm=PETSc.COMM_SELF)
    A.setUp()
    return A


class _Residual:
    """F and its Jacobian of a MotionSystem along a history; the coefficients of one time cached."""

    def __init__(self, system, history):
        self.system, self.history = system, history
        self._cache = {}  # a step's stage times (TSALPHA2 evaluates F and J at t + α_f dt, then t + dt)
        self.rows = np.arange(system.n, dtype=np.int32)

    def coefficients(self, t: float):
        c = self._cache.get(t)
        if c is None:
            if len(self._cache) >= 4:
                self._cache.clear()
            h = self.history
            c = self._cache[t] = self.system.at(float(h.angle(t)), float(h.speed(t)), h.accel)
        return c

    def function(self, ts, t, U, V, A, F):
        M, C, K, f = self.coefficients(t)
        F.setArray(M @ A.getArray(readonly=True) + C @ V.getArray(readonly=True) + K @ U.getArray(readonly=True) - f)

    def jacobian(self, ts, t, U, V, A, shift_v, shift_a, J, P):
        M, C, K, _ = self.coefficients(t)
        P.setValues(self.rows, self.rows, (shift_a * M + shift_v * C + K).ravel())
        P.assemble()
        if J != P:
            J.assemble()


def initial_state(system, history, start: str = "static"):
    """(q₀, q̇₀) of the run: the quasi-static deflection K⁻¹f at t = 0 with q̇₀ = 0, or zero."""
    if start not in STARTS:
        raise ValueError(f"start: one of {', '.join(STARTS)} (got {start!r})")
    n = system.n
    if start == "zero":
        return np.zeros(n), np.zeros(n)
    _, _, K, f = system.at(float(history.angle(0.0)), float(history.speed(0.0)), history.accel)
    return np.linalg.solve(K, f), np.zeros(n)


def default_step(history, steps_per_revolution: int = DEFAULT_STEPS_PER_REVOLUTION) -> float:
    """2π/(|Ω|max · steps) (s); at constant speed the revolution is a whole number of steps."""
    w = max(abs(history.w0), abs(history.w1))
    if history.constant_speed:
        return history.duration / (round(history.duration * w / TWO_PI * steps_per_revolution))
    return TWO_PI / (w * steps_per_revolution)


def make_ts(residual, n: int, dt: float, duration: float, prefix: str = OPTIONS_PREFIX):
    """The TS (TSALPHA2, fixed step ``dt``, to ``duration``), then the options database's settings."""
    from petsc4py import PETSc

    ts = PETSc.TS().create(comm=PETSc.COMM_SELF)
    ts.setOptionsPrefix(prefix)
    ts.setType(PETSc.TS.Type.ALPHA2)
    ts.setI2Function(residual.function, PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF))
    ts.setI2Jacobian(residual.jacobian, _mat(n))
    ts.setTime(0.0)
    ts.setTimeStep(dt)
    ts.setMaxTime(duration)
    ts.setMaxSteps(2**31 - 1)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
    snes = ts.getSNES()
    snes.setType("newtonls")
    snes.getKSP().setType("preonly")
    snes.getKSP().getPC().setType("lu")
    opts = PETSc.Options(prefix)
    for key, value in (("ts_adapt_type", "none"), ("snes_linesearch_type", "basic")):
        if not opts.hasName(key):  # fixed steps unless asked (whole revolutions at constant speed)
            opts.setValue(key, value)
    ts.setFromOptions()
    return ts


def integrate(system, history, *, steps_per_revolution: int = DEFAULT_STEPS_PER_REVOLUTION, dt: float | None = None,
              start: str = "static", state=None, t0: float = 0.0, first_revolution: int = 0,
              on_revolution=None, progress=None, prefix: str = OPTIONS_PREFIX, until: float | None = None) -> Runup:
    """Integrate ``system`` (a MotionSystem) along ``history`` (a CrankHistory); see the module
    docstring. ``state`` (η, η̇) at time ``t0`` (the start of revolution ``first_revolution``)
    continues a run (a checkpoint) instead of ``start``; ``until`` stops at that time (s)."""
    residual = _Residual(system, history)
    n = system.n
    step = default_step(history, steps_per_revolution) if dt is None else float(dt)
    end = history.duration if until is None else min(float(until), history.duration)
    ts = make_ts(residual, n, step, end, prefix)
    ts.setTime(float(t0))
    q0, v0 = initial_state(system, history, start) if state is None else state
    from petsc4py import PETSc

    u, v = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF), PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
    u.setArray(q0)
    v.setArray(v0)
    ts.setSolution2(u, v)
    out = Runup(history, 0, ts.getType())
    gather = _Gather(system, history, out, on_revolution, first_revolution)
    gather.add(float(t0), np.array(q0, float), np.array(v0, float))

    def post_step(ts):
        U, V = ts.getSolution2()
        t = ts.getTime()
        gather.add(t, U.getArray(readonly=True).copy(), V.getArray(readonly=True).copy())  # writable access would restart the step
        if progress is not None:
            progress(t, history.duration)

    ts.setPostStep(post_step)
    ts.solve(u)
    gather.close()
    out.steps, out.rejected = ts.getStepNumber(), ts.getStepRejections()
    return out


class _Gather:
    """Samples grouped by revolution (a sample at a revolution's end closes it and opens the next)."""

    def __init__(self, system, history, out: Runup, on_revolution, first: int):
        self.system, self.history, self.out, self.callback = system, history, out, on_revolution
        self.index, self.buf = first, []

    def revolution_of(self, t: float) -> int:
        r = float(self.history.revolutions(t))
        return int(np.floor(r + 1e-9))  # a sample on a revolution's end begins the next one

    def add(self, t, eta, eta_dot):
        r = self.revolution_of(t)
        if self.buf and r > self.index:
            self.buf.append((t, eta, eta_dot))  # the end sample belongs to both revolutions
            self.flush()
            self.index = r
        self.buf.append((t, eta, eta_dot))

    def flush(self):
        t = np.array([b[0] for b in self.buf])
        eta = np.array([b[1] for b in self.buf])
        eta_dot = np.array([b[2] for b in self.buf])
        theta = self.history.angle(t)
        rev = Revolution(self.index, t, theta, eta, eta_dot, self.system.expand(theta, eta))
        self.out.end_t.append(float(t[-1]))
        self.out.end_state.append((eta[-1].copy(), eta_dot[-1].copy()))
        self.out.last = rev
        if self.callback is not None:
            self.callback(rev)
        self.buf = []

    def close(self):
        if len(self.buf) > 1:
            self.flush()
