"""A moving modal basis W(θ): the lowest r frozen modes of the linkage at each crank angle, aligned
from angle to angle and closed around the revolution (docs/theory.md §18.10).

The linkage's modes move with its geometry: a constant basis (cycle-mean or pooled frozen modes)
needs most of the model's DOFs to hold a band, while W(θ) of r modes converges at a cost set by r
(the Magnus steps follow ω_r/Ω, not the mesh's stiffest mode). ``MovingBasis.frozen(model, omega,
case, r, angles)`` samples the undamped frozen modes (the stiffness of the static problem at
``omega``: the Lagrangian potential where the case has one) at ``angles`` equispaced crank angles,
M(θ)-orthonormal; each sample is rotated within its span onto its predecessor (orthogonal
Procrustes), and the rotation left after a full turn (the holonomy) is spread evenly over the
revolution through its real logarithm, so that W(2π) = W(0). A holonomy with determinant −1 (a mode
that comes back with its sign flipped, or a subspace that crosses a veering at the cutoff) has no
real logarithm: :class:`BasisError`, and the caller changes r. W, W' = dW/dθ and W'' at any angle
come from the trigonometric interpolant of the samples, the derivatives spectral. In the basis
protocol of :func:`fkev_slepc.periodic.reduce.reduced_coefficients` (``shape``, ``at_angle(θ)``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse.linalg as spla

from fkev_slepc.model.periodic import periodic_pieces

TWO_PI = 2.0 * np.pi


class BasisError(ValueError):
    """The frozen modes give no smooth closed basis at this cutoff (see the module docstring)."""


def _frozen_modes(model, omega: float, case: str, r: int, theta: np.ndarray):
    """(angles, n, r) M-orthonormal lowest undamped frozen modes and (angles, r+1) their frequencies
    (rad/s; one above the cutoff, for the gap), sorted."""
    c = periodic_pieces(model, theta, case).at_speed(omega, damping=False)
    stiff = c.K if c.V is None else c.V
    pat, n = model.pattern, int(model.n_free)
    k = min(r + 1, n)
    W, w = np.empty((theta.size, n, r)), np.full((theta.size, r + 1), np.nan)
    for i in range(theta.size):
        K, M = pat.matrix(stiff[i]), pat.matrix(c.M[i])
        K = 0.5 * (K + K.T)
        if n <= 200 or k >= n - 1:
            lam, x = la.eigh(K.toarray(), M.toarray(), subset_by_index=[0, k - 1])
        else:
            lam, x = spla.eigsh(K, k=k, M=M, sigma=0.0, which="LM")
            o = np.argsort(lam)
            lam, x = lam[o], x[:, o]
        W[i] = x[:, :r]
        w[i, :k] = np.sqrt(np.abs(lam)) * np.sign(lam)
    return W, w


def _aligned(W: np.ndarray, M) -> tuple[np.ndarray, np.ndarray]:
    """The samples rotated in their spans onto their predecessors, and the holonomy R: the transport
    carried one step more, onto the sample at 2π (= W₀), ends on W₀·R."""
    out = W.copy()
    for i in range(1, W.shape[0]):
        u, _, vt = np.linalg.svd(out[i - 1].T @ (M[i] @ out[i]))
        out[i] = out[i] @ (u @ vt).T
    u, _, vt = np.linalg.svd(out[-1].T @ (M[0] @ W[0]))
    return out, (u @ vt).T  # W₀·R: the sample at 2π rotated onto the transported end


class MovingBasis:
    """W(θ) (n, r) from ``samples`` (angles, n, r) at equispaced θₖ = 2πk/angles (see the module docstring)."""

    def __init__(self, samples: np.ndarray, frequencies: np.ndarray | None = None):
        self.samples = np.asarray(samples, dtype=float)
        self.frequencies = frequencies  # (angles, r+1) frozen ω at the samples, rad/s
        self.subspace_error = float("nan")  # measured by MovingBasis.frozen at the midpoints
        m = self.samples.shape[0]
        self._coef = np.fft.rfft(self.samples, axis=0) / m  # (m//2+1, n, r)
        self._k = np.arange(self._coef.shape[0], dtype=float)
        if m % 2 == 0:  # the Nyquist term, split evenly (a real, smooth interpolant)
            self._coef[-1] *= 0.5

    @property
    def shape(self) -> tuple[int, int]:
        return self.samples.shape[1:]

    @property
    def r(self) -> int:
        return self.samples.shape[2]

    @property
    def gap(self) -> float:
        """min over θ of ω_{r+1} / max over θ of ω_r: above 1, the cutoff sits in a gap of the spectrum
        over the whole cycle (the subspace is smooth through veering below it); NaN unknown."""
        if self.frequencies is None or not np.all(np.isfinite(self.frequencies[:, -1])):
            return float("nan")
        return float(np.min(self.frequencies[:, -1]) / np.max(self.frequencies[:, -2]))

    @property
    def max_frequency(self) -> float:
        """The largest retained frozen frequency over the cycle, rad/s (it sets the Magnus steps)."""
        return float(np.nanmax(self.frequencies[:, :-1])) if self.frequencies is not None else float("nan")

    def at_angle(self, theta: float):
        """(W, W', W'') at crank angle ``theta`` (rad): the interpolant and its θ-derivatives."""
        e = np.exp(1j * self._k * float(theta))
        terms = [e, 1j * self._k * e, -(self._k**2) * e]
        return tuple(2.0 * np.real(np.tensordot(t, self._coef, axes=1)) - (self._coef[0].real if d == 0 else 0.0)
                     for d, t in enumerate(terms))

    @classmethod
    def frozen(cls, model, omega: float, case: str, r: int, angles: int = 64) -> MovingBasis:
        """The lowest ``r`` frozen modes at ``angles`` equispaced crank angles, aligned and closed;
        the angles doubled (at most ``MAX_ANGLE_DOUBLINGS`` times) until the interpolant between them
        stays in the frozen subspace within :data:`SUBSPACE_TOL` at the midpoints (:func:`subspace_error`)."""
        n = int(model.n_free)
        if not 1 <= r < n:
            raise ValueError(f"r: a moving basis needs 1 <= r < {n} (the model's DOFs) (got {r})")
        m = int(angles)
        W, w = _frozen_modes(model, omega, case, r, TWO_PI * np.arange(m) / m)
        for _ in range(MAX_ANGLE_DOUBLINGS + 1):
            basis = cls._closed(model, case, r, W, w)
            mid = TWO_PI * (np.arange(m) + 0.5) / m
            Wm, wm = _frozen_modes(model, omega, case, r, mid)
            basis.subspace_error = subspace_error(model, case, basis, mid, Wm)
            if basis.subspace_error <= SUBSPACE_TOL:
                return basis
            W, w, m = np.stack([W, Wm], axis=1).reshape(2 * m, *W.shape[1:]), \
                np.stack([w, wm], axis=1).reshape(2 * m, -1), 2 * m
        raise BasisError(f"r = {r}: the subspace of the lowest {r} frozen modes moves faster than {m // 2} angles "
                         f"resolve (midpoint error {basis.subspace_error:.2g} > {SUBSPACE_TOL:g}): the cutoff sits "
                         "at a veering; change r")

    @classmethod
    def _closed(cls, model, case: str, r: int, W: np.ndarray, w: np.ndarray) -> MovingBasis:
        """The samples ``W`` (m, n, r) at equispaced angles aligned and closed (module docstring)."""
        m = W.shape[0]
        mass = periodic_pieces(model, TWO_PI * np.arange(m) / m, case).mass
        W, R = _aligned(W, [model.pattern.matrix(mass[i]) for i in range(m)])  # the transport ends on W₀·R
        if np.linalg.det(R) < 0:
            raise BasisError(f"r = {r}: a frozen mode returns with its sign flipped over the revolution "
                             "(holonomy of determinant -1): change r")
        L = np.real(la.logm(R.T))
        L = 0.5 * (L - L.T)  # the generator of a rotation: skew
        for k in range(1, m):
            W[k] = W[k] @ la.expm((k / m) * L)
        return cls(W, w)


SUBSPACE_TOL = 1e-3  # largest M-norm distance of the interpolated basis from the frozen subspace at the midpoints
MAX_ANGLE_DOUBLINGS = 3  # the sample angles double at most this often (64 -> 512)


def subspace_error(model, case: str, basis: MovingBasis, theta: np.ndarray, frozen: np.ndarray) -> float:
    """max over ``theta`` of the M-norm of the part of the interpolated W(θ) (unit M-norm columns)
    outside the span of ``frozen`` (len(θ), n, r), the M-orthonormal frozen modes there: the
    interpolation error of the subspace, whatever its alignment."""
    mass = periodic_pieces(model, theta, case).mass
    err = 0.0
    for j, t in enumerate(theta):
        M, W, F = model.pattern.matrix(mass[j]), basis.at_angle(t)[0], frozen[j]
        R = W - F @ (F.T @ (M @ W))
        err = max(err, float(np.sqrt(max(np.linalg.eigvalsh(R.T @ (M @ R)).max(), 0.0))))
    return err

SIGN_FLIP_TRIES = 3  # a cutoff whose holonomy flips a mode's sign moves up by one mode, at most this often


def moving_pool(model, omega: float, case: str, angles: int):
    """``pool(r)`` -> the :class:`MovingBasis` of r frozen modes (the truncation sequence's levels,
    fkev_slepc/periodic/truncation.py), or of the next r' <= r + SIGN_FLIP_TRIES - 1 whose holonomy
    is a rotation (det +1) and whose angles resolve it; the whole space (the identity, exact) when
    those tries reach the model's size; :class:`BasisError` when none is below it."""
    def pool(r: int) -> MovingBasis:
        errors = []
        for k in range(int(r), min(int(r) + SIGN_FLIP_TRIES, int(model.n_free))):
            try:
                return MovingBasis.frozen(model, omega, case, k, angles)
            except BasisError as err:
                errors.append(str(err))
        if int(r) + SIGN_FLIP_TRIES >= int(model.n_free):  # no smooth cutoff left below the whole space: take it
            return np.eye(int(model.n_free))  # (exact: the full model's multipliers)
        raise BasisError("; ".join(errors) or f"r = {r}: no moving basis below the model's {model.n_free} DOFs")

    return pool
