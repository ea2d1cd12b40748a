"""Scene files: TOML -> validated, frozen dataclass tree in SI units.

This module owns the scene *schema*. It never imports PETSc, MPI or h5py.
Loading and validation (``load_scene``) collect every problem with its dotted
path and raise one :class:`SceneError`.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

END_NAMES = ("root", "tip")
# Element types (model/element_types.py): the thesis frame element (linear axial) and the
# frame element with cubic axial interpolation (docs/accuracy.md §1), the Timoshenko frame element
# (shear deformation and rotary inertia, docs/theory.md §22).
ELEMENT_NAMES = ("thesis", "cubic", "timoshenko")
THIRD = "third"  # the third joint point of a ternary link (docs/linkages.md)
# Default analysis.damping_tol. Round-off leaves |ζ| ~ 1e-10..1e-8 on undamped modes (pair
# errors 1e-14..1e-8, docs/stability.md); ζ = -1e-6 means an amplitude growth of e only after
# 1/(2π·1e-6) ≈ 160,000 cycles of the mode, far below any structural damping (ζ ~ 1e-3..1e-1).
DAMPING_TOL = 1e-6
# Default analysis.imag_tol: |Im λ| <= IMAG_TOL·|λ| is a real eigenvalue (divergence), not a frequency.
IMAG_TOL = 1e-9


@dataclass(frozen=True)
class Problem:
    """One problem in a scene: dotted field path and a message (includes the value)."""

    path: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"


class SceneError(ValueError):
    """A scene with one or more problems; ``problems`` lists them all."""

    def __init__(self, source: str, problems: list[Problem]):
        self.source = source
        self.problems = list(problems)
        n = len(self.problems)
        head = f"{source}: {n} problem{'s' if n != 1 else ''}"
        super().__init__("\n".join([head, *(f"  {p}" for p in self.problems)]))


@dataclass(frozen=True)
class Material:
    """A ``[materials.NAME]`` table (SI units; docs/response.md §2): the elastic constants a
    link takes with ``material = "NAME"`` and the strengths of the design check (None: not given)."""

    name: str
    youngs_modulus: float  # Pa
    density: float  # kg/m^3
    poisson_ratio: float | None = None  # gives the shear modulus G = E / 2(1 + ν)
    yield_strength: float | None = None  # Pa
    ultimate_strength: float | None = None  # Pa
    endurance_limit: float | None = None  # Pa, fully reversed (corrected) endurance strength


# The optional section and material fields of a Segment and a Link (None: the scene does not
# give them; the out-of-plane ones are the data of out-of-plane bending and torsion).
SECTION_EXTRAS = ("fibre_distance", "second_moment_out", "torsion_constant", "polar_moment",
                  "fibre_distance_out", "shear_modulus", "shear_coefficient", "material")


@dataclass(frozen=True)
class Segment:
    """One uniform piece of a stepped link, in order from the link's root (SI units)."""

    length: float
    elements: int
    youngs_modulus: float
    density: float
    area: float
    second_moment: float
    fibre_distance: float | None = None  # m, extreme fibre from the neutral axis (None: not given)
    second_moment_out: float | None = None  # m^4, about the in-plane axis normal to the link
    torsion_constant: float | None = None  # m^4, St-Venant J
    polar_moment: float | None = None  # m^4, I_p = I + I_out (torsional rotary inertia ρ I_p)
    fibre_distance_out: float | None = None  # m, out-of-plane extreme fibre
    shear_modulus: float | None = None  # Pa
    shear_coefficient: float | None = None  # κ of the Timoshenko element (given, or Cowper's of the shape)
    material: str | None = None  # name of its [materials] entry


@dataclass(frozen=True)
class Link:
    """A straight Euler-Bernoulli link running from its root to its tip.

    ``segments`` (empty for a uniform link) make it stepped; the uniform fields then hold the
    first segment's section, and ``length``/``elements`` the totals. ``third`` makes it ternary:
    the third joint point (x along root->tip, y to its left) in the link frame, reached by a
    branch beam (``third_elements`` elements, the uniform section) from the axis node at x.
    """

    name: str
    length: float  # m
    youngs_modulus: float  # Pa
    density: float  # kg/m^3
    area: float  # m^2
    second_moment: float  # m^4
    elements: int
    segments: tuple[Segment, ...] = ()
    third: tuple[float, float] | None = None  # m, link frame
    third_elements: int = 2
    fibre_distance: float | None = None  # m, extreme fibre (scene/shapes.py; None: not given)
    second_moment_out: float | None = None  # m^4 (the SECTION_EXTRAS as in Segment)
    torsion_constant: float | None = None  # m^4
    polar_moment: float | None = None  # m^4
    fibre_distance_out: float | None = None  # m
    shear_modulus: float | None = None  # Pa
    shear_coefficient: float | None = None  # κ (docs/theory.md §22.1)
    material: str | None = None
    buckling_length_factor: float = 1.0  # K of the Euler load π²EI/(KL)² (1: pinned ends)

    @property
    def uniform(self) -> Segment:
        """The uniform section fields as one segment of the whole length (a ternary link's branch)."""
        return Segment(self.length, self.elements, self.youngs_modulus, self.density, self.area,
                       self.second_moment, **{f: getattr(self, f) for f in SECTION_EXTRAS})

    @property
    def pieces(self) -> tuple[Segment, ...]:
        """The segments of the axis beam (one for a uniform link)."""
        return self.segments or (self.uniform,)


@dataclass(frozen=True)
class LinkEnd:
    link: str
    end: str  # "root" | "tip"


@dataclass(frozen=True)
class Joint:
    """A revolute joint between link ends, or between link ends and a ground point; or a
    prismatic joint: one link end pinned to a slider on a straight ground guide."""

    name: str
    type: str  # "revolute" | "prismatic"
    ends: tuple[LinkEnd, ...]  # the moving link ends it connects (1 or more; prismatic: 1)
    ground: tuple[float, float] | None = None  # ground pivot, or a point of the guide (m)
    assembly: str = "left"  # dyad branch: left/right of the ray P->Q; slider: ahead/behind
    guide_angle: float = 0.0  # prismatic: direction of the guide from +x (rad)
    slider_mass: float = 0.0  # prismatic: mass of the slider block (kg)
    # out of plane: rotational stiffness (about, across the first link's axis), N m/rad; None: rigid
    bearing_stiffness: tuple[float, float] | None = None

    @property
    def prismatic(self) -> bool:
        return self.type == "prismatic"


@dataclass(frozen=True)
class Driver:
    link: str
    speeds: tuple[float, ...]  # rad/s
    acceleration: float = 0.0  # rad/s^2
    speed_unit: str = "rad/s"  # how the speeds were given and are shown ("rpm": speeds_rpm); archived


@dataclass(frozen=True)
class LumpedMass:
    """A lumped mass carried by ``link``: at joint ``joint`` (one of that link's joint points)
    or, with ``joint`` None, at station ``position`` along the link's axis from its root."""

    joint: str | None
    link: str  # the link that carries it (kinetostatics, mesh node)
    mass: float  # kg
    position: float | None = None  # m from the root along the axis (when joint is None)
    inertia: float = 0.0  # kg m^2 about the mass point


@dataclass(frozen=True)
class Analysis:
    crank_angles_deg: tuple[float, ...]
    cases: tuple[str, ...]  # canonical case names (cases.CASE_NAMES order preserved as given)
    modes: int = 4
    mode_shapes: bool = False
    # Named thresholds (recorded in archives): |Im λ| <= imag_tol*|λ| is a real eigenvalue;
    # a reported mode with damping ratio ζ = -Re λ/|λ| < -damping_tol is unstable.
    imag_tol: float = IMAG_TOL
    damping_tol: float = DAMPING_TOL
    element: str = "thesis"  # one of ELEMENT_NAMES
    rel_error: float | None = None  # requested relative frequency error (solve/accuracy.py)
    gravity_m_s2: tuple[float, float] = (0.0, 0.0)  # ground frame; loads and response only (docs/response.md)


@dataclass(frozen=True)
class Damping:
    """Rayleigh structural damping C_d = α M + β K_s of the links (docs/stability.md).

    A property of the material, not of the motion: kept in every case, ``structure`` included.
    """

    mass_proportional: float = 0.0  # α, 1/s
    stiffness_proportional: float = 0.0  # β, s

    @property
    def active(self) -> bool:
        return self.mass_proportional > 0.0 or self.stiffness_proportional > 0.0

    def ratio(self, omega):
        """The modal damping ratio ζ(ω) = α/(2ω) + βω/2 of an undamped mode of ω rad/s (ω > 0; arrays too)."""
        w = np.asarray(omega, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.mass_proportional / (2.0 * w) + self.stiffness_proportional * w / 2.0


@dataclass(frozen=True)
class Drive:
    """The scene's ``[drive]`` (docs/theory.md §20.1): the motor's torque against its shaft speed as
    straight lines through the points (``speeds`` rad/s, ``torques`` N m), extended by the end
    segments (a stall-torque/no-load-speed motor is the two points (0, T_s), (ω_0, 0)); motor and
    flywheel inertia on the motor shaft, which turns ``gear_ratio`` times as fast as the crank;
    the drive shaft's torsional stiffness (None: rigid) and damping."""

    speeds: tuple[float, ...]  # motor shaft, rad/s, increasing
    torques: tuple[float, ...]  # N m
    motor_inertia: float = 0.0  # kg m², on the motor shaft
    flywheel_inertia: float = 0.0  # kg m², on the motor shaft
    gear_ratio: float = 1.0  # motor speed / crank speed
    shaft_stiffness: float | None = None  # N m/rad; None: a rigid shaft
    shaft_damping: float = 0.0  # N m s/rad
    table: bool = False  # given as motor_torque_table (else stall torque and no-load speed)

    @property
    def inertia(self) -> float:
        """J_d = n² (J_m + J_f): the motor side's inertia seen at the crank, kg m²."""
        return self.gear_ratio**2 * (self.motor_inertia + self.flywheel_inertia)

    @property
    def motor_field(self) -> str:
        """The scene key that gives the motor (named when the motor cannot turn the linkage)."""
        return "drive.motor_torque_table" if self.table else "drive.motor_stall_torque_n_m"

    def _segment(self, w):
        x, y = np.asarray(self.speeds), np.asarray(self.torques)
        i = np.clip(np.searchsorted(x, w, side="right") - 1, 0, x.size - 2)
        slope = (y[i + 1] - y[i]) / (x[i + 1] - x[i])
        return i, slope, y[i] + slope * (w - x[i])

    def motor_torque(self, w):
        """T_m at motor speeds ``w`` (rad/s; arrays too), N m."""
        return self._segment(np.asarray(w, dtype=float))[2]

    def motor_slope(self, w):
        """dT_m/dω_m at motor speeds ``w``, N m s."""
        return self._segment(np.asarray(w, dtype=float))[1]

    def motor_change(self, w, dw):
        """T_m(w + dw) − T_m(w) without cancellation: slope·dw within one segment."""
        w, dw = np.asarray(w, dtype=float), np.asarray(dw, dtype=float)
        i, slope, t0 = self._segment(w)
        j, _, t1 = self._segment(w + dw)
        return np.where(i == j, slope * dw, t1 - t0)


@dataclass(frozen=True)
class Solver:
    method: str = "auto"  # "auto" | "slepc" | "dense"
    petsc: tuple[tuple[str, str], ...] = ()  # [solver.petsc] table, option name without "fkev_"


@dataclass(frozen=True)
class Scene:
    title: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    driver: Driver
    masses: tuple[LumpedMass, ...] = ()
    analysis: Analysis = field(default_factory=lambda: Analysis((0.0,), ("full",)))
    solver: Solver = field(default_factory=Solver)
    damping: Damping = field(default_factory=Damping)
    materials: tuple[Material, ...] = ()
    process_loads: tuple = ()  # [[loads]]: scene/process_loads.py ProcessLoad items
    drive: Drive | None = None  # [drive] (scene/drive.py); None: the crank turns at constant speed
    source_text: str = ""  # the TOML text, verbatim (archived)
    source: str = "<scene>"  # file name, for messages

    def material(self, name: str | None) -> Material | None:
        """The ``[materials]`` entry called ``name`` (None for None)."""
        return next((m for m in self.materials if m.name == name), None)


def with_elements(scene: Scene, elements: tuple[int, ...] | int) -> Scene:
    """Return ``scene`` with its links re-meshed (``--elements N`` or ``n1,n2,...``), its title
    followed by the :func:`mesh_tag` of the new mesh."""
    if isinstance(elements, int):
        elements = (elements,) * len(scene.links)
    if len(elements) != len(scene.links):
        raise SceneError(
            scene.source,
            [Problem("elements", f"needs 1 or {len(scene.links)} values (got {len(elements)})")],
        )
    bad = [Problem(f"elements[{i}]", f"must be >= 1 (got {n})") for i, n in enumerate(elements) if n < 1]
    if bad:
        raise SceneError(scene.source, bad)
    links = tuple(_remesh(lk, int(n)) for lk, n in zip(scene.links, elements))
    new = [lk.elements for lk in links]
    if new == [lk.elements for lk in scene.links]:
        return replace(scene, links=links)
    base = REMESHED.sub("", scene.title)  # re-meshed again: one tag, the last mesh's
    # the title heads every report, figure and archive: it names the mesh analysed, not the file's
    return replace(scene, links=links, title=f"{base} {mesh_tag(new)}")


REMESHED = re.compile(r" \[re-meshed: [^\]]*\]$")  # a title's mesh tag (:func:`mesh_tag`)


def mesh_label(elements) -> str:
    """``12 el (4+4+4)``: a mesh by its elements per link."""
    el = [int(n) for n in elements]
    return f"{sum(el)} el ({'+'.join(map(str, el))})"


def mesh_tag(elements) -> str:
    """``[re-meshed: 12 el (4+4+4)]``: the mesh of a re-meshed scene, after its title."""
    return f"[re-meshed: {mesh_label(elements)}]"


def _remesh(link: Link, n: int) -> Link:
    """``link`` with ``n`` axis elements; a stepped link shares them among its segments in
    proportion to their lengths (at least one each)."""
    if not link.segments:
        return replace(link, elements=n)
    share = [max(1, round(n * s.length / link.length)) for s in link.segments]
    segments = tuple(replace(s, elements=k) for s, k in zip(link.segments, share))
    return replace(link, segments=segments, elements=sum(share))
