"""The linkage's elastic equations along a prescribed crank history, M(θ) q̈ + C(θ, Ω) q̇ +
K(θ, Ω, α) q = f(θ, Ω, α) (docs/theory.md §21): the coefficients of the periodic system with the
speed Ω(t) and the crank acceleration α(t) of the moment.

``CrankHistory``: θ(t), Ω(t), α(t) of a constant speed (``constant``) or a linear ramp (``ramp``).

``MotionSystem(model, case, damping=True, gravity=(0, 0), basis=None, tol=1e-12)``: every
coefficient and load is affine in (1, Ω, Ω², α); the four θ-periodic pieces are recovered exactly
from the one Ω-sum of the periodic coefficients (``PeriodicPieces.at_speed`` at (Ω, α) = (0, 0),
(±1, 0), (0, 1); with ``basis`` through ``periodic.reduce.reduced_coefficients``, so full and
reduced are the same system as the Floquet map's), sampled at equispaced crank angles and
evaluated in between by their trigonometric interpolant (``periodic.interpolant.TrigInterpolant``),
the samples doubled until every piece matches its exact values at the midpoints to ``tol``
relative to its largest entry (``error`` the measured value). ``at(θ, Ω, α) -> (M, C, K, f)``
dense (n, n) and (n,) at one instant; ``expand(θ, η) -> q`` the model's DOFs of reduced
coordinates (the identity on the full model). Process loads (tables over the crank angle,
piecewise linear) are evaluated exactly at every instant, not interpolated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.model.periodic import periodic_pieces
from fkev_slepc.model.process_loads import process_load_vectors
from fkev_slepc.periodic.interpolant import TrigInterpolant, to_dense
from fkev_slepc.periodic.reduce import CorotatedBasis, corotated_pairs, reduced_coefficients

TWO_PI = 2.0 * np.pi
MATRICES = ("M", "C0", "C1", "K0", "K1", "K2", "Ka")  # M; C = C0 + Ω C1; K = K0 + Ω K1 + Ω² K2 + α Ka
LOADS = ("f0", "f2", "fa")  # f = f0 + Ω² f2 + α fa (+ the process loads)
START_SAMPLES, MAX_SAMPLES = 32, 2048


@dataclass(frozen=True)
class CrankHistory:
    """θ(t) = start + w0 t + (w1 - w0) t²/(2 duration) for 0 <= t <= duration (constant: w1 = w0)."""

    w0: float
    w1: float
    duration: float
    start: float = 0.0

    @classmethod
    def constant(cls, speed: float, revolutions: float, start: float = 0.0) -> "CrankHistory":
        return cls(float(speed), float(speed), TWO_PI * float(revolutions) / abs(float(speed)), float(start))

    @classmethod
    def ramp(cls, w0: float, w1: float, duration: float, start: float = 0.0) -> "CrankHistory":
        return cls(float(w0), float(w1), float(duration), float(start))

    @property
    def accel(self) -> float:
        return (self.w1 - self.w0) / self.duration

    @property
    def constant_speed(self) -> bool:
        return self.w0 == self.w1

    def angle(self, t):
        t = np.asarray(t, dtype=float)
        return self.start + self.w0 * t + 0.5 * self.accel * t * t

    def speed(self, t):
        return self.w0 + self.accel * np.asarray(t, dtype=float)

    def revolutions(self, t):
        """Crank revolutions turned by time ``t`` (|θ - start| / 2π)."""
        return np.abs(self.angle(t) - self.start) / TWO_PI


def basis_at(model, basis, theta) -> np.ndarray:
    """W (len(θ), n, R) of a basis in the protocol of ``reduce.reduced_coefficients`` (a co-rotated
    V̂, ``at(φ, φ', φ'')`` or ``at_angle(θ)``) at crank angles ``theta``."""
    if isinstance(basis, np.ndarray):
        basis = CorotatedBasis(basis, corotated_pairs(model.mechanism))
    if hasattr(basis, "at_angle"):
        return np.stack([basis.at_angle(t)[0] for t in theta])
    kin = solve_kinematics(model.mechanism, theta)
    return np.stack([basis.at(kin.phi[i], kin.dphi[i], kin.ddphi[i])[0] for i in range(len(theta))])


class MotionSystem:
    """The time-domain system of ``model`` for ``case`` (see the module docstring)."""

    def __init__(self, model, case: str = "full", *, damping: bool = True, gravity=(0.0, 0.0), basis=None,
                 tol: float = 1e-12):
        self.model, self.case, self.damping, self.basis = model, case, bool(damping), basis
        self.gravity = np.asarray(gravity, dtype=float).reshape(2)
        self.n = int(model.n_free) if basis is None else int(basis.shape[1])
        self.tol = float(tol)
        self.process = bool(model.mechanism.scene.process_loads)  # [[loads]]: exact at every instant
        self.interpolant, self.error, self.samples = self._interpolate()

    # -- exact pieces ----------------------------------------------------------------------
    def exact(self, theta) -> np.ndarray:
        """The pieces (len(θ), P) flattened: MATRICES (n² each), LOADS (n each) and, reduced, W (n·R)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        pp = periodic_pieces(self.model, theta, self.case, accel=True)
        w, a = self.scales(pp)
        pts = ((0.0, 0.0), (w, 0.0), (-w, 0.0), (0.0, a))
        if self.basis is None:
            dense = [[to_dense(self.model.pattern, x) for x in pp.at_speed(s, self.damping, b)[:3]] for s, b in pts]
        else:
            dense = [reduced_coefficients(self.model, pp.at_speed(s, self.damping, b), theta, s, self.basis, b)[:3]
                     for s, b in pts]
        (M, C0, K0), (_, Cp, Kp), (_, Cm, Km), (_, _, Ka) = dense
        mats = [M, C0, (Cp - Cm) / (2 * w), K0, (Kp - Km) / (2 * w), (0.5 * (Kp + Km) - K0) / w**2, (Ka - K0) / a]
        gx, gy = self.gravity  # LoadPieces: gravity of 1 m/s² along -X, -Y
        lp = self.model.load_pieces(theta)
        f0 = lp.total(0.0, 0.0, -gy, -gx)
        loads = [f0, lp.total(1.0, 0.0, -gy, -gx) - f0, lp.total(0.0, 1.0, -gy, -gx) - f0]
        parts = [x.reshape(theta.size, -1) for x in mats]
        if self.basis is None:
            parts += loads
        else:
            W = basis_at(self.model, self.basis, theta)
            parts += [np.einsum("kij,ki->kj", W, f) for f in loads] + [W.reshape(theta.size, -1)]
        return np.concatenate(parts, axis=1)

    def scales(self, pp):
        """(w, a): the speed and acceleration at which the pieces are separated, w² = max|K₀|/max|M|
        of the first angle (Ω² K₂ then compares with K₀: the differences lose no digits), a = w²."""
        if not hasattr(self, "_scales"):
            w = float(np.sqrt(np.max(np.abs(pp.stiffness[0])) / np.max(np.abs(pp.mass[0]))))
            self._scales = (w, w * w)
        return self._scales

    def _layout(self):
        n, N = self.n, int(self.model.n_free)
        sizes = [n * n] * len(MATRICES) + [n] * len(LOADS) + ([] if self.basis is None else [N * n])
        return np.concatenate([[0], np.cumsum(sizes)])

    def _interpolate(self):
        """The interpolant of the coefficient and load pieces (each scaled by its largest sample),
        samples doubled from START_SAMPLES until their midpoint error <= tol; a reduced basis's W from
        the same samples, in an interpolant of its own (read once per revolution, not per step)."""
        edges = self._layout()
        k, cut = START_SAMPLES, edges[len(MATRICES) + len(LOADS)]
        S = self.exact(TWO_PI * np.arange(k) / k)
        while True:
            scale = np.ones(S.shape[1])
            for a, b in zip(edges[:-1], edges[1:]):
                peak = np.max(np.abs(S[:, a:b]))
                scale[a:b] = peak if peak > 0 else 1.0
            mid = TWO_PI * (np.arange(k) + 0.5) / k
            exact = self.exact(mid)
            err = float(np.max(np.abs(TrigInterpolant(0.0, S[:, :cut] / scale[:cut])(mid) - exact[:, :cut] / scale[:cut])))
            both = np.empty((2 * k, S.shape[1]))
            both[0::2], both[1::2] = S, exact
            S, k = both, 2 * k
            if err <= self.tol or k >= MAX_SAMPLES:
                if self.basis is not None:
                    self._frame = TrigInterpolant(0.0, S[:, cut:], drop=0.1 * self.tol)
                S = S[:, :cut]
                keep = np.flatnonzero(np.any(S != 0.0, axis=0))  # the pattern's zeros stay zero
                return _Pieces(TrigInterpolant(0.0, S[:, keep] / scale[keep], drop=0.1 * self.tol),
                               keep, scale[keep], cut, edges[: len(MATRICES) + len(LOADS) + 1]), err, k

    # -- one instant -----------------------------------------------------------------------
    def at(self, theta: float, omega: float, accel: float):
        """(M, C, K, f) dense at crank angle ``theta`` (rad), speed ``omega`` (rad/s) and crank
        acceleration ``accel`` (rad/s²)."""
        n = self.n
        p = self.interpolant.parts(theta)
        M, C0, C1, K0, K1, K2, Ka = (p[i].reshape(n, n) for i in range(len(MATRICES)))
        f0, f2, fa = p[len(MATRICES):len(MATRICES) + len(LOADS)]
        C = C0 + omega * C1
        K = K0 + omega * K1 + (omega * omega) * K2 + accel * Ka
        f = f0 + (omega * omega) * f2 + accel * fa
        if self.process:
            fp = process_load_vectors(self.model, [theta])[0]
            f = f + (fp if self.basis is None else self.frame(theta)[0].T @ fp)
        return M, C, K, f

    def frame(self, theta) -> np.ndarray:
        """W (len(θ), n_free, n) at crank angles ``theta``: q = W η (the identity on the full model)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        if self.basis is None:
            return np.broadcast_to(np.eye(self.n), (theta.size, self.n, self.n))
        return self._frame(theta).reshape(theta.size, int(self.model.n_free), self.n)

    def expand(self, theta, eta) -> np.ndarray:
        """q (len(θ), n_free) of coordinates ``eta`` (len(θ), n) at crank angles ``theta``."""
        eta = np.atleast_2d(eta)
        if self.basis is None:
            return eta
        return np.einsum("kij,kj->ki", self.frame(theta), eta)


class _Pieces:
    """The interpolated pieces: ``parts(θ)`` -> list of the flat pieces (unscaled) at one angle."""

    def __init__(self, interp, keep, scale, width, edges):
        self.interp, self.keep, self.scale, self.width, self.edges = interp, keep, scale, width, edges

    def parts(self, theta: float) -> list[np.ndarray]:
        th = float(theta) - self.interp.start
        m = self.interp.harmonics
        w = np.concatenate([np.cos(m * th), np.sin(m[1:] * th)])  # the interpolant's Fourier series at one angle
        flat = np.zeros(self.width)
        flat[self.keep] = (w @ self.interp.coefficients) * self.scale
        return [flat[a:b] for a, b in zip(self.edges[:-1], self.edges[1:])]


RUNUP_REDUCE = "none, links, links:N, N or moving:R"


def runup_reduction(value):
    """The resolved ``reduce`` of a run-up (``periodic.settings.resolve_reduce``), or ValueError: one fixed
    basis for the whole history, so none of the convergence sequences (auto, default, moving). Not given
    (None), the run-up's default: the full model."""
    from fkev_slepc.periodic.settings import resolve_reduce

    if value is None:
        return None
    r = resolve_reduce(value)
    if r in ("auto", "default", "moving"):
        raise ValueError(f"the run-up takes one fixed basis: {RUNUP_REDUCE} (got {value!r})")
    return r


def runup_basis(model, reduce, case: str, omega: float, settings=None):
    """The basis of a resolved run-up ``reduce`` (None: the full model): the link-frame component modes
    (``links``: ``settings.link_modes`` per link, ``links:N``; independent of the speed), or at the
    reference speed ``omega`` (rad/s) the co-rotated pool of N frozen modes compressed as the Floquet
    map's (``settings.basis_angles``, ``threshold``) or the moving basis of R frozen modes."""
    from fkev_slepc.periodic.settings import DEFAULTS

    st = settings or DEFAULTS
    if reduce is None:
        return None
    n = int(model.n_free)
    if isinstance(reduce, str) and reduce.startswith("links"):
        from fkev_slepc.periodic.components import link_components

        return link_components(model).basis(st.link_modes if reduce == "links" else int(reduce[6:]))
    if isinstance(reduce, str) and reduce.startswith("moving:"):
        from fkev_slepc.periodic.moving import moving_pool

        return moving_pool(model, omega, case, st.moving_angles)(min(int(reduce[7:]), n - 1))
    from fkev_slepc.periodic.reduce import compress, frozen_pool

    return compress(frozen_pool(model, omega, case, min(int(reduce), n - 1), st.basis_angles), st.threshold)
