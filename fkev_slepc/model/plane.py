"""The two problems of a planar linkage as objects: :data:`IN`, the in-plane problem (docs/theory.md
§4-§18), and :data:`OUT`, bending out of the plane and torsion (§19).

A plane travels through the code, the CLI (``--plane``) and the archives (root attribute ``plane``) as its
:attr:`Plane.name`, ``"in"`` or ``"out"``; what differs between the two problems is asked of the object
(``Plane.parse(name).has_term("coriolis")``), never by comparing the name, so that this module is the one
place that says what each plane is (tests/test_layout.py::test_planes_are_not_compared_by_name).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Plane:
    """One of the two problems (:data:`IN`, :data:`OUT`); get one with :meth:`parse`."""

    name: str  # "in" / "out": the value of --plane and of the archives' attribute plane
    label: str  # "in plane" / "out of plane": figures and messages
    dof_labels: tuple[str, ...]  # the DOFs of a node, in the model's order
    absent_terms: tuple[str, ...]  # motion terms identically zero in this plane (§19.6)
    primary: bool  # the default plane: of every command, of the root sweep of a two-plane archive, of
    #                archive names without a suffix, left unmentioned in messages
    section: bool  # built from the out-of-plane section data and the joints' bearing springs (§19.7-§19.8)
    rigid_loads: bool  # the rigid-body motion and gravity load it (model/loads.py; not out of plane, §19.1)
    flutter: bool  # frozen-time flutter possible (out of plane K is symmetric, C absent or dissipative: §19.6)
    sensitivities: bool  # eigenvalue sensitivities to scene keys exist (solve/sensitivity.py: in plane only)
    accuracy_plan: bool  # the rel_error accuracy plan applies (solve/accuracy.py: in plane only)
    weighted_signatures: bool  # tracking weighs eigenvector entries by √M_ii (sweep/tracking.py)
    transverse: bool  # its DOFs move the linkage across its plane: shapes drawn as w along the links
    #                   (plots/out_of_plane.py), a node's displacement given as (w, θ_X, θ_Y)

    @property
    def dofs_per_node(self) -> int:
        return len(self.dof_labels)

    @property
    def suffix(self) -> str:
        """What the plane adds to a default archive name: ``four-bar.h5``, ``four-bar-out.h5``."""
        return "" if self.primary else f"-{self.name}"

    def has_term(self, term: str) -> bool:
        """Whether the motion term ``term`` (a field of scene/cases.py's terms) exists in this plane."""
        return term not in self.absent_terms

    @classmethod
    def parse(cls, value, field: str = "plane") -> "Plane":
        """The plane named ``value`` (a name or a Plane); ValueError naming ``field`` and the value else."""
        if isinstance(value, Plane):
            return value
        plane = BY_NAME.get(value) if isinstance(value, str) else None
        if plane is None:
            raise ValueError(f"{field}: {unknown_plane(value)}")
        return plane


IN = Plane("in", "in plane", ("u", "v", "φ"), (), primary=True, section=False, rigid_loads=True, flutter=True,
           sensitivities=True, accuracy_plan=True, weighted_signatures=False, transverse=False)
OUT = Plane("out", "out of plane", ("θ_X", "θ_Y", "w"), ("coriolis", "tangential"), primary=False, section=True,
            rigid_loads=False, flutter=False, sensitivities=False, accuracy_plan=False, weighted_signatures=True,
            transverse=True)
BY_NAME = {p.name: p for p in (IN, OUT)}
PLANES = tuple(BY_NAME)  # the names, in order: ("in", "out")
BOTH = "both"  # fkev run --plane both: the two planes in one archive


def unknown_plane(value) -> str:
    """The message for a value that names no plane."""
    return f"must be one of {', '.join(PLANES)} (got {value!r})"


def planes_of(choice, field: str = "plane") -> tuple[Plane, ...]:
    """The planes a sweep's ``choice`` solves: one plane by its name, or both (``"both"``), in plane first."""
    return tuple(BY_NAME.values()) if choice == BOTH else (Plane.parse(choice, field),)
