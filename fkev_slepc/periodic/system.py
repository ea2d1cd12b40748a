"""One periodic system of a linkage at constant crank speed, for Floquet and the response
(docs/theory.md §18.7, docs/response.md §3).

``PeriodicSystem(model, omega, case="full", *, damping=True, gravity=(0, 0), basis=None,
start=0.0)`` holds everything both periodic analyses need, built once on the model's pieces
(:func:`fkev_slepc.model.periodic.periodic_pieces`, :meth:`Model.load_pieces`):

``coefficients(θ) -> Coefficients``
    dense per-angle M, C, K of M q̈ + C q̇ + K q = f (time form, Rayleigh damping from the scene
    when ``damping``) and the canonical N = Ω N₁, V = K₀ + Ω² V₂, C_d, K_d = Ω K_d (§18.2-18.5);
    with ``basis`` (co-rotated V̂, :mod:`fkev_slepc.periodic.reduce`) the Galerkin-reduced ones.
``mck(θ) -> (M, C, K)``
    the three stacks alone (the generic interface of :mod:`~fkev_slepc.periodic.harmonic_balance` and
    :mod:`~fkev_slepc.periodic.shooting`).
``load(θ) -> f (len(θ), n)``
    the rigid-body inertia loads Ω² f₂(θ) and the gravity ``gravity`` = (g_x, g_y) (m/s², ground
    frame) through :meth:`fkev_slepc.model.loads.LoadPieces.total` (the one gravity of the model);
    with ``basis`` the Galerkin load Wᵀf.
``generator(θ) -> A (len(θ), 2n, 2n)``
    the first-order generator in 1/rad (d/dθ = d/dt / |Ω|): canonical (q, p), p = M q̇ + N q, for
    the Lagrangian cases (Hamiltonian undamped), else (q, q̇) by
    :func:`fkev_slepc.periodic.magnus.state_matrix`; both scaled DOF by DOF (q̂ᵢ = dᵢqᵢ,
    dᵢ = (Mᵢᵢ Kᵢᵢ)^¼; p̂ᵢ = pᵢ/dᵢ, or q̇ᵢ scaled by dᵢ/ωᵢ, ωᵢ² = Kᵢᵢ/Mᵢᵢ). ``scaling`` (2n,) is
    decided ONCE per system, from the mean diagonals over ``SCALING_ANGLES`` equispaced angles,
    and used for every batch of angles (issue 27: a per-batch scaling made the samples and the
    midpoints disagree and the interpolation check stall).
``interpolant(samples=16, tol=1e-12, max_samples=1024) -> Interpolated``
    the trigonometric interpolant of the generator: samples double until the interpolant matches
    the exact generator at the midpoints to ``tol`` (relative to max|A|); ``error`` the last
    measured value (the midpoints then join the samples). It is evaluated as its Fourier series
    without the harmonics whose summed amplitudes are below 0.1·``tol``·max|A| (``TrigInterpolant``'s
    ``drop``: the Magnus steps' node values then cost fewer weights, and ``error`` is measured on it).
    Hamiltonian samples (the undamped Lagrangian cases, full or reduced) take the packed interpolant
    and structured Magnus steps of :mod:`fkev_slepc.periodic.hamiltonian` (``hamiltonian_steps``).

``forcing(τ) -> b̂ (len(τ), 2n)``
    the load in the generator's scaled state (1/rad): x̂' = A x̂ + b̂ is M q̈ + C q̇ + K q = f
    (the response by shooting, fkev_slepc/periodic/response.py).
``link_frame() -> PeriodicSystem | None``
    the same system in co-rotating link-frame coordinates q = W(θ) q̂ (every node translation in
    its link's frame: :mod:`fkev_slepc.periodic.reduce` with the whole space as basis, an
    exact change of variables) where its generator is constant to round-off (``CONSTANT_TOL`` at
    ``CONSTANT_ANGLES`` angles): a lone rotating link. None otherwise. Then the monodromy is one
    exponential and the periodic response one static solve (issue 24 item 3).
``frame(θ) -> W (len(θ), n, n)``: that change of variables at crank angles θ.
``on(basis) -> PeriodicSystem``: the same system on another basis (the reduction ladder's levels).
``spread(X) -> float``: the relative spread of a stack over its first axis (0: constant).

The crank angle runs θ = start + sign(Ω)·τ, τ ∈ [0, 2π] the angle the generator and the
interpolant take (a negative Ω turns the crank backwards).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fkev_slepc.model.periodic import periodic_pieces
from fkev_slepc.model.process_loads import process_load_vectors
from fkev_slepc.periodic import hamiltonian
from fkev_slepc.periodic.magnus import state_matrix
from fkev_slepc.periodic.interpolant import TrigInterpolant, to_dense
from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.periodic.reduce import corotated_pairs, reduced_coefficients, reduced_load, rotate_rows
from fkev_slepc.periodic.settings import DEFAULTS

TWO_PI = 2.0 * np.pi
SCALING_ANGLES = 16  # angles whose mean diagonals fix the DOF scaling of the generator
CONSTANT_ANGLES = 5  # angles at which a link-frame generator (and load) is tested for constancy
CONSTANT_TOL = 1e-13  # relative spread (max|X(θ) - X(θ₀)| / max|X|) that counts as constant


@dataclass(frozen=True)
class Coefficients:
    """Dense per-angle matrices (k, n, n) of one speed (see the module docstring)."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    N: np.ndarray | None  # Ω N₁ (canonical form), None for a non-Lagrangian case
    V: np.ndarray | None  # K₀ + Ω² V₂
    Cd: np.ndarray | None  # Rayleigh C_d
    Kd: np.ndarray | None  # Ω K_d


@dataclass(frozen=True)
class Interpolated:
    """The generator's trigonometric interpolant (callable τ -> A), its measured relative error
    at the last midpoints, and the number of samples it holds."""

    generator: TrigInterpolant | hamiltonian.HamiltonianInterpolant
    error: float
    samples: int

    @property
    def peak(self) -> float:
        """max |A_ij| over the samples (1/rad): the scale of ``error``."""
        return float(np.max(np.abs(self.generator.S)))


class PeriodicSystem:
    """The periodic system of ``model`` at crank speed ``omega`` (rad/s) for ``case``."""

    hamiltonian_steps = True  # Hamiltonian samples take the structured interpolant and steps (False: generic; a benchmark's switch)

    def __init__(self, model, omega: float, case: str = "full", *, damping: bool = True,
                 gravity=(0.0, 0.0), basis: np.ndarray | None = None, start: float = 0.0):
        self.model, self.omega, self.case = model, float(omega), case
        self.damping, self.basis, self.start = bool(damping), basis, float(start)
        self.gravity = np.asarray(gravity, dtype=float).reshape(2)
        self.n = int(model.n_free) if basis is None else int(basis.shape[1])

    def on(self, basis) -> "PeriodicSystem":
        """This system (model, speed, case, damping, gravity, start) on ``basis`` (None: the full model)."""
        return PeriodicSystem(self.model, self.omega, self.case, damping=self.damping, gravity=self.gravity,
                              basis=basis, start=self.start)

    def angle(self, tau) -> np.ndarray:
        """The crank angle θ (rad) of the generator's τ."""
        return self.start + np.sign(self.omega) * np.asarray(tau, dtype=float)

    def coefficients(self, theta) -> Coefficients:
        """Dense coefficients at the crank angles ``theta`` (rad)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        c = periodic_pieces(self.model, theta, self.case).at_speed(self.omega, self.damping)
        if self.basis is not None:
            return Coefficients(*reduced_coefficients(self.model, c, theta, self.omega, self.basis))
        pat = self.model.pattern
        return Coefficients(*(None if x is None else to_dense(pat, x) for x in c))

    def mck(self, theta):
        """(M, C, K) dense stacks at ``theta`` (rad): the response solvers' interface."""
        c = self.coefficients(theta)
        return c.M, c.C, c.K

    def load(self, theta) -> np.ndarray:
        """f (len(θ), n_free): Ω² f₂(θ) plus gravity (g_x, g_y) (ground frame, m/s²) plus the scene's
        process loads ``[[loads]]`` (model/process_loads.py; zero without); with ``basis`` its Galerkin
        load Wᵀf (len(θ), R), the load of the reduced coefficients."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        gx, gy = self.gravity  # LoadPieces: gravity of 1 m/s² along -X, -Y
        f = self.model.load_pieces(theta).total(self.omega, 0.0, -gy, -gx) + process_load_vectors(self.model, theta)
        return f if self.basis is None else reduced_load(self.model, f, theta, self.basis)

    @cached_property
    def reference(self) -> Coefficients:
        """The coefficients at the ``SCALING_ANGLES`` angles the scaling is taken from."""
        return self.coefficients(self.angle(TWO_PI * np.arange(SCALING_ANGLES) / SCALING_ANGLES))

    @cached_property
    def scaling(self) -> np.ndarray:
        """s (2n,): the generator is diag(s) A diag(s)⁻¹ (see the module docstring); fixed once."""
        c = self.reference
        m = np.abs(np.mean(np.diagonal(c.M, axis1=1, axis2=2), axis=0))
        k = np.abs(np.mean(np.diagonal(c.K, axis1=1, axis2=2), axis=0))
        k = np.where(k > 0, k, np.max(k))
        d = (m * k) ** 0.25
        if c.N is not None:
            return np.concatenate([d, 1.0 / d])
        return np.concatenate([d, d / np.sqrt(k / m)])

    @property
    def dof_scaling(self) -> np.ndarray:
        """d (n,): q̂ = d q, the first half of :attr:`scaling`."""
        return self.scaling[: self.n]

    def generator_of(self, c: Coefficients) -> np.ndarray:
        """The scaled generator (1/rad) from coefficients ``c`` (see the module docstring)."""
        n = c.M.shape[1]
        if c.N is not None:  # (q, p): q̇ = M⁻¹(p - Nq), ṗ = (Nᵀ - C_d) q̇ - (V + K_d) q
            Minv = np.linalg.inv(c.M)
            G = np.swapaxes(c.N, 1, 2) - (0.0 if c.Cd is None else c.Cd)
            A = np.empty((c.M.shape[0], 2 * n, 2 * n))
            A[:, :n, :n] = -Minv @ c.N
            A[:, :n, n:] = Minv
            A[:, n:, :n] = -G @ Minv @ c.N - c.V - (0.0 if c.Kd is None else c.Kd)
            A[:, n:, n:] = G @ Minv
        else:  # (q, q̇)
            A = state_matrix(c.M, c.C, c.K)
        s = self.scaling
        return A * (s[None, :, None] / s[None, None, :]) / abs(self.omega)

    def forcing_of(self, c: Coefficients, f) -> np.ndarray:
        """The scaled forcing b̂ (k, 2n) in 1/rad of the load ``f`` (k, n) beside :meth:`generator_of`
        of the same coefficients: [0, f] in (q, p) (ṗ takes the generalised force), [0, M⁻¹f] in (q, q̇)."""
        n = c.M.shape[1]
        f = np.asarray(f, dtype=float)
        b = np.zeros((f.shape[0], 2 * n))
        b[:, n:] = f if c.N is not None else np.linalg.solve(c.M, f[:, :, None])[:, :, 0]
        return b * self.scaling[None, :] / abs(self.omega)

    def forcing(self, tau) -> np.ndarray:
        """b̂ (len(τ), 2n) in 1/rad at the generator angles ``tau``: the load in the generator's state."""
        theta = self.angle(tau)
        return self.forcing_of(self.coefficients(theta), self.load(theta))

    def generator(self, tau) -> np.ndarray:
        """A (len(τ), 2n, 2n) in 1/rad at the generator angles ``tau`` (crank angle start ± τ)."""
        return self.generator_of(self.coefficients(self.angle(tau)))

    def interpolant(self, samples: int = DEFAULTS.samples, tol: float = DEFAULTS.interp_tol,
                    max_samples: int = DEFAULTS.max_samples) -> Interpolated:
        """The generator's trigonometric interpolant, samples doubled until its relative error at
        the midpoints is <= ``tol`` or ``max_samples`` are held (see the module docstring); the
        midpoints then join the samples, and the error returned is that of the interpolant used,
        measured between its samples."""
        k = max(4, 2 * (int(samples) // 2))
        # the scaling's reference angles are the first samples when as many: computed once
        S = self.generator_of(self.reference) if k == SCALING_ANGLES else self.generator(TWO_PI * np.arange(k) / k)
        while True:
            tau_mid = TWO_PI * (np.arange(k) + 0.5) / k
            mid = self.generator(tau_mid)
            err = float(np.max(np.abs(TrigInterpolant(0.0, S)(tau_mid) - mid)) / np.max(np.abs(S)))
            both = np.empty((2 * k,) + S.shape[1:])
            both[0::2], both[1::2] = S, mid
            S, k = both, 2 * k
            if err <= tol or k >= max_samples:
                # the interpolant used holds the midpoints too: its own error, at points between all
                # its samples (every 4th gap), is what enters the multipliers' error bound
                check = TWO_PI * (np.arange(0, k, 4) + 0.25) / k
                # its negligible harmonics left out; Hamiltonian samples (undamped Lagrangian): packed, structured steps
                interp = (hamiltonian.interpolant if self.hamiltonian_steps else TrigInterpolant)(0.0, S, drop=0.1 * tol)
                final = float(np.max(np.abs(interp(check) - self.generator(check))) / np.max(np.abs(S)))
                return Interpolated(interp, final, k)

    def frame(self, theta) -> np.ndarray:
        """W (len(θ), n, n): q = W q̂ with each free node translation in its link's frame."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        mech = self.model.mechanism
        pairs = corotated_pairs(mech)
        phi = solve_kinematics(mech, theta).phi[:, pairs[2]]
        eye = np.eye(int(self.model.n_free))
        return np.stack([rotate_rows(eye, pairs, p) for p in phi])

    def link_frame(self) -> "PeriodicSystem | None":
        """This system in link-frame coordinates where its generator is constant, else None."""
        if self.basis is not None or self.omega == 0.0 or len(self.model.mechanism.link_names) != 1:
            return None
        frame = self.on(np.eye(int(self.model.n_free)))
        tau = TWO_PI * np.arange(CONSTANT_ANGLES) / CONSTANT_ANGLES
        return frame if spread(frame.generator(tau)) <= CONSTANT_TOL else None


def spread(X: np.ndarray) -> float:
    """max |X_j - X_0| / max |X| over the first axis (0 for a constant stack)."""
    X = np.asarray(X, dtype=float)
    return float(np.max(np.abs(X - X[:1])) / max(np.max(np.abs(X)), 1e-300))
