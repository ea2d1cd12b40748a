"""Exact periodic coefficients of the linkage at constant crank speed (docs/theory.md §18).

The frozen matrices of :mod:`fkev_slepc.model.operators` are the element equations of §6 written
at a fixed configuration. Over the cycle the global DOFs obey q_e = T(φ_j(t)) q_g with a moving
T, and Ṫ = -φ̇ E T (E = blockdiag(S, 0, S, 0, 0…) per element, S the +90° rotation) adds
frame-rate terms. With φ̇ = φ'Ω, φ̈ = φ''Ω² (α = 0) and c_c, c_t, c_n, c_p the case's flags for
the Coriolis, tangential, normal and pseudo-normal terms (Table 3.1):

    M(θ)    = Σ Tᵀ m T + lumped masses                             (the frozen M)
    C(θ)    = Ω C₁(θ) + C_d(θ)
      C₁    = Σ φ' Tᵀ (2 c_c m_a - 2 m E) T                         sym C₁ = dM/dθ
      C_d   = Σ Tᵀ (α_d m + β_d k) T + α_d · lumped                 (the frozen Rayleigh C)
    K(θ)    = K₀(θ) + Ω² K₂(θ) + Ω K_d(θ)
      K₀    = Σ Tᵀ k T
      K₂    = Σ Tᵀ [c_t φ'' m_a - φ'' m E + φ'² (m E² - 2 c_c m_a E - c_n m) + c_p k_g] T
      K_d   = -Σ φ' Tᵀ (α_d m + β_d k) E T - α_d Σ_P m_P φ'_P S_P    (damping of q̇_e, not q̇_g)

The Lagrangian cases (``structure``, ``full``, ``no_normal``, ``no_pseudo_normal``: c_c = c_t)
also have the canonical pieces L = ½ q̇ᵀMq̇ + Ω q̇ᵀ N₁ q - ½ qᵀ(K₀ + Ω² V₂) q with

      N₁    = Σ φ' Tᵀ (c_c m_a - m E) T
      V₂    = Σ Tᵀ [c_p k_g + φ'² (E m E - c_c (E m_a + m_a E) - c_n m)] T   (symmetric)

so that C₁ = N₁ - N₁ᵀ + dM/dθ and K₂ = V₂ + dN₁/dθ (tests/test_floquet.py checks both).

Public API: ``periodic_pieces(model, thetas, case) -> PeriodicPieces`` (every array a stack of
CSR data on ``model.pattern``, shape (len(thetas), nnz); θ in rad), and
``PeriodicPieces.coefficients(omega) -> (M, C, K)`` data stacks for Ω in rad/s (M q̈ + C q̇ +
K q = 0 in time t). A scene with a crank acceleration is refused (ValueError naming
``driver.acceleration_rad_s2``).
"""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np
import scipy.sparse as sp

from fkev_slepc.model import elements as el
from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.model.kinetostatics import axial_polynomials, solve_loads
from fkev_slepc.scene.cases import CASE_NAMES, CASES

LAGRANGIAN_CASES = ("structure", "full", "no_normal", "no_pseudo_normal")


@dataclass(frozen=True)
class PeriodicPieces:
    """Per-angle CSR data (n_θ, nnz) of the exact periodic coefficients (see module docstring)."""

    theta: np.ndarray
    case: str
    mass: np.ndarray
    gyro: np.ndarray  # C₁, per Ω
    stiffness: np.ndarray  # K₀
    speed_stiffness: np.ndarray  # K₂, per Ω²
    coupling: np.ndarray | None  # N₁ (Lagrangian cases), per Ω
    potential: np.ndarray | None  # V₂ (Lagrangian cases), per Ω²
    damping: np.ndarray | None  # C_d
    damping_stiffness: np.ndarray | None  # K_d, per Ω

    @property
    def lagrangian(self) -> bool:
        return self.coupling is not None

    def coefficients(self, omega: float):
        """(M, C, K) CSR data stacks at crank speed ``omega`` (rad/s)."""
        w = float(omega)
        C = w * self.gyro
        K = self.stiffness + w * w * self.speed_stiffness
        if self.damping is not None:
            C = C + self.damping
            K = K + w * self.damping_stiffness
        return self.mass, C, K


def frame_rate(n_dof: int) -> np.ndarray:
    """E with Ṫ = -φ̇ E T: the +90° rotation S on each node's translations, 0 elsewhere."""
    E = np.zeros((n_dof, n_dof))
    for o in (0, 3):
        E[o, o + 1], E[o + 1, o] = -1.0, 1.0
    return E


class _Scatter:
    """Stacked scatter of (n_θ, n_el, d, d) element stacks into (n_θ, nnz) CSR data."""

    def __init__(self, pattern):
        cols = np.flatnonzero(pattern.valid)
        self.op = sp.csr_matrix((np.ones(cols.size), (pattern.position, cols)),
                                shape=(pattern.nnz, pattern.valid.size))

    def __call__(self, stack: np.ndarray) -> np.ndarray:
        k = stack.shape[0]
        return np.asarray((self.op @ stack.reshape(k, -1).T).T)


def _stacks(model):
    """Local element stacks m, m_a, k (public names when the model has them)."""
    names = (("elem_mass", "_m"), ("elem_skew_mass", "_ma"), ("elem_structural", "_ks"))
    return tuple(getattr(model, pub) if hasattr(model, pub) else getattr(model, priv)
                 for pub, priv in names)


def periodic_pieces(model, thetas, case: str = "full") -> PeriodicPieces:
    """Exact periodic coefficient pieces of ``model`` at crank angles ``thetas`` (rad)."""
    if case not in CASES:
        raise ValueError(f"case: unknown case {case!r}; known: {', '.join(CASE_NAMES)}")
    acc = model.scene.driver.acceleration
    if acc != 0.0:
        raise ValueError(
            f"driver.acceleration_rad_s2: the periodic coefficients need a constant crank speed, "
            f"got {acc:g} rad/s²")
    mech, pat, et = model.mechanism, model.pattern, model.element
    thetas = np.atleast_1d(np.asarray(thetas, dtype=float))
    kin = solve_kinematics(mech, thetas)
    if not np.all(kin.ok):
        bad = np.degrees(thetas[~kin.ok][0])
        raise ValueError(f"crank angle: the linkage cannot be assembled at {bad:g} deg; the "
                         f"periodic analysis needs a crank that turns fully")
    t = CASES[case]
    cc, ct, cn, cp = (float(t.keeps(x)) for x in ("coriolis", "tangential", "normal", "pseudo_normal"))
    lk = mech.elem_link
    k_ang, n_el, d = thetas.size, lk.size, et.n_dof
    T = el.rotation((kin.phi[:, lk] + mech.elem_angle).ravel(), d).reshape(k_ang, n_el, d, d)
    frames = getattr(model, "_node_frames", None)
    if frames is not None:
        T = T @ frames
    m, ma, ks = _stacks(model)
    E = frame_rate(d)
    mE, maE, Ema, EmE = m @ E, ma @ E, E @ ma, E @ m @ E
    dp = kin.dphi[:, lk][:, :, None, None]
    ddp = kin.ddphi[:, lk][:, :, None, None]
    Tt = np.swapaxes(T, 2, 3)
    g = lambda X: Tt @ X @ T  # local -> global, broadcast over (θ, element)
    scatter = _Scatter(pat)

    mass = scatter(np.broadcast_to(g(m), (k_ang, n_el, d, d)))
    mass = np.stack([pat.add_diagonal(
        pat.add_diagonal(row, mech.mass_dofs[:, :2], mech.mass_value[:, None]),
        mech.mass_dofs[:, 2], mech.mass_inertia) for row in mass])
    stiff = scatter(g(ks))
    gyro = scatter(g(dp * (2.0 * cc * ma - 2.0 * mE)))
    kg = np.zeros((k_ang, n_el, d, d))
    if cp:
        loads = solve_loads(mech, kin)
        l = mech.elem_length
        kg = np.stack([et.axial_force(axial_polynomials(mech, kin, loads, a)[0], l)
                       for a in range(k_ang)])
    speed = scatter(g(ct * ddp * ma - ddp * mE + dp**2 * (m @ E @ E - 2.0 * cc * maE - cn * m) + kg))
    coupling = potential = None
    if case in LAGRANGIAN_CASES:
        coupling = scatter(g(dp * (cc * ma - mE)))
        potential = scatter(g(kg + dp**2 * (EmE - cc * (Ema + maE) - cn * m)))
    damping = damping_k = None
    dm = model.scene.damping
    if dm is not None and dm.active:
        a_d, b_d = dm.mass_proportional, dm.stiffness_proportional
        ce = a_d * m + b_d * ks
        damping = a_d * mass + b_d * stiff
        damping_k = scatter(g(-dp * (ce @ E)))
        if mech.mass_value.size and a_d:
            damping_k = _lumped_frame_damping(pat, damping_k, mech, kin, a_d)
    return PeriodicPieces(thetas, case, mass, gyro, stiff, speed, coupling, potential, damping, damping_k)


def _lumped_frame_damping(pat, data, mech, kin, a_d):
    """-α_d m_P φ'_P S on each particle's (U, V) pair: its velocity relative to its link's frame."""
    out = data.copy()
    lookup = {}
    indptr, indices = pat.indptr, pat.indices
    for r in range(pat.n):
        for pos in range(indptr[r], indptr[r + 1]):
            lookup[(r, int(indices[pos]))] = pos
    for p, (u, v) in enumerate(mech.mass_dofs[:, :2]):
        if u < 0 or v < 0:
            continue  # a slider block: its normal DOF is fixed, S has no entry on the free one
        w = -a_d * mech.mass_value[p] * kin.dphi[:, mech.mass_link[p]]
        out[:, lookup[(u, v)]] -= w  # S = [[0, -1], [1, 0]]
        out[:, lookup[(v, u)]] += w
    return out
