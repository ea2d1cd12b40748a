"""The archive's products, declared once: every dataset of an fkev archive is a row of a table here.

A :class:`Var` row names a dataset by its path and gives its dimensions (the paths of the
dimension scales of its axes), dtype, units, long name and fill value. A :class:`Product` is a
set of rows written by one kind of run, with its *unit of work*: the leading dimensions
(``unit_dims``) that one rank solves at a time, and the dimensions of the points inside one
unit (``point_dims``). The sweep of ``fkev run`` has one crank angle as its unit and
(speed, case) points in it; a Floquet analysis would have (speed, case) units and no points
inside, a design study one design point.

Every module that creates, writes, reads or verifies an archive takes its dataset names,
shapes and attributes from these tables (``store.create``, ``writer.Writer``,
``reader.load``, ``verify.verify``, ``sweep.runner``, ``sweep.session``); no dataset name is
spelled anywhere else (``tests/test_layout.py`` checks it), and docs/archive.md is checked
against a real archive by ``tests/test_archive_layout.py``. A new product is one more table:
see docs/archive.md, "Adding a product".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.archive.product_types import (  # noqa: F401 (the tables' vocabulary, re-exported)
    ANGLE, CASE, CNAN, FORMAT, FORMAT_VERSION, MESSAGE, MESSAGE_BYTES, MODE, SPEED, STATUS, STRING,
    SUPPORTED_VERSIONS, ErrorTable, Product, Var, error_table,
)


# ------------------------------------------------------------------------------ the sweep
GRID3 = (ANGLE, SPEED, CASE)
GRID4 = GRID3 + (MODE,)
_STATUS_DESCRIPTION = (
    "convergence first: pending (not solved yet), failed (the solver raised), not_converged "
    "(fewer modes than asked or the solver stopped short); a converged point is divergent if "
    "its spectrum has a positive real eigenvalue anywhere, else unstable if a reported mode has "
    "damping_ratio < -damping_tol, else ok.")
# What each verdict covers (attribute of status): the archive never implies the whole spectrum from the lowest modes.
STABILITY_SCOPE = ("divergent: whole spectrum (a real eigenvalue > 0 anywhere; solve/stability.py); "
                   "unstable and damping_ratio: the reported modes only")

SCALES = (
    Var(ANGLE, (ANGLE,), "f8", "degree", "crank angle", scale=True, required=True, source="angles_deg"),
    Var(SPEED, (SPEED,), "f8", "rad/s", "crank speed", scale=True, required=True, source="speeds"),
    Var(CASE, (CASE,), STRING, "1", "case of Table 3.1 (terms kept)", scale=True, required=True, source="cases"),
    Var(MODE, (MODE,), "i4", "1", "mode number, 1-based", scale=True, required=True, source="modes"),
)
FREQUENCY = Var("frequency_hz", GRID4, "f8", "Hz", "natural frequency Im(lambda)/2pi, modes sorted by frequency",
                np.nan, required=True, source="frequency_hz")
TRACKED = Var("tracked_frequency_hz", GRID4, "f8", "Hz",
              "natural frequency, modes followed along crank angle (MAC)", np.nan, required=True)
SPEED_TRACKED = Var("speed_tracked_frequency_hz", GRID4, "f8", "Hz",
                    "natural frequency, modes followed along crank speed (MAC)", np.nan)
EIGENVALUE = Var("eigenvalue", GRID4, "c16", "1/s", "eigenvalue lambda of the mode (Im > 0 member)", CNAN,
                 required=True, source="eigenvalue")
RESIDUAL = Var("residual", GRID4, "f8", "1",
               "relative residual |P(lambda)x| / (|Kx| + |lambda||Cx| + |lambda|^2|Mx|)", np.nan,
               required=True, source="residual")
DAMPING = Var("damping_ratio", GRID4, "f8", "1",
              "damping ratio zeta = -Re(lambda)/|lambda| of the mode (< 0: growing)", np.nan, source="damping_ratio")
MAX_REAL = Var("max_real", GRID3, "f8", "1/s", "max Re(lambda) over the reported modes and the positive real "
               "eigenvalues located in the whole spectrum", np.nan, required=True, source="max_real")
STATUS_VAR = Var("status", GRID3, STATUS, "1", "outcome of the point", 0, required=True, source="status",
                 attrs={"description": _STATUS_DESCRIPTION, "stability_scope": STABILITY_SCOPE})
TRANSMISSION = Var("transmission_angle_deg", (ANGLE,), "f8", "degree",
                   "smallest transmission angle of the linkage's dyads, folded to [0, 90] (90 ideal, 0 a toggle "
                   "position; NaN without dyads or where the linkage cannot be assembled)", np.nan,
                   needs="transmission")
ERRORS = error_table("errors", ("angle", "speed", "case"))

# /mesh: sources are attributes of model.mechanism.Mechanism
NODE, ELEMENT, COMPONENT, END, XY = "mesh/node", "mesh/element", "mesh/component", "mesh/end", "mesh/xy"
LINK_NAMES = "mesh/link_names"
LINKS = Var(LINK_NAMES, (LINK_NAMES,), STRING, "1", "link names in scene order", scale=True, needs="mechanism",
            source="link_names")
NODE_LINK = Var("mesh/node_link", (NODE,), "i8", "1", "link of each node (index into link_names)", needs="mechanism",
                source="node_link")
NODE_S = Var("mesh/node_s", (NODE,), "f8", "m", "station of the node along its link, from the link's root",
             needs="mechanism", source="node_s")
NODE_DOFS = Var("mesh/node_dofs", (NODE, COMPONENT), "i8", "1",
                "free DOF index of (U, V, Phi) at each node, -1 if constrained", needs="mechanism", source="node_dofs")
ELEM_NODES = Var("mesh/elem_nodes", (ELEMENT, END), "i8", "1", "(left, right) node of each element", needs="mechanism",
                 source="elem_nodes")
NODE_AXIS = Var("mesh/node_axis", (NODE, XY), "f8", "1", "unit direction of the node's first translational DOF (U): "
                "x, or the guide of a slider node; V is normal to it", needs="node_axis", source="node_axis")
MESH = (
    LINKS,
    Var(NODE, (NODE,), "i4", "1", "node number", scale=True, needs="mechanism"),
    Var(ELEMENT, (ELEMENT,), "i4", "1", "element number", scale=True, needs="mechanism"),
    Var(COMPONENT, (COMPONENT,), STRING, "1", "nodal DOF (translations, rotation)", scale=True, needs="mechanism",
        values=("U", "V", "Phi")),
    Var(END, (END,), STRING, "1", "element end", scale=True, needs="mechanism", values=("left", "right")),
    NODE_LINK, NODE_S, NODE_DOFS, ELEM_NODES,
    Var(XY, (XY,), STRING, "1", "coordinate", scale=True, needs="node_axis", values=("x", "y")),
    NODE_AXIS,
)
MESH_ARRAYS = tuple(v for v in MESH if v.source is not None and not v.scale)

# /tracking
DOFS = "tracking/dofs"
TRACKING = (
    Var(DOFS, (DOFS,), "i4", "1", "free DOF index of the kept entries", scale=True, needs="signatures",
        source="tracking_dofs"),
    Var("tracking/signature", GRID3 + (DOFS, MODE), "c16", "1", "eigenvector entries of each sorted mode at `dofs`"
        " (out of plane weighted by sqrt(M_ii), docs/tracking.md)",
        CNAN, needs="signatures", source="shapes", rows=DOFS),
)
FALLBACK = Var("tracking/fallback", (SPEED, CASE), "u1", "1",
               "1: the (speed, case) line is in sorted order in tracked_frequency_hz (ambiguous MAC)",
               needs="tracked", source="fallback")
SPEED_FALLBACK = Var("tracking/speed_fallback", (ANGLE, CASE), "u1", "1",
                     "1: the (angle, case) line is in sorted order in speed_tracked_frequency_hz (ambiguous MAC)",
                     needs="speed_tracked", source="speed_fallback")
R_ANGLE = "tracking/refined/crank_angle_deg"
_R3 = (R_ANGLE, SPEED, CASE)
REFINED = (
    Var(R_ANGLE, (R_ANGLE,), "f8", "degree", "extra crank angle (tracking refinement)", scale=True, needs="refined",
        source="angles_deg"),
    Var("tracking/refined/frequency_hz", _R3 + (MODE,), "f8", "Hz", "natural frequency, sorted", needs="refined", source="freq"),
    Var("tracking/refined/tracked_frequency_hz", _R3 + (MODE,), "f8", "Hz",
        "natural frequency, tracked along crank angle", needs="refined", source="tracked"),
    Var("tracking/refined/eigenvalue", _R3 + (MODE,), "c16", "1/s", "eigenvalue lambda of the sorted mode",
        needs="refined", source="eigenvalue"),
    Var("tracking/refined/status", _R3, STATUS, "1", "outcome of the point (pending: line not refined here)",
        needs="refined", source="status"),
    Var("tracking/refined/signature", _R3 + (DOFS, MODE), "c16", "1",
        "eigenvector entries of each sorted mode at /tracking/dofs", needs="refined", source="sig"),
)

# /modes
FREE_DOF, M_NODE, M_XY = "modes/free_dof", "modes/node", "modes/xy"
MODES = (
    Var(FREE_DOF, (FREE_DOF,), "i4", "1", "free DOF index", scale=True, needs="shapes"),
    Var(M_NODE, (M_NODE,), "i4", "1", "node number", scale=True, needs="shapes"),
    Var(M_XY, (M_XY,), STRING, "1", "coordinate", scale=True, needs="shapes", values=("x", "y")),
    Var("modes/shape", GRID3 + (FREE_DOF, MODE), "c16", "1", "mode shape over the free DOFs, max |entry| = 1 and real",
        CNAN, needs="shapes", source="shapes"),
    Var("modes/node_xy", (ANGLE, M_NODE, M_XY), "f8", "m", "undeformed node positions at each crank angle", np.nan,
        needs="shapes", source="node_xy"),
)
SIGNATURE, SHAPE, NODE_XY = TRACKING[1], MODES[3], MODES[4]

SWEEP = Product(
    name="sweep",
    unit_dims=(ANGLE,),
    point_dims=(SPEED, CASE),
    status=STATUS_VAR.path,
    variables=SCALES + (FREQUENCY, TRACKED, SPEED_TRACKED, EIGENVALUE, RESIDUAL, DAMPING, MAX_REAL, TRANSMISSION,
                        STATUS_VAR) + ERRORS.rows + MESH + TRACKING + (FALLBACK, SPEED_FALLBACK) + REFINED + MODES,
    errors=ERRORS,
    groups={
        "errors": "messages of failed and not-converged points (one row per point)",
        "tracking": "eigenvector entries at the free DOFs `dofs`, used to follow modes between neighbouring crank "
                    "angles by MAC",
        "tracking/refined": "extra crank angles solved only for mode tracking, where the MAC between neighbouring "
                            "grid angles was ambiguous; points of lines that were not refined at an angle are pending",
    },
)

# ------------------------------------------------------------------------- a design study
# One unit of work per design point (values of scene keys, fkev_slepc/design/study.py): the sweep's
# grid at every design point, and the lowest divergence speed over the crank angles.
D_POINT, D_KEY = "design/point", "design/key"
D_GRID = (D_POINT, ANGLE, SPEED, CASE)
D_VALUE = Var("design/value", (D_POINT, D_KEY), "f8", "SI", "value of each design key at the design point", np.nan)
D_FREQUENCY, D_EIGENVALUE, D_DAMPING, D_MAX_REAL = (
    Var("design/" + v.name, D_GRID + v.dims[3:], v.dtype, v.units, v.long_name, v.fill, source=v.source)
    for v in (FREQUENCY, EIGENVALUE, DAMPING, MAX_REAL))
D_STATUS = Var("design/status", D_GRID, STATUS, "1", "outcome of the point", 0, source="status", attrs=STATUS_VAR.attrs)
D_DIVERGENCE = Var("design/divergence_speed_rad_s", (D_POINT, CASE), "f8", "rad/s", "lowest crank speed at which "
                   "K(Omega) is singular (divergence, buckling) over the crank angles (NaN: none)", np.nan,
                   source="divergence_speed")
D_DIVERGENCE_ANGLE = Var("design/divergence_angle_deg", (D_POINT, CASE), "f8", "degree",
                         "crank angle where that lowest divergence speed occurs", np.nan, source="divergence_angle")
D_ERRORS = error_table("design/errors", ("design", "angle", "speed", "case"))
# The design check of each design point over the study's crank angles (fkev_slepc/design/point_checks.py):
# kinetostatic columns always, the stress ones with --stress, d/d(design key) of the smooth ones with --sensitivity.
D_LINK, D_JOINT = "design/link", "design/joint"


def _column(name, dims, units, long_name, needs=""):
    return Var("design/" + name, (D_POINT,) + dims, "f8", units, long_name, np.nan, needs=needs, source=name)


D_TORQUE_MIN = _column("torque_min_n_m", (SPEED,), "N m", "smallest driving torque over the crank angles (fkev loads)")
D_TORQUE_MAX = _column("torque_max_n_m", (SPEED,), "N m", "largest driving torque over the crank angles (fkev loads)")
D_JOINT_PEAK = _column("peak_joint_force_n", (SPEED, D_JOINT), "N",
                       "largest |joint force| over the crank angles (fkev loads peak_n)")
D_PIN_PEAK = _column("peak_pin_force_n", (SPEED, D_JOINT), "N", "largest |wrist-pin force| of a prismatic joint over "
                     "the crank angles (fkev loads pin_peak_n; NaN at other joints)")
D_BUCKLING = _column("buckling_sf", (SPEED, D_LINK), "1", "weak-axis Euler factor P_cr/|N_min| (NaN: never in "
                     "compression or no out-of-plane section)")
D_MIN_AXIAL = _column("min_axial_force_n", (SPEED, D_LINK), "N",
                      "most compressive kinetostatic axial force N_min over the link and the crank angles")
D_PEAK_STRESS = _column("peak_stress_pa", (SPEED, CASE, D_LINK), "Pa", "peak |sigma| of the periodic response along "
                        "the link over the crank angles (fkev design-check)", needs="stress")
D_STATIC_SF = _column("static_sf", (SPEED, CASE, D_LINK), "1", "static safety factor against yield (fkev design-check; "
                      "NaN: no yield strength or no stress)", needs="stress")
D_FATIGUE_SF = _column("fatigue_sf", (SPEED, CASE, D_LINK), "1", "fatigue safety factor at the link's critical point "
                       "(fkev design-check; criterion in the attribute fatigue_criterion)", needs="stress")
D_SMOOTH = (D_TORQUE_MIN, D_TORQUE_MAX, D_JOINT_PEAK, D_PIN_PEAK, D_BUCKLING)  # the columns with sensitivities
D_SENSITIVITY = tuple(Var("design/sensitivity/" + v.name, (D_POINT, D_KEY) + v.dims[1:], "f8", v.units + " per key unit",
                          "derivative with respect to the design key (central difference) of " + v.name, np.nan,
                          needs="sensitivity", source="d_" + v.name) for v in D_SMOOTH)
DESIGN = Product(
    name="design", unit_dims=(D_POINT,), point_dims=(ANGLE, SPEED, CASE), status=D_STATUS.path,
    variables=(Var(D_POINT, (D_POINT,), "i4", "1", "design point number", scale=True),
               Var(D_KEY, (D_KEY,), STRING, "1", "design key (a scene key path, e.g. links[1].length_m)", scale=True),
               D_VALUE, D_FREQUENCY, D_EIGENVALUE, D_DAMPING, D_MAX_REAL, D_STATUS, D_DIVERGENCE, D_DIVERGENCE_ANGLE,
               Var(D_LINK, (D_LINK,), STRING, "1", "link names in scene order", scale=True),
               Var(D_JOINT, (D_JOINT,), STRING, "1", "joint names in scene order", scale=True),
               D_TORQUE_MIN, D_TORQUE_MAX, D_JOINT_PEAK, D_PIN_PEAK, D_BUCKLING, D_MIN_AXIAL,
               D_PEAK_STRESS, D_STATIC_SF, D_FATIGUE_SF) + D_SENSITIVITY
    + D_ERRORS.rows, errors=D_ERRORS,
    groups={"design": "a design study (fkev design): the sweep's grid at each design point (values of scene keys); "
                      "the root sweep is the scene as written", "design/errors": "messages of failed design points",
            "design/sensitivity": "derivatives of the kinetostatic columns with respect to each design key "
                                  "(fkev design --sensitivity)"},
)


from fkev_slepc.archive.products_floquet import (  # noqa: E402 (the /floquet product's table)
    BAND_ROWS, F_BAND, F_INDEX, F_STATUS, FLOQUET, FLOQUET_ERRORS, MAX_ABS_MULTIPLIER, MULTIPLIER, MULTIPLIER_ERROR,
)

from fkev_slepc.archive.products_response import (  # noqa: E402 (the /response product's table)
    PEAK_CHORD, PEAK_MOMENT, PEAK_STRESS, PEAK_TRANSVERSE, R_ERROR, R_ERRORS, R_HARMONICS, R_HB_ERROR, R_MAX_ABS,
    R_MEAN_FREQUENCY, R_MODE, R_SHOOTING_STEPS, R_STATION, R_STATUS, RESPONSE, STATION_LINK, STATION_S,
)

from fkev_slepc.archive.products_planes import OUT as PLANE_OUT_GROUP, plane_product  # noqa: E402
from fkev_slepc.model.plane import Plane  # noqa: E402

# /planes/out: the out-of-plane sweep of a two-plane archive; PLANE_OUT_PATHS: sweep path -> its path there
PLANE_OUT, PLANE_OUT_PATHS = plane_product(FREQUENCY, TRACKED, EIGENVALUE, RESIDUAL, DAMPING, MAX_REAL,
                                           STATUS_VAR, SIGNATURE, FALLBACK, SHAPE, NODE_DOFS, DOFS, FREE_DOF, COMPONENT,
                                           NODE, (SPEED_TRACKED, SPEED_FALLBACK) + REFINED)


def on_plane(v: Var, plane: str) -> Var:
    """The row of ``plane`` ("in": the sweep's own ``v``; "out": its copy in :data:`PLANE_OUT`)."""
    return v if Plane.parse(plane).primary else PLANE_OUT.var(f"{PLANE_OUT_GROUP}/{v.path}")


PRODUCTS = (SWEEP, DESIGN, FLOQUET, RESPONSE, PLANE_OUT)  # every product of the format; docs/archive.md lists their datasets


# -------------------------------------------------------------------- root attributes
@dataclass(frozen=True)
class Attr:
    """A root attribute: name, units and meaning (docs/archive.md, "Root attributes")."""

    name: str
    units: str
    meaning: str


ROOT_ATTRS = (
    Attr("format", "", f"`{FORMAT}`"),
    Attr("format_version", "", f"{FORMAT_VERSION}"),
    Attr("created", "", "ISO 8601, UTC"),
    Attr("complete", "", "1 once every point was attempted and the file renamed into place, else 0"),
    Attr("title", "", "the scene's title (figure and report headings), ending in the mesh tag "
         "\"[re-meshed: 12 el (4+4+4)]\" for a run with --elements"),
    Attr("scene_toml", "", "the scene file, verbatim"),
    Attr("scene_source", "", "its path"),
    Attr("command_line", "", "of the run that created the file"),
    Attr("last_command_line", "", "of the run that completed it"),
    Attr("element", "", "element type of the mesh (`analysis.element`)"),
    Attr("elements", "", "elements per link, scene order"),
    Attr("n_free", "", "free DOFs (length of a mode shape)"),
    Attr("plane", "", "`in`: the in-plane problem; `out`: bending out of the plane and torsion, DOFs (θ_X, θ_Y, w) "
         "per node (docs/theory.md §19); absent in archives written before it: `in`"),
    Attr("mode_shapes", "", "0/1: `/modes` holds mode shapes"),
    Attr("speed_unit", "", "unit the speeds were given in and are shown in: `rad/s` or `rpm` (stored in rad/s)"),
    Attr("damping_alpha", "1/s", "Rayleigh damping, mass-proportional coefficient α (0: none)"),
    Attr("damping_beta", "s", "Rayleigh damping, stiffness-proportional coefficient β (0: none)"),
    Attr("imag_tol", "", "|Im λ| ≤ imag_tol·|λ| is a real eigenvalue"),
    Attr("damping_tol", "", "a mode with ζ < −damping_tol is growing (`unstable`)"),
    Attr("solver_settings", "", "JSON: the engine's effective settings when the archive was created"),
    Attr("last_solver_settings", "", "JSON: the same, from rank 0's engine at the end of the run that completed it"),
    Attr("accuracy", "", "JSON: the mesh plan of `--rel-error` (when asked)"),
    Attr("n_ranks", "", "MPI ranks of the last run"),
    Attr("wall_time_s", "s", "summed over the runs that wrote the archive"),
    Attr("tracking_open_loops", "", "(speed, case) lines whose modes come back permuted after a revolution"),
    Attr("fkev_version", "", "software versions of the run that created the file"),
    Attr("petsc_version", "", ""),
    Attr("slepc_version", "", ""),
    Attr("mpi_version", "", ""),
    Attr("h5py_version", "", ""),
    Attr("hdf5_version", "", ""),
    Attr("attrs_sha256", "", "SHA-256 of the root attributes (archive/verify.py)"),
)


def datasets(products=None) -> tuple[Var, ...]:
    """Every dataset of the given products (default :data:`PRODUCTS`; scales included), each once."""
    seen: dict[str, Var] = {}
    for p in PRODUCTS if products is None else products:
        for v in p.variables:
            seen.setdefault(v.path, v)
    return tuple(seen.values())


def find(path: str) -> Var | None:
    """The table row of an archive path (a leading ``/`` allowed), or None."""
    path = path.lstrip("/")
    return next((v for v in datasets() if v.path == path), None)


# ------------------------------------------------------------------------- the sweep grid
@dataclass(frozen=True)
class Grid:
    """The sweep grid: crank angles (deg), speeds (rad/s), case names, modes per point."""

    angles_deg: np.ndarray
    speeds: np.ndarray
    cases: tuple[str, ...]
    n_modes: int

    @property
    def shape(self) -> tuple[int, int, int]:
        return (len(self.angles_deg), len(self.speeds), len(self.cases))

    @property
    def n_points(self) -> int:
        return int(np.prod(self.shape))

    def index(self, flat) -> tuple:
        """(angle, speed, case) indices of flat point number(s), C order (case fastest)."""
        return np.unravel_index(flat, self.shape)

    def scale_values(self) -> dict:
        """Values of the sweep's grid scales, by path."""
        return {ANGLE: np.asarray(self.angles_deg, "f8"), SPEED: np.asarray(self.speeds, "f8"),
                CASE: list(self.cases), MODE: np.arange(1, self.n_modes + 1, dtype="i4")}
