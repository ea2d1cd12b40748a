"""The model's third and fourth layers: named operator pieces at many crank angles, and the one
function that combines them per (speed, acceleration, case) (docs/theory.md §6-9).

At a crank angle, with crank speed Ω and crank acceleration α:

    M                       (angle only)
    C = Ω · G               G  = Σ 2φ'_j m_a                     (Coriolis)
      + α_d M + β_d K_s                                          (Rayleigh structural damping)
    K = K_s                                                     (structural)
      + Ω² T₂ + α T₁,       T₂ = Σ φ''_j m_a, T₁ = Σ φ'_j m_a    (tangential)
      + Ω² N₂,              N₂ = -Σ φ'_j² m                      (normal)
      + Ω² P₂ + α P₁,       k_g of the per-Ω² / per-α axial forces (pseudo-normal)

A :class:`PieceStack` holds every piece as CSR data on the model's pattern, one row per angle,
shape (n_θ, nnz); :class:`OperatorPieces` is one row of it (what the per-point solvers take).
:func:`combine` is the only place where the pieces are summed: ``Model.qep`` (one point) and
``Model.stiffness_terms`` (K(Ω) = K₀ + Ω² K₂ for the critical speeds, and the periodic
coefficients) both call it, on one angle or on a whole stack.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fkev_slepc.model.assembly import Pattern
from fkev_slepc.model.energy import StagedStiffness
from fkev_slepc.model.stacks import AngleState, ElementStacks
from fkev_slepc.model import elements as el
from fkev_slepc.scene.cases import Terms


@dataclass(frozen=True)
class _Named:
    """The named pieces, CSR data on the model's pattern: (nnz,) at one angle, (n_θ, nnz) in a
    stack. Pairs are (per Ω², per α); None where no case of the model keeps the term."""

    theta: float | np.ndarray
    mass: np.ndarray
    structural: np.ndarray
    coriolis: np.ndarray | None  # per unit Ω
    tangential: tuple[np.ndarray, np.ndarray] | None
    normal: np.ndarray | None  # per Ω²
    pseudo_normal: tuple[np.ndarray, np.ndarray] | None


@dataclass(frozen=True)
class OperatorPieces(_Named):
    """The pieces of one crank angle (what the per-point solvers take)."""

    staged: StagedStiffness | None = None  # K_s kept factored (model/energy.py)
    # the same for every (speed, case) of the angle: M as the CSR matrix every QEP shares (never
    # modified), and the Rayleigh damping α M + β K_s data (None without [damping])
    mass_matrix: sp.csr_matrix | None = None
    rayleigh: np.ndarray | None = None


@dataclass(frozen=True)
class PieceStack(_Named):
    """The pieces at crank angles ``theta`` (n_θ,), each (n_θ, nnz). Rows of angles at which the
    linkage cannot be assembled (``ok`` False) are NaN."""

    ok: np.ndarray  # (n_θ,)
    rayleigh: np.ndarray | None  # α_d M + β_d K_s (None without [damping])
    state: AngleState

    def __len__(self) -> int:
        return self.theta.size


def assemble_pieces(stacks: ElementStacks, pattern: Pattern, state: AngleState, terms: set[str],
                    lumped, damping) -> PieceStack:
    """Every piece ``terms`` needs at the angles of ``state``: each element stack transformed
    (Tᵀ k T for all angles and elements in one batched product) and scattered in one call.

    ``lumped``: ((dofs, values), ...) diagonal entries of the lumped masses, added in order;
    ``damping``: the scene's ``[damping]`` (Rayleigh α_d, β_d)."""
    T, pat = state.T, pattern
    m_g = el.to_global(stacks.mass, T)
    mass = pat.scatter(m_g)
    for dofs, values in lumped:
        mass = pat.add_diagonal(mass, dofs, values)
    structural = pat.scatter(el.to_global(stacks.structural, T))
    dphi, ddphi = state.dphi[..., None, None], state.ddphi[..., None, None]
    ma_g = el.to_global(stacks.skew_mass, T) if terms & {"coriolis", "tangential"} else None
    coriolis = pat.scatter(2.0 * dphi * ma_g) if "coriolis" in terms else None
    tangential = (pat.scatter(ddphi * ma_g), pat.scatter(dphi * ma_g)) if "tangential" in terms else None
    normal = None
    if "normal" in terms:  # -φ̇² m in plane (§6); out of plane the propeller moment (§19.4)
        n_g = m_g if stacks.normal is None else el.to_global(stacks.normal, T)
        normal = pat.scatter(-(dphi**2) * n_g)
    pseudo = None
    if "pseudo_normal" in terms:
        pseudo = tuple(pat.scatter(el.to_global(stacks.axial_force(c), T)) for c in state.axial)
    rayleigh = None
    if damping.active:  # symmetric positive semi-definite (α, β >= 0)
        rayleigh = damping.mass_proportional * mass + damping.stiffness_proportional * structural
    return PieceStack(state.theta, mass, structural, coriolis, tangential, normal, pseudo, ok=state.ok,
                      rayleigh=rayleigh, state=state)


@dataclass(frozen=True)
class Combined:
    """The pieces summed at one (Ω, α, case): CSR data, (nnz,) or (n_θ, nnz) for a stack."""

    rest: np.ndarray  # every stiffness term but K_s: K = K_s + rest
    damping: np.ndarray | None  # C (Coriolis and Rayleigh damping); None when there is no C
    k_symmetric: bool | np.ndarray  # per angle for a stack: False when a tangential part acts


@np.errstate(over="ignore", invalid="ignore")  # an overflowing Ω² gives inf/NaN entries: the engines refuse them
def combine(p, omega: float, terms: Terms, accel: float, with_damping: bool = True) -> Combined:
    """Sum the pieces ``p`` (:class:`OperatorPieces` or :class:`PieceStack`) at crank speed
    ``omega`` and acceleration ``accel`` with the terms of a case (Table 3.1).

    A motion term enters only when the case keeps it and it can be non-zero (the linkage moves:
    Ω ≠ 0 or α ≠ 0; the normal term needs Ω ≠ 0, the Coriolis term Ω ≠ 0); a term that would
    enter but was not assembled is an error. A tangential part that vanishes (a lone crank at
    constant speed) keeps K symmetric. C = Ω G (if kept) + the scene's Rayleigh damping, which
    every case keeps (a property of the links, not a motion term); ``with_damping=False``
    leaves C out (stiffness only).
    """
    w2, acc = omega * omega, accel
    rest = np.zeros_like(p.structural)
    moving = terms.motion and (omega != 0.0 or acc != 0.0)
    k_sym = np.ones(rest.shape[:-1], dtype=bool)
    for name, piece in (("tangential", p.tangential), ("pseudo_normal", p.pseudo_normal)):
        if moving and terms.keeps(name):
            _require(name, piece)
            part = w2 * piece[0] + acc * piece[1]
            rest += part
            if name == "tangential":
                k_sym &= ~np.any(part, axis=-1)
    if moving and terms.keeps("normal") and w2 != 0.0:
        _require("normal", p.normal)
        rest += w2 * p.normal
    data = None
    if with_damping:
        if terms.keeps("coriolis") and omega != 0.0:
            _require("coriolis", p.coriolis)
            data = omega * p.coriolis
        if p.rayleigh is not None:
            data = p.rayleigh if data is None else data + p.rayleigh
    return Combined(rest, data, k_sym[()] if k_sym.ndim == 0 else k_sym)


def _require(name, piece):
    if piece is None:
        raise ValueError(f"term {name!r} was not assembled: build the Model with the cases that need it")
