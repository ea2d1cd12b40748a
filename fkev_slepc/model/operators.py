"""Operators of the instantaneous structure: the Model, which builds the layers of
docs/engine.md "Vectorised pieces" once per mechanism and serves them per angle and per point.

1. angle-independent data, once: element stacks (model/stacks.py), the CSR pattern and its
   scatter positions (model/assembly.py), the kinetostatic unknowns, the gather matrix of the
   factored K_s (model/energy.py), the lumped-mass diagonal;
2. :meth:`Model.angle_state`: the rigid motion at an array of crank angles;
3. :meth:`Model.piece_stack`: the named pieces as CSR data (n_θ, nnz), and
   :meth:`Model.load_pieces`: the rigid-body inertia loads (n_θ, n_free) (model/loads.py);
4. :func:`~fkev_slepc.model.pieces.combine`, the one sum of the pieces per (Ω, α, case), behind
   :meth:`Model.qep` and :meth:`Model.stiffness_terms`.

:meth:`Model.pieces` (one angle, what the per-point solvers take) is row 0 of a one-angle stack.
Pieces of terms that no requested case keeps are never assembled.
"""

from __future__ import annotations

import dataclasses
from functools import cached_property

import numpy as np

from fkev_slepc.model import out_of_plane as oop
from fkev_slepc.model.assembly import Pattern
from fkev_slepc.model.element_types import element_type
from fkev_slepc.model.energy import StagedStiffness, gather_matrix
from fkev_slepc.model.kinematics import point_local, solve_kinematics
from fkev_slepc.model.kinetostatics import unknowns
from fkev_slepc.model.loads import LoadPieces, assemble_loads
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.model.pieces import OperatorPieces, PieceStack, assemble_pieces, combine
from fkev_slepc.model.plane import PLANES, Plane
from fkev_slepc.model.qep import GENERAL, GYROSCOPIC, LINEAR, LINEAR_SYMMETRIC, QEP
from fkev_slepc.model.stacks import AngleState, angle_state, element_stacks, node_frames
from fkev_slepc.scene import Scene
from fkev_slepc.scene.cases import CASE_NAMES, CASES, terms_used
from fkev_slepc.scene.validity import OUT_OF_PLANE_THESIS, in_plane_only

__all__ = ["AssemblyError", "LoadPieces", "Model", "OperatorPieces", "PieceStack", "classify", "node_frames"]


# Angles per block of a vectorised call: a block's element temporaries (n_angle, n_el, n_dof,
# n_dof) stay near 2**21 floats (16 MB) each, whatever the mesh.
BLOCK_FLOATS = 2**21


class AssemblyError(ValueError):
    """The linkage cannot be assembled (or is at a dead centre) at the requested crank angle."""

    @classmethod
    def at(cls, theta: float) -> "AssemblyError":
        return cls(f"the linkage cannot be assembled at crank angle {np.degrees(theta):g} deg")


def classify(has_damping: bool, k_symmetric: bool, c_skew: bool = True) -> str:
    """Problem kind from the structure of the terms present (see qep.KINDS).

    ``has_damping``: a C matrix is present; ``c_skew``: it is Coriolis only (structural damping
    makes C non-skew, and the problem is then ``general`` whatever K is)."""
    if not has_damping:
        return LINEAR_SYMMETRIC if k_symmetric else LINEAR
    return GYROSCOPIC if k_symmetric and c_skew else GENERAL


class Model:
    """A meshed mechanism with its constant element data and cached sparsity pattern.

    Parameters
    ----------
    scene : Scene
    cases : tuple of case names, optional
        The cases that will be asked for (default: the scene's); terms none of them keep are
        not assembled.
    plane : {"in", "out"}
        The in-plane problem (§4-§18) or the out-of-plane one (§19: per node θ_X, θ_Y, w; no
        Coriolis or tangential term; the normal term is the twist's propeller moment).
    section : out_of_plane.Section, optional
        Out-of-plane section data per element (default: the mechanism's, from the scene).
    bearings : dict, optional
        Out of plane: {joint name: (k_t, k_b)}, compliant joints whose links' rotations about the
        in-plane axes are tied by springs (N m/rad, about and across the first link's axis, §19.8)
        instead of shared (default: the scene's joints' ``bearing_stiffness_nm_rad``).
    """

    def __init__(self, scene: Scene, cases: tuple[str, ...] | None = None, plane: str = "in", section=None,
                 bearings: dict | None = None):
        if plane not in PLANES:
            raise ValueError(f"plane must be one of {', '.join(PLANES)} (got {plane!r})")
        kind = Plane.parse(plane)
        refusal = in_plane_only(scene, OUT_OF_PLANE_THESIS) if kind.section else None
        if refusal:
            raise ValueError(str(refusal))
        self.scene = scene
        self.plane = plane
        mech = build_mechanism(scene)
        self.cases = tuple(cases or scene.analysis.cases)
        self.element = et = element_type(scene.analysis.element)
        self.bearings = None
        if bearings and not kind.section:
            raise ValueError("bearings: compliant joints act out of plane only (plane 'out')")
        if not kind.section:
            self.stacks = element_stacks(mech, et)
            # lumped masses and rotary inertias on the mass diagonal, added in this order
            self._lumped = ((mech.mass_dofs[:, :2], mech.mass_value[:, None]), (mech.mass_dofs[:, 2], mech.mass_inertia))
        else:
            section = oop.section_of(mech, section)
            if bearings is None:  # the scene's compliant joints
                bearings = {j.name: j.bearing_stiffness for j in scene.joints if j.bearing_stiffness is not None}
            names = set(bearings)
            oop_mech = oop.out_of_plane_mechanism(mech, {i for i, n in enumerate(mech.joint_names) if n in names})
            self.bearings = oop.bearings(mech, oop_mech, bearings)
            mech = oop_mech
            self.stacks = oop.out_of_plane_stacks(mech, section)
            self._lumped = oop.lumped(mech)
        self.mechanism = mech
        self.n_free = mech.n_free
        self.pattern = Pattern(mech.elem_dofs, mech.n_free, None if self.bearings is None else self.bearings.dofs)
        self.terms = {t for t in terms_used(self.cases) if self._terms(t)}

    @property
    def lumped(self) -> tuple:
        """The lumped-mass diagonal ((dofs, values), ...), added to M in this order: masses on the
        translations and rotary inertias on Φ in plane, masses on w out of plane."""
        return self._lumped

    def case_terms(self, case: str):
        """The motion terms ``case`` keeps in this model's plane (Table 3.1; §19.6 out of plane)."""
        return self._case(case, 0.0)[0]

    @cached_property
    def kinetostatic_plan(self):
        """The kinetostatic unknowns of the mechanism (angle-independent; kinetostatics.unknowns)."""
        return unknowns(self.mechanism)

    @cached_property
    def _gather(self):
        return gather_matrix(self.mechanism.elem_dofs, self.n_free)

    # -- many angles -----------------------------------------------------------------------
    def angle_state(self, theta, with_loads: bool | None = None) -> AngleState:
        """The rigid motion at crank angles ``theta`` (rad, scalar or array; model/stacks.py).
        ``with_loads`` (default: when the pseudo-normal term is needed) adds the kinetostatics."""
        if with_loads is None:
            with_loads = "pseudo_normal" in self.terms
        return angle_state(self.mechanism, self.stacks, theta, with_loads,
                           self.kinetostatic_plan if with_loads else None)

    def piece_stack(self, theta) -> PieceStack:
        """Every piece the model's cases need at crank angles ``theta`` (rad): CSR data
        (n_θ, nnz) on :attr:`pattern` (NaN rows where ``ok`` is False). Computed in blocks of
        angles whose temporaries stay near :data:`BLOCK_FLOATS` floats each."""
        return self._by_blocks(theta, self.stack_at)

    def stack_at(self, state: AngleState, terms=None) -> PieceStack:
        """The pieces of ``terms`` (default the model's) at the angles of ``state``, the compliant bearings
        in K_s: the one assembly of M, K_s and the Rayleigh damping (the periodic coefficients take
        theirs from it, ``terms=()``: model/periodic.py)."""
        stack = assemble_pieces(self.stacks, self.pattern, state, self.terms if terms is None else set(terms),
                                self._lumped, self.scene.damping)
        bearing = self.bearing_data(state)
        return stack if bearing is None else dataclasses.replace(stack, structural=stack.structural + bearing)

    def bearing_data(self, state: AngleState) -> np.ndarray | None:
        """The compliant bearings' stiffness (n_θ, nnz) at the angles of ``state`` (None without any;
        part of K_s, not of its Rayleigh damping β K_s)."""
        if self.bearings is None:
            return None
        return self.pattern.scatter_extra(self.bearings.stack(state.kinematics.phi))

    def load_pieces(self, theta) -> LoadPieces:
        """The rigid-body inertia loads at crank angles ``theta`` (rad; model/loads.py): vectors
        (n_θ, n_free) on the DOFs of :attr:`pattern`, per Ω², per crank acceleration α and per
        unit gravity along -Y (``LoadPieces.total(Ω, α, g)`` sums them). In plane only: the rigid
        motion and gravity load nothing out of plane (§19.1)."""
        if not Plane.parse(self.plane).rigid_loads:
            raise ValueError("plane 'out' has no rigid-body loads: the rigid motion and gravity lie in the plane")
        return self._by_blocks(theta, lambda state: assemble_loads(self.mechanism, self.stacks, self.pattern, state),
                               with_loads=False)

    def _by_blocks(self, theta, build, with_loads=None):
        """``build(angle_state)`` over blocks of the angles ``theta`` whose element temporaries
        stay near :data:`BLOCK_FLOATS` floats each, joined along the angle axis."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float)).ravel()
        step = max(1, BLOCK_FLOATS // (self.stacks.n_el * self.stacks.n_dof**2))
        blocks = [build(self.angle_state(theta[i : i + step], with_loads)) for i in range(0, max(theta.size, 1), step)]
        return blocks[0] if len(blocks) == 1 else _concatenate(blocks)

    def pieces_at(self, stack: PieceStack, i: int) -> OperatorPieces:
        """Angle ``i`` of ``stack`` as the :class:`OperatorPieces` the per-point solvers take
        (with K_s factored and M as a CSR matrix); AssemblyError where the linkage cannot be
        assembled."""
        if not stack.ok[i]:
            raise AssemblyError.at(stack.theta[i])
        mech = self.mechanism
        staged = None if self.bearings is not None else StagedStiffness(  # bearings are not in the strains
            self.stacks.strain, self.stacks.strain_weight, stack.state.T[i], mech.elem_dofs, mech.n_free, self._gather)
        row = (lambda a: None if a is None else a[i])  # noqa: E731
        pair = (lambda a: None if a is None else (a[0][i], a[1][i]))  # noqa: E731
        return OperatorPieces(float(stack.theta[i]), stack.mass[i], stack.structural[i], row(stack.coriolis),
                              pair(stack.tangential), row(stack.normal), pair(stack.pseudo_normal), staged,
                              self.pattern.matrix(stack.mass[i]), row(stack.rayleigh))

    # -- per angle -------------------------------------------------------------------------
    def kinematics(self, theta: float):
        kin = solve_kinematics(self.mechanism, [theta])
        if not kin.ok[0]:
            raise AssemblyError.at(theta)
        return kin

    def pieces(self, theta: float) -> OperatorPieces:
        """Assemble every piece needed by the model's cases at crank angle ``theta`` (rad)."""
        return self.pieces_at(self.piece_stack(theta), 0)

    # -- per speed and case ----------------------------------------------------------------
    def stiffness_terms(self, p, case: str, accel: float | None = None):
        """(K₀, K₂, symmetric) CSR data with K(Ω) = K₀ + Ω² K₂ at the crank acceleration
        ``accel`` (default the scene's), held fixed while Ω varies; ``p`` is one angle's
        :class:`OperatorPieces` or a :class:`PieceStack` (then (n_θ, nnz) and (n_θ,) arrays).

        K₀ = K_s + α (T₁ + P₁) and K₂ = T₂ + N₂ + P₂ with the terms the case keeps; the
        ``structure`` case has K₂ = 0. ``symmetric`` is False when a tangential part is present
        (T₁, T₂ are skew). Both come from :func:`~fkev_slepc.model.pieces.combine`, as
        :meth:`qep`'s K does.
        """
        t, acc = self._case(case, accel)
        per_w2 = combine(p, 1.0, t, 0.0, with_damping=False)
        at_rest = combine(p, 0.0, t, acc, with_damping=False)
        return p.structural + at_rest.rest, per_w2.rest, per_w2.k_symmetric & at_rest.k_symmetric

    def qep(self, p: OperatorPieces, omega: float, case: str, accel: float | None = None) -> QEP:
        """The QEP at crank speed ``omega`` (rad/s), crank acceleration ``accel`` (rad/s²;
        default the scene's) for the named case (Table 3.1).

        C = Ω G + α_d M + β_d K_s: the Coriolis term (if kept) plus the scene's Rayleigh
        structural damping, which every case keeps (a property of the links, not a motion term).
        """
        t, acc = self._case(case, accel)
        c = combine(p, omega, t, acc)
        pat = self.pattern
        C = None if c.damping is None else pat.matrix(c.damping)
        kind = classify(C is not None, c.k_symmetric, c_skew=p.rayleigh is None)
        return QEP(p.mass_matrix, C, pat.matrix(p.structural + c.rest), kind,
                   staged=p.staged, stiffness_rest=pat.matrix(c.rest))

    def _case(self, case: str, accel: float | None):
        """The case's term flags (Table 3.1; out of plane without the Coriolis and tangential
        terms, §19.6) and the crank acceleration (default the scene's)."""
        if case not in CASES:
            raise ValueError(f"unknown case {case!r}; known: {', '.join(CASE_NAMES)}")
        t = CASES[case]
        t = dataclasses.replace(t, **{name: False for name in Plane.parse(self.plane).absent_terms})
        return t, self.scene.driver.acceleration if accel is None else float(accel)

    def _terms(self, term: str) -> bool:
        """Whether the motion term ``term`` exists in this model's plane."""
        return Plane.parse(self.plane).has_term(term)

    # -- geometry for drawing --------------------------------------------------------------
    def node_positions(self, theta: float) -> np.ndarray:
        """Undeformed node positions (n_node, 2) at crank angle ``theta`` (rad)."""
        mech = self.mechanism
        kin = self.kinematics(theta)
        return point_local(kin, mech.node_link, mech.node_local)[0][0]


def _concatenate(items):
    """Blocks of dataclasses of per-angle arrays (PieceStack, AngleState, Kinematics, Loads)
    joined along their leading (angle) axis."""
    first = items[0]
    if first is None:
        return None
    if isinstance(first, tuple):
        return tuple(_concatenate([it[k] for it in items]) for k in range(len(first)))
    if dataclasses.is_dataclass(first):
        return dataclasses.replace(first, **{f.name: _concatenate([getattr(it, f.name) for it in items])
                                             for f in dataclasses.fields(first)})
    return np.concatenate(items)
