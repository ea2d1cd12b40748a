"""Harmonic balance for the periodic response of M(θ)q̈ + C(θ)q̇ + K(θ)q = f(θ), θ = Ωt
(docs/response.md §3).

The response is sought as a trigonometric polynomial of degree H in θ, q = Σ_{|l|<=H} Q_l e^{ilθ},
and the harmonics |k| <= H of the residual of the equation in θ,

    Ω² M(θ) q'' + Ω C(θ) q' + K(θ) q = f(θ),

vanish (Galerkin harmonic balance, :func:`galerkin_solve`): one dense complex LU of size
(2H + 1) n, the blocks Toeplitz in the coefficients' Fourier coefficients. Trigonometric
collocation (the equation imposed at 2H + 1 angles; tests/test_response_solvers.py keeps it as a
check) aliases the harmonics above H of the products M q'' ... into the equations, and where a
harmonic kΩ near the truncation meets a natural frequency of an undamped linkage that aliasing is
amplified (measured: Bahgat-Willmert at 300 rad/s, collocation at 129 angles 1.5 % off the
converged response, Galerkin at the same H converged).

The truncation error is estimated by repeating with H/2 and comparing the harmonics (``error``:
the largest change of any harmonic relative to the largest harmonic); with ``tol`` H doubles
until the estimate is below it.

**A balance that will not converge** (:func:`will_not_converge`, asked with ``abandon``): where the
harmonics decay geometrically, |c_k| ~ r^k, the estimate at H measures the H/2 solution,
e_H ≈ A r^{H/2}, so two successive estimates give ρ = e_H/e_{H/2} = r^{H/4} and the level H' is
predicted at e_H ρ^{2(H'/H − 1)} (ρ² at 2H: the estimate squares each doubling). The doubling is
abandoned at the first level whose two last estimates do not fall (ρ ≥ 1) or whose prediction at
the last level allowed (``max_harmonics``, :data:`MAX_UNKNOWNS`) misses ``tol``, as long as the
estimate is above √tol (the balance resolves the response there, and a stall is its conditioning
floor, which shooting does not beat: the slider-crank design scene at 100 rad/s stalls at 2.3e-7,
1.1e-7 for H = 32, 64, and its shooting misses 1e-8 at 65,536 steps): the costly last levels are
not solved, and the caller takes the periodic response by shooting (fkev_slepc/periodic/response.py).
Undamped Bahgat–Willmert (1 element per link) at 500 rad/s: estimates 3.0, 0.67, 1.0 at H = 16, 32,
64, abandoned at 64 (doubled on, it reached 1.8e-7 at H = 256, the last level: 3.2 s against 0.17 s
for the levels to 64, a session script on an idle machine); Turcic–Midha at 60 rad/s: 1.35, 4.6e-2,
1.5e-4, 3.3e-9 at H = 16 ... 128, ρ = 0.034, 3.3e-3: predicted 7e-11 at 128 from H = 32, kept.

Generic interface (no linkage in here): ``coefficients(theta)`` -> (M, C, K), dense stacks
(k, n, n) at the angles theta (k,) in the time form (units of the equation in t);
``load(theta)`` -> f (k, n). Ω (rad/s) turns θ-derivatives into time derivatives.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as la

MAX_UNKNOWNS = 12_000  # N·n of one dense solve (1.15 GB of LU at the limit): beyond, refuse


@dataclass(frozen=True)
class HarmonicResponse:
    """The periodic response at the collocation angles and its harmonics."""

    theta: np.ndarray  # (N,) rad, 2πj/N
    q: np.ndarray  # (N, n)
    dq: np.ndarray  # (N, n) dq/dθ (multiply by Ω for the velocity)
    harmonics: np.ndarray  # (H + 1, n) complex: q(θ) = Re Σ_k c_k e^{ikθ} (c_0 real)
    error: float  # estimated relative truncation error of the harmonics (NaN: not estimated)
    condition: float  # reciprocal condition estimate of the collocation matrix (1-norm)
    levels: tuple = ()  # (H, estimate) of every level with an estimate, coarse to fine
    abandoned: bool = False  # the doubling stopped early: it will not reach its tol (:func:`will_not_converge`)

    @property
    def n_angles(self) -> int:
        return self.theta.size

    def at(self, theta) -> np.ndarray:
        """q at any angles (k,) -> (k, n), by the trigonometric interpolant."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        k = np.arange(self.harmonics.shape[0])
        return np.real(np.exp(1j * np.outer(theta, k)) @ self.harmonics)


def harmonics_of(q: np.ndarray) -> np.ndarray:
    """(H + 1, n) complex c_k with q(θ_j) = Re Σ c_k e^{ikθ_j} for samples q (N, n), N odd."""
    N = q.shape[0]
    c = np.fft.rfft(q, axis=0) / N
    c[1:] *= 2.0
    return c


def galerkin_solve(coefficients, load, omega: float, H: int) -> HarmonicResponse:
    """The periodic response with harmonics 0..H by Galerkin harmonic balance (one dense LU).

    q(θ) = Σ_{|l|<=H} Q_l e^{ilθ}; the residual's harmonics |k| <= H vanish:
    Σ_l [K̂_{k-l} + ilΩ Ĉ_{k-l} - l²Ω² M̂_{k-l}] Q_l = F̂_k, with the coefficients' Fourier
    coefficients from 4H + 1 samples (exact for coefficients of degree <= 2H; a linkage's decay
    geometrically). Unlike collocation, nothing above H is aliased into the equations, so a
    harmonic near a high natural frequency is excited only by the forcing's own content there."""
    H = int(H)
    if H < 1:
        raise ValueError(f"harmonics: must be >= 1 (got {H})")
    Nq = 4 * H + 1
    tq = 2.0 * np.pi * np.arange(Nq) / Nq
    M, C, K = (np.asarray(x, dtype=float) for x in coefficients(tq))
    f = np.asarray(load(tq), dtype=float)
    n = M.shape[1]
    size = (2 * H + 1) * n
    if size > MAX_UNKNOWNS:
        raise ValueError(f"harmonic balance: {2 * H + 1} harmonics x {n} DOFs = {size} unknowns exceeds the dense "
                         f"limit {MAX_UNKNOWNS}; use fewer harmonics")
    hat = lambda x: np.fft.fft(x, axis=0) / Nq  # noqa: E731  index m mod Nq: harmonic m
    Mh, Ch, Kh, Fh = hat(M), hat(C), hat(K), hat(f)
    ls, ks = np.arange(-H, H + 1), np.arange(H + 1)
    diff = (ks[:, None] - ls[None, :]) % Nq  # k - l for the residual's harmonics k >= 0 (k < 0: conjugates)
    w = float(omega)
    # assembled in place (one block matrix and one temporary: the memory of large models)
    A = Kh[diff]
    T = Ch[diff]
    T *= (1j * w * ls)[None, :, None, None]
    A += T
    np.take(Mh, diff, axis=0, out=T)
    T *= ((w * ls) ** 2)[None, :, None, None]
    A -= T
    del T
    # q real: Q_-l = conj(Q_l) = a_l - i b_l, so the real unknowns (a_0, a_1..a_H, b_1..b_H) and the
    # real equations (Re of harmonics 0..H, Im of 1..H): a real LU of the same size, 1/4 of the
    # complex one's work
    P = A[:, H + 1:] + A[:, H - 1::-1]  # multiplies a_l
    D = 1j * (A[:, H + 1:] - A[:, H - 1::-1])  # multiplies b_l
    blocks = np.concatenate([A[:, H:H + 1], P, D], axis=1)  # (H + 1, 2H + 1, n, n) complex
    del A, P, D
    G = np.concatenate([blocks.real, blocks[1:].imag], axis=0)
    del blocks
    G = G.transpose(0, 2, 1, 3).reshape(size, size)
    F = Fh[ks]
    x, rcond = _solve(G, np.concatenate([F.real, F[1:].imag]).reshape(-1))
    x = x.reshape(2 * H + 1, n)
    Q = np.empty((2 * H + 1, n), dtype=complex)
    Q[H] = x[0]
    Q[H + 1:] = x[1:H + 1] + 1j * x[H + 1:]
    Q[:H] = np.conj(Q[H + 1:][::-1])
    harmonics = np.concatenate([Q[H : H + 1].real, 2.0 * Q[H + 1 :]])
    theta = 2.0 * np.pi * np.arange(2 * H + 1) / (2 * H + 1)
    E = np.exp(1j * np.outer(theta, ls))
    q = np.real(E @ Q)
    dq = np.real(E @ (1j * ls[:, None] * Q))
    return HarmonicResponse(theta, q, dq, harmonics, float("nan"), rcond)


def _solve(A, b):
    """x of A x = b: equilibrated (rows, then columns, by powers of 2: exact), LU, refined twice
    (the DOFs mix translations and rotations, and the axial stiffness is far above the rest);
    and LAPACK's reciprocal condition estimate of the equilibrated matrix."""
    r = _pow2(1.0 / np.abs(A).max(axis=1))
    As = A * r[:, None]
    c = _pow2(1.0 / np.abs(As).max(axis=0))
    As *= c[None, :]
    lu = la.lu_factor(As, check_finite=False)
    rcond = _rcond(As, lu)
    y = la.lu_solve(lu, r * b, check_finite=False)
    for _ in range(2):
        y = y + la.lu_solve(lu, r * (b - A @ (c * y)), check_finite=False)
    return c * y, rcond


def _pow2(x: np.ndarray) -> np.ndarray:
    """The powers of two nearest ``x`` (scaling by them is exact); 1 where x is not finite."""
    x = np.where(np.isfinite(x) & (x > 0), x, 1.0)
    return np.exp2(np.round(np.log2(x)))


def _rcond(A, lu) -> float:
    """LAPACK's reciprocal 1-norm condition estimate from the LU factors."""
    gecon = la.get_lapack_funcs("gecon", (A,))
    rc, info = gecon(lu[0], np.linalg.norm(A, 1), norm="1")
    return float(rc)


def will_not_converge(levels, tol: float, last: int) -> bool:
    """True where the estimates of ``levels`` ((H, estimate), coarse to fine) say the doubling
    will not bring the estimate to ``tol`` by the harmonics ``last``: the last two estimates do not
    fall, or their geometric prediction e_H ρ^{2(last/H − 1)} at ``last`` misses ``tol`` (module
    docstring); False with fewer than two estimates or the last ≤ √tol (a floor there is the
    balance's own, not an unresolved spectrum: the doubling goes on)."""
    if len(levels) < 2 or levels[-1][1] <= np.sqrt(tol):
        return False
    (_, before), (H, e) = levels[-2], levels[-1]
    rho = e / before if before > 0 else np.inf
    return not rho < 1.0 or e * rho ** (2.0 * (last / H - 1.0)) > tol


def harmonic_balance(coefficients, load, omega: float, *, harmonics: int | None = None, tol: float = 1e-10,
                     start: int = 8, max_harmonics: int = 256, abandon: bool = False) -> HarmonicResponse:
    """The periodic response by Galerkin harmonic balance with its truncation-error estimate.

    ``harmonics`` fixes H (the estimate compares with H/2); without it H = start, 2·start, ...
    until the estimate <= ``tol`` or H would pass ``max_harmonics`` (the last estimate is
    reported either way); with ``abandon`` also at the first level where :func:`will_not_converge`
    (the result's ``abandoned`` set). The estimate is the change of the harmonics from H/2 to H
    relative to the largest one: it measures the coarser solution, an upper bound for a geometric
    convergence."""
    def compare(fine, coarse):
        a, b = fine.harmonics, coarse.harmonics
        k = b.shape[0]
        scale = max(np.abs(a).max(), 1e-300)
        return float(max(np.abs(a[:k] - b).max(), np.abs(a[k:]).max(initial=0.0)) / scale)

    if harmonics is not None:
        H = int(harmonics)
        fine = galerkin_solve(coefficients, load, omega, H)
        coarse = galerkin_solve(coefficients, load, omega, max(1, H // 2))
        err = compare(fine, coarse)
        return replace(fine, error=err, levels=((H, err),))
    H = int(start)
    coarse = galerkin_solve(coefficients, load, omega, H)
    n = coarse.q.shape[1]
    last = H
    while 2 * last <= max_harmonics and (4 * last + 1) * n <= MAX_UNKNOWNS:
        last *= 2
    levels = []
    while True:
        H *= 2
        fine = galerkin_solve(coefficients, load, omega, H)
        levels.append((H, compare(fine, coarse)))
        err = levels[-1][1]
        stop = abandon and will_not_converge(levels, tol, last)
        if err <= tol or H >= last or stop:
            return replace(fine, error=err, levels=tuple(levels), abandoned=bool(stop))
        coarse = fine
