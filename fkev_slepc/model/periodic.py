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
``driver.acceleration_rad_s2``); a run-up's varying speed takes ``accel=True`` and
``at_speed(Ω, accel=α)`` instead (docs/theory.md §21: φ̈ = φ''Ω² + φ'α adds α K_α).

Out of plane (``Model(..., plane="out")``, §19.9) the same formulas hold with m_a = 0 (no
Coriolis, no tangential term), the propeller matrix for the normal term's m, and E acting on each
node's rotation pair (θ_X, θ_Y), which the out-of-plane DOF order puts where the translations are.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from fkev_slepc.model import elements as el
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
    accel_stiffness: np.ndarray | None = None  # K_α, per crank acceleration α (``periodic_pieces(..., accel=True)``)

    @property
    def lagrangian(self) -> bool:
        return self.coupling is not None

    def at_speed(self, omega: float, damping: bool = True, accel: float = 0.0) -> SpeedCoefficients:
        """The one Ω-sum of the periodic coefficients: CSR data stacks at crank speed ``omega``
        (rad/s), with the structural damping where ``damping`` and the model has it
        (``tests/test_layout.py`` fails on a sum of these pieces anywhere else). ``accel``: the crank
        acceleration α (rad/s²) of a run-up (docs/theory.md §21): K gains α K_α and V the α part of the
        axial-force stiffness (needs the pieces built with ``accel=True``)."""
        w, a = float(omega), float(accel)
        if a and self.accel_stiffness is None:
            raise ValueError("accel: these periodic pieces were built without the crank-acceleration piece")
        damped = damping and self.damping is not None
        C = w * self.gyro
        K = self.stiffness + w * w * self.speed_stiffness
        if a:
            K = K + a * self.accel_stiffness
        N = V = Cd = Kd = None
        if damped:
            C = C + self.damping
            K = K + w * self.damping_stiffness
            Cd, Kd = self.damping, w * self.damping_stiffness
        if self.lagrangian:
            N, V = w * self.coupling, self.stiffness + w * w * self.potential
            if a:  # K_α = N₁ + c_p k_g^(α): its potential part is K_α - N₁ (docs/theory.md §21)
                V = V + a * (self.accel_stiffness - self.coupling)
        return SpeedCoefficients(self.mass, C, K, N, V, Cd, Kd)

    def coefficients(self, omega: float):
        """(M, C, K) CSR data stacks at crank speed ``omega`` (rad/s), damping included."""
        return self.at_speed(omega)[:3]


class SpeedCoefficients(NamedTuple):
    """The periodic coefficients at one crank speed, CSR data stacks (n_θ, nnz): M q̈ + C q̇ + K q,
    and of the Lagrangian form the coupling N, the potential V (None in other cases) and the structural
    damping's C_d, K_d (None undamped)."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    N: np.ndarray | None
    V: np.ndarray | None
    Cd: np.ndarray | None
    Kd: np.ndarray | None


def frame_rate(n_dof: int) -> np.ndarray:
    """E with Ṫ = -φ̇ E T: the +90° rotation S on each node's translations, 0 elsewhere (out of
    plane, on the same positions, each node's in-plane rotation pair (θ_X, θ_Y): §19.9)."""
    E = np.zeros((n_dof, n_dof))
    for o in (0, 3):
        E[o, o + 1], E[o + 1, o] = -1.0, 1.0
    return E


def periodic_pieces(model, thetas, case: str = "full", accel: bool = False) -> PeriodicPieces:
    """Exact periodic coefficient pieces of ``model`` at crank angles ``thetas`` (rad), built on
    its element stacks and vectorised angle state (model/stacks.py) in one batched product.
    ``accel``: also the piece K_α per crank acceleration of a run-up (docs/theory.md §21),
    K_α = Σ Tᵀ[φ'(c_t m_a − m E) + c_p k_g^(α)]T."""
    if case not in CASES:
        raise ValueError(f"case: unknown case {case!r}; known: {', '.join(CASE_NAMES)}")
    acc = model.scene.driver.acceleration
    if acc != 0.0:
        raise ValueError(
            f"driver.acceleration_rad_s2: the periodic coefficients need a constant crank speed, "
            f"got {acc:g} rad/s²")
    t = model.case_terms(case)  # out of plane: no Coriolis, no tangential term (§19.9)
    cc, ct, cn, cp = (float(t.keeps(x)) for x in ("coriolis", "tangential", "normal", "pseudo_normal"))
    mech, pat, st = model.mechanism, model.pattern, model.stacks
    thetas = np.atleast_1d(np.asarray(thetas, dtype=float))
    state = model.angle_state(thetas, with_loads=bool(cp))
    if not np.all(state.ok):
        bad = np.degrees(thetas[~state.ok][0])
        raise ValueError(f"crank angle: the linkage cannot be assembled at {bad:g} deg; the "
                         f"periodic analysis needs a crank that turns fully")
    m, ks = st.mass, st.structural
    ma = np.zeros_like(m) if st.skew_mass is None else st.skew_mass  # None out of plane (c_c = c_t = 0)
    nm = m if st.normal is None else st.normal  # the normal term's -φ̇² n: m in plane, the propeller out of it
    E = frame_rate(st.n_dof)
    mE, maE, Ema, EmE = m @ E, ma @ E, E @ ma, E @ m @ E
    dp, ddp = state.dphi[..., None, None], state.ddphi[..., None, None]
    g = lambda X: el.to_global(X, state.T)  # Tᵀ X T over (θ, element)

    base = model.stack_at(state, terms=())  # M, K_s (bearings in) and the Rayleigh damping: the model's one assembly
    mass, stiff = base.mass, base.structural
    gyro = pat.scatter(g(dp * (2.0 * cc * ma - 2.0 * mE)))
    kg = st.axial_force(state.axial[0]) if cp else 0.0
    speed = pat.scatter(g(ct * ddp * ma - ddp * mE + dp**2 * (m @ E @ E - 2.0 * cc * maE - cn * nm) + kg))
    coupling = potential = None
    if cc == ct:  # Lagrangian (LAGRANGIAN_CASES in plane; every case out of plane, §19.9)
        coupling = pat.scatter(g(dp * (cc * ma - mE)))
        potential = pat.scatter(g(kg + dp**2 * (EmE - cc * (Ema + maE) - cn * nm)))
    damping, damping_k = base.rayleigh, None
    dm = model.scene.damping
    if damping is not None:
        a_d, b_d = dm.mass_proportional, dm.stiffness_proportional
        damping_k = pat.scatter(g(-dp * ((a_d * m + b_d * ks) @ E)))
        if mech.mass_value.size and a_d:
            damping_k = _lumped_frame_damping(pat, damping_k, mech, state.kinematics, a_d)
    accel_k = None
    if accel:
        kga = st.axial_force(state.axial[1]) if cp else 0.0
        accel_k = pat.scatter(g(dp * (ct * ma - mE) + kga))
    # compliant joints (in K_s of the stack): a potential, not damped (§19.8)
    return PeriodicPieces(thetas, case, mass, gyro, stiff, speed, coupling, potential, damping, damping_k, accel_k)


def _lumped_frame_damping(pat, data, mech, kin, a_d):
    """-α_d m_P φ'_P S on each particle's (U, V) pair: its velocity relative to its link's frame."""
    out = data.copy()

    def position(r, c):
        row = slice(pat.indptr[r], pat.indptr[r + 1])
        return pat.indptr[r] + int(np.flatnonzero(pat.indices[row] == c)[0])

    for p, (u, v) in enumerate(mech.mass_dofs[:, :2]):
        if u < 0 or v < 0:
            continue  # a slider block: its normal DOF is fixed, S has no entry on the free one
        w = a_d * mech.mass_value[p] * kin.dphi[:, mech.mass_link[p]]
        out[:, position(u, v)] += w  # -α_d m φ' S, S = [[0, -1], [1, 0]]
        out[:, position(v, u)] -= w
    return out
