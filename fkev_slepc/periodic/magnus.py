"""Monodromy of a linear periodic system, its Floquet multipliers, and the particular response.

The system is the first-order form in the independent variable θ (for a linkage at constant
crank speed Ω, θ is the crank angle and ' = d/dθ; docs/theory.md §18)

    x'(θ) = A(θ) x(θ) + b(θ),        A(θ + P) = A(θ),  b(θ + P) = b(θ),

or the second-order form M(θ) q'' + C(θ) q' + K(θ) q = f(θ), whose state is x = (q, q').

Integrator: the Magnus expansion of order 4 (two Gauss–Legendre nodes per step) or 6 (three
nodes), one matrix exponential per step, uniform steps over one period. It is exact for constant
A whatever the step (a stiff, fast-oscillating mode costs nothing by itself: only the variation of
A over a step is resolved), and it is structure-preserving: every step is the exponential of an
element of the Lie algebra the generators span (for a Hamiltonian A in canonical coordinates
each step is symplectic, for a trace-free A it has det 1). The forcing rides along as an extra
column of the generator, [[A, b], [0, 0]], so the particular solution is integrated by the same
method and order. The error is estimated by step doubling: the monodromy at N steps and at N/2,
``phi_error = ‖Φ_N - Φ_{N/2}‖_F / ((2^p - 1) ‖Φ_N‖_F)`` (p the order) and
``error = max |μ_N - μ_{N/2}| / (2^p - 1)`` over matched multipliers; with ``steps=None`` N
doubles until ``phi_error`` is below ``tol``.

**Pre-asymptotic levels** (``mu_tol``, the linkage Floquet criterion; docs/engine.md "Step count"):
d = max|μ_N - μ_{N/2}| is divided by 2^p - 1 only where d_{N/2}/d_N is within 4× of 2^p, else
stated (:func:`step_doubling_error`); the first level runs N/4 for that rate only where d itself is
too large and d/(2^p - 1) would do. N doubles until the estimate, over max(1, max|μ|), is <= ``mu_tol``.
The caller's ``measure`` says what d compares (default every multiplier, matched; the linkage
Floquet: the moduli and the low Floquet frequencies, which is what its results use).

Public API (shapes with n the state size, k the number of θ values; θ in the caller's units,
radians of crank angle for a linkage; exponents in 1/[θ])

``monodromy(generator, period=2π, *, forcing=None, order=6, steps=None, tol=1e-10, mu_tol=None,
start=0.0, max_steps=2**16, comm=None, measure=...) -> Monodromy`` (``comm``: steps over MPI ranks)
    ``generator(theta)``: theta (k,) -> A (k, n, n), vectorised over θ; without a forcing, its
    ``magnus_step(theta (s, nodes), h, order) -> Ω (s, n, n)`` if it has one (periodic/hamiltonian.py).
    ``forcing(theta)``: theta (k,) -> b (k, n) or (k, n, m) for m load cases; optional.
``Monodromy`` (frozen dataclass)
    ``phi`` (n, n) Φ = x(start + P) for x(start) = I; ``multipliers`` (n,) complex, sorted by
    decreasing |μ|; ``exponents`` principal log(μ)/P (Im modulo 2π/P); ``max_abs`` max |μ| (per
    period: per revolution for a linkage); ``growth_rate`` log(max|μ|)/P; ``error`` the estimated
    absolute multiplier error (of what ``measure`` compares), ``second_error`` its second measure's,
    ``phi_error`` the relative error of Φ (Frobenius); ``steps``, ``order``, ``period``, ``start``,
    ``converged``; ``particular`` (n,) or (n, m): x(start + P) from x(start) = 0 under the forcing
    (None without), ``particular_error`` its relative step-doubling estimate.
``exponential_monodromy(A, period=2π, start=0.0) -> (Monodromy, λ, X)``
    the monodromy exp(P A) of a constant generator from its eigen-decomposition (``steps`` 1,
    ``order`` 0: exact up to the eigenvalues' round-off, which ``error`` bounds).
``trajectory(generator, x0, thetas, *, forcing=None, order=6, steps) -> x (len(thetas), n[, m])``
    the state at the given θ (increasing, first = start) from x(thetas[0]) = x0, by the same
    Magnus steps (``steps`` per period P = thetas[-1] - thetas[0] unless ``period`` is given).
``second_order(coefficients) -> generator``, ``second_order_forcing(mass, load)``: adapters for
    M q'' + C q' + K q = f, (M, C, K) (k, n, n) dense; A = [[0, I], [-M⁻¹K, -M⁻¹C]] (``state_matrix``), b = [0, M⁻¹f].
``match_multipliers(a, b) -> (i, j)``: the pairing minimising Σ|a_i - b_j| (Hungarian).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
from scipy.optimize import linear_sum_assignment

# Gauss-Legendre nodes on [0, 1]
_NODES = {
    4: np.array([0.5 - np.sqrt(3.0) / 6.0, 0.5 + np.sqrt(3.0) / 6.0]),
    6: np.array([0.5 - np.sqrt(15.0) / 10.0, 0.5, 0.5 + np.sqrt(15.0) / 10.0]),
}
# step exponentials per block: a block of (steps x nodes) generators of ~ this many doubles, 4 MB,
# stays in cache (2x faster than 64 MB on Bahgat–Willmert at 4 el/link; docs/engine.md "Cheaper steps")
_BLOCK_DOUBLES = 2**19


def magnus_generators(A: np.ndarray, h: float, order: int, commutator=lambda a, b: a @ b - b @ a) -> np.ndarray:
    """Ω of each step from the generator at the step's Gauss nodes: A (s, nodes, n, n) -> (s, n, n)
    (or any stack, axis 1 the nodes, of Lie-algebra elements with its ``commutator``: hamiltonian.py's).

    Order 4: Ω = h/2 (A₁ + A₂) + √3 h²/12 [A₂, A₁]. Order 6 (Blanes, Casas, Oteo & Ros, Phys.
    Rep. 470 (2009), §5.2): with a₁ = h A₂, a₂ = √15 h/3 (A₃ - A₁), a₃ = 10 h/3 (A₃ - 2A₂ + A₁),
    c₁ = [a₁, a₂], c₂ = -[a₁, 2a₃ + c₁]/60, Ω = a₁ + a₃/12 + [-20a₁ - a₃ + c₁, a₂ + c₂]/240."""
    if order == 4:
        A1, A2 = A[:, 0], A[:, 1]
        return 0.5 * h * (A1 + A2) + (np.sqrt(3.0) * h * h / 12.0) * commutator(A2, A1)
    if order == 6:
        A1, A2, A3 = A[:, 0], A[:, 1], A[:, 2]
        a1 = h * A2
        a2 = (np.sqrt(15.0) * h / 3.0) * (A3 - A1)
        a3 = (10.0 * h / 3.0) * (A3 - 2.0 * A2 + A1)
        c1 = commutator(a1, a2)
        c2 = -commutator(a1, 2.0 * a3 + c1) / 60.0
        return a1 + a3 / 12.0 + commutator(-20.0 * a1 - a3 + c1, a2 + c2) / 240.0
    raise ValueError(f"order: the Magnus integrator has orders 4 and 6, not {order!r}")


def _augmented(generator, forcing, theta):
    """Generator (k, n[+m], n[+m]) at θ: A alone, or [[A, b], [0, 0]] with the forcing columns."""
    A = np.asarray(generator(theta), dtype=float)
    if A.ndim != 3 or A.shape[0] != theta.size or A.shape[1] != A.shape[2]:
        raise ValueError(f"generator: must return shape ({theta.size}, n, n), got {A.shape}")
    if forcing is None:
        return A, 0
    b = np.asarray(forcing(theta), dtype=float)
    if b.ndim == 2:
        b = b[:, :, None]
    if b.shape[:2] != A.shape[:2]:
        raise ValueError(f"forcing: must return shape ({theta.size}, {A.shape[1]}[, m]), got {b.shape}")
    k, n, m = b.shape
    G = np.zeros((k, n + m, n + m))
    G[:, :n, :n] = A
    G[:, :n, n:] = b
    return G, m


def step_exponentials(generator, a: float, b: float, steps: int, *, forcing=None, order: int = 6):
    """Yield (first step index, E) blocks: E (s, N, N) the Magnus step maps over [a, b] in
    ``steps`` uniform steps, N = n (+ m with a forcing, the augmented map [[Φₖ, pₖ], [0, I]])."""
    c = _NODES.get(order)
    if c is None:
        raise ValueError(f"order: the Magnus integrator has orders 4 and 6, not {order!r}")
    h = (b - a) / steps
    probe, m = _augmented(generator, forcing, np.array([a]))
    size = probe.shape[1]
    block = max(1, min(steps, _BLOCK_DOUBLES // (c.size * size * size)))
    own = getattr(generator, "magnus_step", None) if forcing is None else None  # a structured Ω (hamiltonian.py)
    for s0 in range(0, steps, block):
        s = np.arange(s0, min(steps, s0 + block))
        theta = (a + h * (s[:, None] + c[None, :])).ravel()
        yield s0, la.expm(own(theta.reshape(s.size, c.size), h, order) if own else magnus_generators(
            _augmented(generator, forcing, theta)[0].reshape(s.size, c.size, size, size), h, order))


def _product(generator, a, b, steps, forcing, order, comm=None, progress=None):
    """Φ (and the particular columns) over [a, b]: the ordered product of the step maps
    (``progress(steps done, steps)`` after each block).

    With an MPI ``comm`` of several ranks the steps are split into one contiguous segment per rank
    (the same step length, segment k starting at a + h·(first step of k)); each rank multiplies its
    own segment and the segment propagators are multiplied in order on every rank (exact up to
    round-off: the same steps, grouped differently)."""
    if comm is not None and comm.size > 1:
        h = (b - a) / steps
        counts = np.full(comm.size, steps // comm.size)
        counts[: steps % comm.size] += 1
        first = np.concatenate([[0], np.cumsum(counts)])
        mine = None
        if counts[comm.rank]:
            lo, hi = first[comm.rank], first[comm.rank + 1]
            mine = _product(generator, a + h * lo, a + h * hi, int(hi - lo), forcing, order,
                            progress=progress if comm.rank == 0 else None)
        total = None
        for part in comm.allgather(mine):
            if part is not None:
                total = part if total is None else part @ total
        return total
    total = None
    for s0, E in step_exponentials(generator, a, b, steps, forcing=forcing, order=order):
        if progress is not None:
            progress(s0 + E.shape[0], steps)
        # pairwise (tree) products inside a block keep the Python loop at log2(block) levels;
        # later steps multiply from the left
        while E.shape[0] > 1:
            if E.shape[0] % 2:
                E = np.concatenate([E[:-2], (E[-1] @ E[-2])[None]], axis=0)
                continue
            E = E[1::2] @ E[0::2]
        total = E[0] if total is None else E[0] @ total
    return total


def multiplier_spectrum(phi):
    """The default level spectrum of :func:`monodromy`: (eigenvalues of Φ, None)."""
    return la.eigvals(phi), None


def multiplier_change(fine, coarse) -> tuple[float, float]:
    """The default level change of :func:`monodromy`: (max |μ - μ_coarse|, matched; 0.0: no second measure)."""
    i, j = match_multipliers(fine[0], coarse[0])
    return float(np.max(np.abs(fine[0][i] - coarse[0][j]))), 0.0


def match_multipliers(a, b):
    """Indices (i, j) pairing a[i] with b[j] to minimise Σ|a_i - b_j| (Hungarian assignment)."""
    a, b = np.asarray(a), np.asarray(b)
    return linear_sum_assignment(np.abs(a[:, None] - b[None, :]))


@dataclass(frozen=True)
class Monodromy:
    """One period's monodromy Φ and its Floquet multipliers (see the module docstring)."""

    phi: np.ndarray
    multipliers: np.ndarray
    period: float
    start: float
    steps: int
    order: int
    error: float
    phi_error: float
    converged: bool
    particular: np.ndarray | None = None
    particular_error: float | None = None
    second_error: float = 0.0  # the step-doubling estimate of the ``measure``'s second (relative) change
    matched_error: float = 0.0  # ... of its third (absolute; the linkage Floquet: every multiplier matched)

    @property
    def exponents(self) -> np.ndarray:
        """Principal Floquet exponents log(μ)/P (1/[θ]; Im defined modulo 2π/P)."""
        return np.log(self.multipliers.astype(complex)) / self.period

    @property
    def max_abs(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    @property
    def growth_rate(self) -> float:
        """log(max |μ|)/P, the largest real part of the Floquet exponents (1/[θ])."""
        return float(np.log(self.max_abs) / self.period)


def _split(total, n, m):
    if m == 0:
        return total, None
    p = total[:n, n:]
    return total[:n, :n], (p[:, 0] if m == 1 else p)


def step_doubling_error(d: float, d_before: float | None, order: int) -> float:
    """The N-step level's error from its change ``d`` from N/2 and N/2's change ``d_before`` from N/4
    (None: unknown): d/(2^p - 1) where d_before/d is 2^p within 4× (or unknown), else d (module docstring)."""
    rate = 2.0**order
    if d_before is None or d == 0.0 or rate / 4.0 <= d_before / d <= 4.0 * rate:
        return d / (rate - 1.0)
    return d


def monodromy(generator, period: float = 2.0 * np.pi, *, forcing=None, order: int = 6,
              steps: int | None = None, tol: float = 1e-10, mu_tol: float | None = None, start: float = 0.0,
              max_steps: int = 2**16, min_steps: int = 16, comm=None, progress=None,
              measure=(multiplier_spectrum, multiplier_change), second_tol: float | None = None,
              matched_tol=np.inf) -> Monodromy:
    """Monodromy of x' = A(θ) x (+ b(θ)) over [start, start + period] (see the module docstring).

    ``steps`` fixes the number of uniform steps (even; the estimate then uses steps/2 as well);
    ``steps=None`` starts at ``min_steps`` (rounded up to a power of 2) and doubles until the estimated relative error of Φ <= ``tol``
    (with ``mu_tol``: the multiplier error of :func:`step_doubling_error`, relative to
    max(1, max|μ|), <= ``mu_tol``) or ``max_steps`` is reached (then ``converged`` is False). The multiplier estimate
    ``error`` follows Φ's for simple multipliers (times their condition number) but only as its
    square root at a defective one (a double multiplier ±1 on a transition curve).

    ``comm``: an MPI communicator whose ranks share the steps of every product (collective: every
    rank calls with the same arguments and gets the same result; see ``_product``).
    ``progress(steps done, steps)``: called after each block of step exponentials of every run.
    ``measure`` = (spectrum(Φ) -> (μ, extra), change(fine, coarse) -> (d_μ, d_2[, d_3])): what ``mu_tol``
    compares between levels: d_μ absolute (estimate ``error``, against ``mu_tol``·max(1, max|μ|)),
    d_2 relative (``second_error``, against ``second_tol``, default ``mu_tol``), d_3 absolute
    (``matched_error``, against ``matched_tol``, or ``matched_tol(μ)``); default every multiplier matched, no d_2 (the
    linkage Floquet: the moduli, the low frequencies and every multiplier matched, floquet.py)."""
    if not np.isfinite(period) or period <= 0.0:
        raise ValueError(f"period: must be a positive finite number, got {period!r}")
    if steps is not None and (int(steps) != steps or steps < 2 or steps % 2):
        raise ValueError(f"steps: must be an even integer >= 2, got {steps!r}")
    a, b = float(start), float(start) + float(period)
    n = np.asarray(generator(np.array([a]))).shape[-1]
    fb = None if forcing is None else np.asarray(forcing(np.array([a])))
    m = 0 if fb is None else (1 if fb.ndim == 2 else fb.shape[2])

    spectrum, change = measure
    scale = 2.0**order - 1.0
    N = int(steps) if steps is not None else int(2 ** np.ceil(np.log2(max(2, min_steps))))

    def level(n_steps):  # (phi, particular, spectrum or None where Φ is not finite)
        with np.errstate(over="ignore", invalid="ignore"):  # a coarse level may blow up: handled as not finite
            phi, part = _split(_product(generator, a, b, n_steps, forcing, order, comm, progress), n, m)
        return phi, part, (spectrum(phi) if np.all(np.isfinite(phi)) else None)

    inf2, before = (np.inf,) * 3, (None,) * 3
    guard = mu_tol is not None and steps is None and N >= 8  # the N/4 level, for the rate check, when needed
    tol2 = mu_tol if second_tol is None else second_tol
    coarse = level(N // 2)

    def judged(d, before, mu):  # ((err, err2, err3), ok) of a level's change d given the change before it
        errs = tuple(step_doubling_error(x, x_before, order) for x, x_before in zip(d, before))
        lim = (np.inf if mu_tol is None else mu_tol * max(1.0, float(np.max(np.abs(mu)))), tol2,
               matched_tol(mu) if callable(matched_tol) else matched_tol)
        return errs, (phi_err <= tol if mu_tol is None else all(e <= t for e, t in zip(errs, lim)))

    def change3(f, c):  # the measure's changes, three (d_3 = 0 where it has two)
        return (tuple(change(f[2], c[2])) + (0.0,))[:3] if f[2] is not None and c[2] is not None else inf2

    while True:
        fine = level(N)
        phi_err = float(np.linalg.norm(fine[0] - coarse[0])
                        / (scale * max(np.linalg.norm(fine[0]), 1e-300)))
        finite = fine[2] is not None and coarse[2] is not None
        d = change3(fine, coarse)
        mu = fine[2][0] if finite else np.full(n, np.nan)
        if guard:  # the first level: undivided, a bound, needs no N/4; the rate only if it would decide
            guard, (errs, ok) = False, judged(d, inf2, mu)
            if not ok and judged(d, (None,) * 3, mu)[1]:
                before = change3(coarse, level(N // 4))
                errs, ok = judged(d, before, mu)
        else:
            errs, ok = judged(d, before, mu)
        if steps is not None or ok or 2 * N > max_steps:
            break
        coarse, N, before = fine, 2 * N, d
    if not finite:
        raise ValueError(f"steps: {N} steps (and {N // 2} for the error estimate) do not resolve "
                         f"the generator over the period: use more steps (or steps=None)")
    phi, part = fine[0], fine[1]
    part_err = None if part is None else float(np.linalg.norm(part - coarse[1])
                                               / (scale * max(np.linalg.norm(part), 1e-300)))
    order_ = np.argsort(-np.abs(mu), kind="stable")
    return Monodromy(phi=phi, multipliers=mu[order_], period=float(period), start=a, steps=N,
                     order=order, error=errs[0], phi_error=phi_err,
                     converged=bool(steps is not None or ok), particular=part,
                     particular_error=part_err, second_error=errs[1], matched_error=errs[2])


def exponential_monodromy(A: np.ndarray, period: float = 2.0 * np.pi, start: float = 0.0):
    """(Monodromy, λ, X) of a constant generator A (n, n): Φ = exp(P A) = X diag(e^{Pλ}) X⁻¹ from
    the eigen-decomposition A X = X diag(λ), so μ = e^{Pλ} to the eigenvalues' accuracy (a norm
    of A in the thousands costs expm its digits, the eigenvalues keep them). ``error``: the
    first-order bound P |μ| ε ‖A‖₂ κ(λ) with κ the eigenvalue condition numbers."""
    lam, Y, X = la.eig(A, left=True, right=True)
    mu = np.exp(period * lam)
    phi = np.real((X * mu) @ np.linalg.inv(X))
    kappa = np.linalg.norm(Y, axis=0) * np.linalg.norm(X, axis=0) / np.abs(np.sum(Y.conj() * X, axis=0))
    err = float(np.max(period * np.abs(mu) * np.finfo(float).eps * np.linalg.norm(A, 2) * kappa))
    order_ = np.argsort(-np.abs(mu), kind="stable")
    mono = Monodromy(phi=phi, multipliers=mu[order_], period=float(period), start=float(start), steps=1, order=0,
                     error=err, phi_error=err / max(float(np.max(np.abs(mu))), 1e-300), converged=True)
    return mono, lam, X


def trajectory(generator, x0, thetas, *, forcing=None, order: int = 6, steps: int = 256,
               period: float | None = None) -> np.ndarray:
    """State at ``thetas`` (increasing) from x(thetas[0]) = x0 by Magnus steps of length
    period/steps (period defaults to thetas[-1] - thetas[0]); each θ is reached exactly by
    splitting the interval before it into whole steps of at most that length."""
    thetas = np.asarray(thetas, dtype=float)
    if thetas.ndim != 1 or thetas.size < 1 or np.any(np.diff(thetas) <= 0):
        raise ValueError("thetas: must be a strictly increasing 1-D array")
    span = period if period is not None else thetas[-1] - thetas[0]
    hmax = span / steps if span > 0 else 1.0
    x = np.asarray(x0, dtype=float)
    vec = x.ndim == 1
    X = x[:, None] if vec else x
    n, m = X.shape[0], None
    if forcing is not None:
        fb = np.asarray(forcing(thetas[:1]))
        m = 1 if fb.ndim == 2 else fb.shape[2]
        if m != 1 and m != X.shape[1]:
            raise ValueError(f"x0: {X.shape[1]} columns for {m} forcing columns")
    out = [X.copy()]
    for t0, t1 in zip(thetas[:-1], thetas[1:]):
        k = max(1, int(np.ceil((t1 - t0) / hmax - 1e-12)))
        for _, E in step_exponentials(generator, t0, t1, k, forcing=forcing, order=order):
            for Ek in E:
                X = Ek @ X if m is None else Ek[:n, :n] @ X + Ek[:n, n:]
        out.append(X.copy())
    Y = np.stack(out)
    return Y[:, :, 0] if vec and (m is None or m == 1) else Y


def state_matrix(M, C, K) -> np.ndarray:
    """A = [[0, I], [-M⁻¹K, -M⁻¹C]] (k, 2n, 2n) of M x'' + C x' + K x = 0 from dense stacks
    (k, n, n): the generator of the state (x, x'), in the units of the equation's derivative."""
    M, C, K = (np.asarray(x, dtype=float) for x in (M, C, K))
    k, n, _ = M.shape
    A = np.zeros((k, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :] = -np.linalg.solve(M, np.concatenate([K, C], axis=2))
    return A


def second_order(coefficients):
    """Generator θ -> A = [[0, I], [-M⁻¹K, -M⁻¹C]] (:func:`state_matrix`) from
    ``coefficients(theta)`` -> (M, C, K), each a dense stack (k, n, n). The state is x = (q, q')."""

    def generator(theta):
        return state_matrix(*coefficients(theta))

    return generator


def second_order_forcing(mass, load):
    """Forcing θ -> b = [0, M⁻¹f] for the state x = (q, q'): ``mass(theta)`` -> M (k, n, n),
    ``load(theta)`` -> f (k, n) or (k, n, m)."""

    def forcing(theta):
        M = np.asarray(mass(theta), dtype=float)
        f = np.asarray(load(theta), dtype=float)
        f3 = f[:, :, None] if f.ndim == 2 else f
        y = np.linalg.solve(M, f3)
        b = np.concatenate([np.zeros_like(y), y], axis=1)
        return b[:, :, 0] if f.ndim == 2 else b

    return forcing
