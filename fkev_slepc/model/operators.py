"""Operators of the instantaneous structure: per-angle pieces, combined per speed and case.

At a fixed crank angle, with crank speed Ω and crank acceleration α (docs/theory.md §6-7):

    M                       (angle only)
    C = Ω · G               G  = Σ 2φ'_j m_a                     (Coriolis)
      + α_d M + β_d K_s                                          (Rayleigh structural damping)
    K = K_s                                                     (structural)
      + Ω² T₂ + α T₁,       T₂ = Σ φ''_j m_a, T₁ = Σ φ'_j m_a    (tangential)
      + Ω² N₂,              N₂ = -Σ φ'_j² m                      (normal)
      + Ω² P₂ + α P₁,       k_g of the per-Ω² / per-α axial forces (pseudo-normal)

so the pieces are assembled once per angle and only summed per (Ω, case). Pieces of terms that
no requested case keeps are never assembled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fkev_slepc.model import elements as el
from fkev_slepc.model.assembly import Pattern
from fkev_slepc.model.element_types import element_type
from fkev_slepc.model.energy import StagedStiffness
from fkev_slepc.scene.cases import CASE_NAMES, CASES, terms_used
from fkev_slepc.model.kinematics import point_local, solve_kinematics
from fkev_slepc.model.kinetostatics import axial_polynomials, solve_loads
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.qep import GENERAL, GYROSCOPIC, LINEAR, LINEAR_SYMMETRIC, QEP
from fkev_slepc.scene import Scene


class AssemblyError(ValueError):
    """The linkage cannot be assembled (or is at a dead centre) at the requested crank angle."""


@dataclass(frozen=True)
class OperatorPieces:
    """CSR data arrays (on ``Model.pattern``) of one crank angle. Pairs are (per Ω², per α)."""

    theta: float
    mass: np.ndarray
    structural: np.ndarray
    coriolis: np.ndarray | None  # per unit Ω
    tangential: tuple[np.ndarray, np.ndarray] | None
    normal: np.ndarray | None  # per Ω²
    pseudo_normal: tuple[np.ndarray, np.ndarray] | None
    staged: StagedStiffness | None = None  # K_s kept factored (model/energy.py)
    # the same for every (speed, case) of the angle: M as the CSR matrix every QEP shares (never
    # modified), and the Rayleigh damping α M + β K_s data (None without [damping])
    mass_matrix: sp.csr_matrix | None = None
    rayleigh: np.ndarray | None = None


def classify(has_damping: bool, k_symmetric: bool, c_skew: bool = True) -> str:
    """Problem kind from the structure of the terms present (see qep.KINDS).

    ``has_damping``: a C matrix is present; ``c_skew``: it is Coriolis only (structural damping
    makes C non-skew, and the problem is then ``general`` whatever K is)."""
    if not has_damping:
        return LINEAR_SYMMETRIC if k_symmetric else LINEAR
    return GYROSCOPIC if k_symmetric and c_skew else GENERAL


def node_frames(mech, n_dof: int = 6) -> np.ndarray | None:
    """Per element blockdiag(Cₙ₁, 1, Cₙ₂, 1, I), Cₙ = [a, a⊥] with a = ``node_axis``: the node's
    translations taken along/normal to a slider's guide (docs/linkages.md); internal DOFs of
    higher-order elements (beyond the sixth) are unchanged. None if no node has a rotated frame
    (then the element transformation is T alone)."""
    a = mech.node_axis
    if np.all(a[:, 0] == 1.0):
        return None
    C = np.zeros((mech.elem_nodes.shape[0], n_dof, n_dof))
    C[:, 6:, 6:] = np.eye(n_dof - 6)
    for o, nodes in ((0, mech.elem_nodes[:, 0]), (3, mech.elem_nodes[:, 1])):
        ax, ay = a[nodes, 0], a[nodes, 1]
        C[:, o, o], C[:, o, o + 1], C[:, o + 1, o], C[:, o + 1, o + 1] = ax, -ay, ay, ax
        C[:, o + 2, o + 2] = 1.0
    return C


class Model:
    """A meshed mechanism with its constant element data and cached sparsity pattern.

    Parameters
    ----------
    scene : Scene
    cases : tuple of case names, optional
        The cases that will be asked for (default: the scene's); terms none of them keep are
        not assembled.
    """

    def __init__(self, scene: Scene, cases: tuple[str, ...] | None = None):
        self.scene = scene
        self.mechanism = mech = build_mechanism(scene)
        self.n_free = mech.n_free
        self.pattern = Pattern(mech.elem_dofs, mech.n_free)
        self.cases = tuple(cases or scene.analysis.cases)
        self.terms = terms_used(self.cases)
        self.element = et = element_type(scene.analysis.element)
        l = mech.elem_length
        self._m = et.mass(mech.elem_rho_a, l)
        self._ma = et.skew_mass(mech.elem_rho_a, l)
        self._ks = et.structural(mech.elem_ea, mech.elem_ei, l)
        self._strain_op = et.strains(mech.elem_ea, mech.elem_ei, l)
        self._node_frames = node_frames(mech, et.n_dof)

    # -- per angle -------------------------------------------------------------------------
    def kinematics(self, theta: float):
        kin = solve_kinematics(self.mechanism, [theta])
        if not kin.ok[0]:
            raise AssemblyError(
                f"the linkage cannot be assembled at crank angle {np.degrees(theta):g} deg"
            )
        return kin

    def pieces(self, theta: float) -> OperatorPieces:
        """Assemble every piece needed by the model's cases at crank angle ``theta`` (rad)."""
        mech, pat, terms = self.mechanism, self.pattern, self.terms
        kin = self.kinematics(theta)
        lk = mech.elem_link
        T = el.rotation(kin.phi[0, lk] + mech.elem_angle, self.element.n_dof)
        if self._node_frames is not None:
            T = T @ self._node_frames
        m_g = el.to_global(self._m, T)
        mass = pat.add_diagonal(pat.scatter(m_g), mech.mass_dofs[:, :2], mech.mass_value[:, None])
        mass = pat.add_diagonal(mass, mech.mass_dofs[:, 2], mech.mass_inertia)
        structural = pat.scatter(el.to_global(self._ks, T))
        dphi, ddphi = kin.dphi[0, lk][:, None, None], kin.ddphi[0, lk][:, None, None]
        ma_g = el.to_global(self._ma, T) if terms & {"coriolis", "tangential"} else None
        coriolis = pat.scatter(2.0 * dphi * ma_g) if "coriolis" in terms else None
        tangential = (
            (pat.scatter(ddphi * ma_g), pat.scatter(dphi * ma_g)) if "tangential" in terms else None
        )
        normal = pat.scatter(-(dphi**2) * m_g) if "normal" in terms else None
        pseudo = None
        if "pseudo_normal" in terms:
            loads = solve_loads(mech, kin)
            c_w2, c_acc = axial_polynomials(mech, kin, loads, 0)
            l = mech.elem_length
            pseudo = (
                pat.scatter(el.to_global(self.element.axial_force(c_w2, l), T)),
                pat.scatter(el.to_global(self.element.axial_force(c_acc, l), T)),
            )
        staged = StagedStiffness(*self._strain_op, T, mech.elem_dofs, mech.n_free)
        d = self.scene.damping  # Rayleigh damping: symmetric positive semi-definite (α, β >= 0)
        rayleigh = d.mass_proportional * mass + d.stiffness_proportional * structural if d.active else None
        return OperatorPieces(float(theta), mass, structural, coriolis, tangential, normal, pseudo, staged,
                              pat.matrix(mass), rayleigh)

    # -- per speed and case ----------------------------------------------------------------
    def stiffness_terms(self, p: OperatorPieces, case: str, accel: float | None = None):
        """(K₀, K₂, symmetric) CSR data with K(Ω) = K₀ + Ω² K₂ at the crank acceleration
        ``accel`` (default the scene's), held fixed while Ω varies.

        K₀ = K_s + α (T₁ + P₁) and K₂ = T₂ + N₂ + P₂ with the terms the case keeps; the
        ``structure`` case has K₂ = 0. ``symmetric`` is False when a tangential part is present
        (T₁, T₂ are skew). :meth:`qep` sums the same terms (in its own order).
        """
        t, acc = self._case(case, accel)
        K0, K2 = p.structural.copy(), np.zeros_like(p.structural)
        k_sym = True
        for name, piece in (("tangential", p.tangential), ("pseudo_normal", p.pseudo_normal)):
            if t.keeps(name):
                self._require(name, piece)
                K2 += piece[0]
                K0 += acc * piece[1]
                k_sym &= name != "tangential" or not (np.any(piece[0]) or (acc != 0.0 and np.any(piece[1])))
        if t.keeps("normal"):
            self._require("normal", p.normal)
            K2 += p.normal
        return K0, K2, k_sym

    def qep(self, p: OperatorPieces, omega: float, case: str, accel: float | None = None) -> QEP:
        """The QEP at crank speed ``omega`` (rad/s), crank acceleration ``accel`` (rad/s²;
        default the scene's) for the named case (Table 3.1).

        C = Ω G + α_d M + β_d K_s: the Coriolis term (if kept) plus the scene's Rayleigh
        structural damping, which every case keeps (a property of the links, not a motion term).
        """
        t, acc = self._case(case, accel)
        w2 = omega * omega
        rest = np.zeros_like(p.structural)  # every stiffness term but K_s
        moving = t.motion and (omega != 0.0 or acc != 0.0)
        k_sym = True
        for name, piece in (("tangential", p.tangential), ("pseudo_normal", p.pseudo_normal)):
            if moving and t.keeps(name):
                self._require(name, piece)
                part = w2 * piece[0] + acc * piece[1]
                rest += part
                # a tangential term that vanishes (e.g. a lone crank at constant speed) keeps K symmetric
                k_sym &= name != "tangential" or not np.any(part)
        if moving and t.keeps("normal") and w2 != 0.0:
            self._require("normal", p.normal)
            rest += w2 * p.normal
        data = None
        if t.keeps("coriolis") and omega != 0.0:
            self._require("coriolis", p.coriolis)
            data = omega * p.coriolis
        if p.rayleigh is not None:
            data = p.rayleigh if data is None else data + p.rayleigh
        pat = self.pattern
        C = None if data is None else pat.matrix(data)
        kind = classify(C is not None, k_sym, c_skew=p.rayleigh is None)
        return QEP(p.mass_matrix, C, pat.matrix(p.structural + rest), kind,
                   staged=p.staged, stiffness_rest=pat.matrix(rest))

    def _case(self, case: str, accel: float | None):
        """The case's term flags (Table 3.1) and the crank acceleration (default the scene's)."""
        if case not in CASES:
            raise ValueError(f"unknown case {case!r}; known: {', '.join(CASE_NAMES)}")
        return CASES[case], self.scene.driver.acceleration if accel is None else float(accel)

    def _require(self, name, piece):
        if piece is None:
            raise ValueError(
                f"term {name!r} was not assembled: build the Model with the cases that need it"
            )

    # -- geometry for drawing --------------------------------------------------------------
    def node_positions(self, theta: float) -> np.ndarray:
        """Undeformed node positions (n_node, 2) at crank angle ``theta`` (rad)."""
        mech = self.mechanism
        kin = self.kinematics(theta)
        return point_local(kin, mech.node_link, mech.node_local)[0][0]
