"""The run-up in time: the elastic coordinates along a prescribed crank history integrated by PETSc
TS (docs/theory.md §21).

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
    """About 2π/(|Ω|max · steps) (s), a whole number of steps in the duration (at constant speed a
    revolution is exactly ``steps_per_revolution`` steps)."""
    w = max(abs(history.w0), abs(history.w1))
    return history.duration / max(1, round(history.duration * w / TWO_PI * steps_per_revolution))


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


def is_adaptive(prefix: str = OPTIONS_PREFIX) -> bool:
    """Whether the options database asks for adaptive steps (``-<prefix>ts_adapt_type`` other than none)."""
    from petsc4py import PETSc

    kind = PETSc.Options(prefix).getString("ts_adapt_type", "none")
    return kind.lower() != "none"


class Integration:
    """``system`` (a MotionSystem) along ``history`` (a CrankHistory) by PETSc TS, in segments of at
    most ``segment_steps`` steps, each a fresh TS from the state where the last one ended (so that a
    run resumed from a checkpoint takes the same steps and gives the same numbers bit for bit). With
    fixed steps (the default) the run takes N = ⌈duration/dt⌉ steps of ``dt``; with adaptive steps it
    runs to the duration (the last step matched). See the module docstring."""

    def __init__(self, system, history, *, steps_per_revolution: int = DEFAULT_STEPS_PER_REVOLUTION,
                 dt: float | None = None, start: str = "static", on_revolution=None, progress=None,
                 prefix: str = OPTIONS_PREFIX):
        self.system, self.history, self.prefix, self.progress = system, history, prefix, progress
        self.dt = default_step(history, steps_per_revolution) if dt is None else float(dt)
        self.adaptive = is_adaptive(prefix)
        self.total = int(np.ceil(history.duration / self.dt - 1e-9))
        self.t, self.steps, self.rejected, self.ts_type = 0.0, 0, 0, "alpha2"
        self.residual = _Residual(system, history)
        self.out = Runup(history, 0, self.ts_type)
        self.gather = _Gather(system, history, self.out, on_revolution, 0)
        self.state = initial_state(system, history, start)
        self.gather.add(0.0, *(np.array(x, float) for x in self.state))

    @property
    def done(self) -> bool:
        if self.adaptive:
            return self.t >= self.history.duration * (1.0 - 1e-12)
        return self.steps >= self.total

    def advance(self, max_steps: int) -> None:
        """At most ``max_steps`` more steps (fewer at the end), from the current state."""
        from petsc4py import PETSc

        n = self.system.n
        remaining = max_steps if self.adaptive else min(max_steps, self.total - self.steps)
        ts = make_ts(self.residual, n, self.dt, self.history.duration if self.adaptive else 2.0 * self.history.duration
                     + 1.0, self.prefix)
        ts.setTime(self.t)
        ts.setMaxSteps(int(remaining))
        u, v = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF), PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        u.setArray(self.state[0])
        v.setArray(self.state[1])
        ts.setSolution2(u, v)

        def post_step(ts):
            U, V = ts.getSolution2()  # writable access would restart the step
            t = ts.getTime()
            self.gather.add(t, U.getArray(readonly=True).copy(), V.getArray(readonly=True).copy())
            if self.progress is not None:
                self.progress(t, self.history.duration)

        ts.setPostStep(post_step)
        ts.solve(u)
        U, V = ts.getSolution2()
        self.t, self.state = ts.getTime(), (U.getArray(readonly=True).copy(), V.getArray(readonly=True).copy())
        self.steps += ts.getStepNumber()
        self.rejected += ts.getStepRejections()
        self.ts_type = ts.getType()
        self.dt = self.dt if not self.adaptive else ts.getTimeStep()

    def run(self, segment_steps: int = 2**31 - 1, after_segment=None) -> Runup:
        """Segments until the end; ``after_segment(self)`` after each (a checkpoint)."""
        while not self.done:
            self.advance(segment_steps)
            if self.done:
                self.gather.close()
            if after_segment is not None:
                after_segment(self)
        self.out.steps, self.out.rejected, self.out.ts_type = self.steps, self.rejected, self.ts_type
        return self.out

    # -- checkpoints -----------------------------------------------------------------------
    def checkpoint(self) -> dict:
        """The arrays that continue this run: time, steps, state and the open revolution's samples."""
        buf, n = self.gather.buf, self.system.n
        return {"t": self.t, "steps": self.steps, "rejected": self.rejected, "dt": self.dt,
                "revolution": self.gather.index, "q": self.state[0], "q_dot": self.state[1],
                "buffer_t": np.array([b[0] for b in buf]), "buffer_q": np.array([b[1] for b in buf]).reshape(len(buf), n),
                "buffer_q_dot": np.array([b[2] for b in buf]).reshape(len(buf), n)}

    def restore(self, cp: dict) -> None:
        """Continue from :meth:`checkpoint`'s arrays (the revolutions before it already reported)."""
        self.t, self.steps, self.rejected, self.dt = float(cp["t"]), int(cp["steps"]), int(cp["rejected"]), float(cp["dt"])
        self.state = (np.array(cp["q"], float), np.array(cp["q_dot"], float))
        self.gather.index = int(cp["revolution"])
        self.gather.buf = [(float(t), np.array(a), np.array(b)) for t, a, b in
                           zip(cp["buffer_t"], cp["buffer_q"], cp["buffer_q_dot"])]


def integrate(system, history, *, segment_steps: int = 2**31 - 1, **options) -> Runup:
    """One :class:`Integration` run to the end (``options`` as there)."""
    return Integration(system, history, **options).run(segment_steps)
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
        if len(self.buf) > 1:  # the last, possibly partial, revolution
            self.flush()
        self.buf = []
