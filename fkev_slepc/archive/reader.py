"""Sweep archives as named arrays: :class:`SweepResults`, read with h5py (no matplotlib here).

The reader side of the archive contract (issue 4; the writer is :mod:`fkev_slepc.archive.store`).
Gridded data live in the root group, shaped (angle, speed, case, mode) or (angle, speed, case);
``/mesh`` holds the node/DOF map and the optional ``/modes`` group the mode shapes with the
undeformed node positions. Mode shapes can be large (n_free × every grid point), so they are
read lazily, one (angle, speed, case) at a time, by :meth:`SweepResults.mode_shape`.

Derived quantities follow docs/theory.md §12:

- frequency parameter ω_i(case) / ω_i(structure) at one crank angle,
- speed parameter α = Ω / ω_1(structure) at one crank angle (ω in rad/s),
- percentage error (ω_i(case) − ω_i(full)) / ω_i(full) × 100 (:func:`modes.percent_error`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.products import FORMAT as ARCHIVE_FORMAT, SUPPORTED_VERSIONS
from fkev_slepc.archive.scene_text import scene_title
from fkev_slepc.archive.verified import ArchiveError, DamagedArchiveWarning, checked  # noqa: F401 (the readers' errors)
from fkev_slepc.scene.cases import case_name
from fkev_slepc.solve.modes import percent_error
from fkev_slepc.status import Status, converged_codes

# Points whose eigenvalues are trustworthy. Unstable and divergent points converged; their
# oscillatory frequencies are real results. Pending/failed/not-converged points are masked.
ORDERS = ("sorted", "tracked")


@dataclass(frozen=True)
class NodeDofMap:
    """Node and DOF map of the model (archive group ``/mesh``).

    Every node belongs to one link (pin joints are two nodes sharing translation DOFs),
    ``node_s`` is its station along the link from the link's root (m), ``node_dofs`` its
    global (U, V, Φ) free-DOF indices with -1 for a constrained DOF, and ``elem_nodes``
    the (left, right) nodes of each element, left nearer the link's root.
    """

    node_link: np.ndarray  # (n_node,) int
    node_s: np.ndarray  # (n_node,) m
    node_dofs: np.ndarray  # (n_node, 3) int, -1 = constrained
    elem_nodes: np.ndarray  # (n_el, 2) int
    link_names: tuple[str, ...]
    node_axis: np.ndarray | None = None  # (n_node, 2) direction of U (x, or a slider's guide); None: not archived

    @property
    def n_free(self) -> int:
        return int(self.node_dofs.max()) + 1 if self.node_dofs.size else 0


@dataclass(frozen=True)
class SweepResults:
    """Everything a sweep archive holds on its (angle, speed, case, mode) grid.

    Arrays are the archive's, unmodified; use :meth:`frequency` for frequencies masked
    to converged points. Build with :func:`load`.
    """

    path: Path
    crank_angle_deg: np.ndarray  # (n_angle,)
    speed_rad_s: np.ndarray  # (n_speed,)
    cases: tuple[str, ...]
    modes: np.ndarray  # (n_mode,) 1-based
    status: np.ndarray  # (n_angle, n_speed, n_case) uint8, Status codes (status.STATUS_CODES)
    eigenvalue: np.ndarray  # (n_angle, n_speed, n_case, n_mode) complex, 1/s
    frequency_hz: np.ndarray  # same shape, sorted by frequency
    tracked_frequency_hz: np.ndarray  # same shape, modes followed along crank angle
    residual: np.ndarray  # same shape
    damping_ratio: np.ndarray  # same shape, -Re λ/|λ| (computed from eigenvalue for archives without it)
    max_real: np.ndarray  # (n_angle, n_speed, n_case) 1/s
    title: str
    scene_toml: str
    mesh: NodeDofMap | None
    has_mode_shapes: bool
    node_xy: np.ndarray | None  # (n_angle, n_node, 2) undeformed node positions, m
    attrs: dict = field(default_factory=dict)  # every root attribute, decoded
    plane = property(lambda self: str(self.attrs.get("plane", "in")))  # in/out (docs/theory.md §19); absent: in
    status_flags: dict = field(default_factory=dict)  # status value -> name (CF flag_values/flag_meanings)
    plane_names: tuple[str, ...] = ()  # the planes the file holds (a two-plane archive: in, out); () : plane
    table_plane: str = "in"  # whose table rows these arrays are: "in" (root group), "out" (/planes/out)

    # ------------------------------------------------------------------------------ planes
    @property
    def planes(self) -> tuple[str, ...]:
        """The planes of the archive: ``("in", "out")`` for a two-plane archive (``fkev run --plane
        both``), else the one plane of its sweep (``("in",)`` or, ``--plane out`` alone, ``("out",)``)."""
        return self.plane_names or (self.plane,)

    def on_plane(self, plane: str) -> "SweepResults":
        """The sweep of ``plane`` ("in" or "out") of this archive, with the same grid; this one when
        it is already that plane. ArchiveError naming ``plane`` when the archive does not hold it
        (:func:`fkev_slepc.archive.plane_view.plane_view`)."""
        from fkev_slepc.archive.plane_view import plane_view

        return plane_view(self, plane, lambda: load(self.path, type(self), verify=False))

    # ---------------------------------------------------------------- selection by labels
    @property
    def default_case(self) -> str:
        """``full`` if the archive has it, else its first case (what figures and margins show by default)."""
        return "full" if "full" in self.cases else self.cases[0]

    def angle_index(self, angle_deg: float, tol: float = 1e-6) -> int:
        """Index of crank angle ``angle_deg`` (deg, compared modulo 360)."""
        d = np.abs((self.crank_angle_deg - angle_deg + 180.0) % 360.0 - 180.0)
        i = int(np.argmin(d))
        if d[i] > tol:
            raise ArchiveError(f"angle: {angle_deg:g} deg is not on the archive's crank-angle grid "
                               f"({_describe_grid(self.crank_angle_deg)} deg)")
        return i

    def speed_index(self, speed_rad_s: float, tol: float = 1e-9) -> int:
        """Index of crank speed ``speed_rad_s`` (rad/s)."""
        d = np.abs(self.speed_rad_s - speed_rad_s)
        i = int(np.argmin(d))
        if d[i] > tol * max(1.0, abs(speed_rad_s)):
            raise ArchiveError(f"speed: {speed_rad_s:g} rad/s is not on the archive's speed grid "
                               f"({_describe_grid(self.speed_rad_s)} rad/s)")
        return i

    def case_index(self, case: str | int) -> int:
        """Index of a case given by name or Table 3.1 number."""
        try:
            name = case_name(case)
        except ValueError as exc:
            raise ArchiveError(f"case: {exc}") from None
        if name not in self.cases:
            raise ArchiveError(f"case: case {name!r} is not in this archive (it has: {', '.join(self.cases)})")
        return self.cases.index(name)

    def mode_index(self, mode: int) -> int:
        """Index of 1-based mode number ``mode``."""
        hit = np.flatnonzero(self.modes == int(mode))
        if hit.size == 0:
            raise ArchiveError(f"mode: mode {mode} is not in this archive (it has modes "
                               f"{int(self.modes.min())}..{int(self.modes.max())})")
        return int(hit[0])

    # ------------------------------------------------------------------- derived arrays
    @property
    def speeds_in_rpm(self) -> bool:
        """The run's speeds were given in rpm (scene ``speeds_rpm`` or ``--speeds-rpm``): show rpm too.

        The archived ``speed_unit``; archives written before it existed: from the scene text and
        command line."""
        unit = self.attrs.get("speed_unit")
        if unit is not None:
            return str(unit) == "rpm"
        from fkev_slepc.scene.units import speeds_given_in_rpm

        return speeds_given_in_rpm(self.scene_toml, str(self.attrs.get("command_line", "")))

    @property
    def status_names(self) -> np.ndarray:
        """(angle, speed, case) array of status names (``ok``, ``unstable``, ...), decoded with
        the archive's CF ``flag_values``/``flag_meanings`` (:class:`~fkev_slepc.status.Status` if absent)."""
        flags = self.status_flags or {s.code: s.value for s in Status}
        lookup = np.array([flags.get(v, f"unknown_{v}") for v in range(256)])
        return lookup[self.status]

    @property
    def converged(self) -> np.ndarray:
        """(angle, speed, case) bool: the point's eigenvalues converged (ok/unstable/divergent)."""
        return np.isin(self.status, converged_codes())

    def frequency(self, case: str | int | None = None, speed_rad_s: float | None = None,
                  order: str = "sorted") -> np.ndarray:
        """Frequencies (Hz), NaN where the point did not converge: (angle, speed, case, mode),
        or (angle, speed, mode) for one ``case``, (angle, case, mode) for one speed, (angle,
        mode) for both.

        ``order="sorted"``: the i-th lowest at each point (docs/theory.md §10.4);
        ``"tracked"``: modes followed along crank angle by eigenvector correlation.
        """
        if order not in ORDERS:
            raise ArchiveError(f"order: must be one of {', '.join(ORDERS)} (got {order!r})")
        f = self.frequency_hz if order == "sorted" else self.tracked_frequency_hz
        f = np.where(self.converged[..., None], f, np.nan)
        if speed_rad_s is not None:
            f = f[:, self.speed_index(speed_rad_s)]
        if case is not None:
            f = f[..., self.case_index(case), :]
        return f

    def structure_frequency(self, order: str = "sorted") -> np.ndarray:
        """ω_i(structure) in Hz, (angle, mode). Case ``structure`` does not depend on speed,
        so the median over the speeds where it converged is taken (they agree to round-off)."""
        c = self.case_index("structure")
        f = self.frequency(order=order)[:, :, c, :]
        out = np.full((f.shape[0], f.shape[2]), np.nan)
        have = np.any(np.isfinite(f), axis=1)
        out[have] = np.nanmedian(f.transpose(0, 2, 1)[have], axis=-1)
        return out

    def frequency_parameter(self, order: str = "sorted") -> np.ndarray:
        """ω_i(case) / ω_i(structure), (angle, speed, case, mode) (docs/theory.md §12)."""
        return self.frequency(order=order) / self.structure_frequency(order)[:, None, None, :]

    def speed_parameter(self) -> np.ndarray:
        """α = Ω / ω_1(structure), (angle, speed), with ω_1 the lowest structure frequency in
        rad/s at that crank angle (docs/theory.md §12)."""
        w1 = 2.0 * np.pi * self.structure_frequency("sorted")[:, 0]
        return self.speed_rad_s[None, :] / w1[:, None]

    def percent_error(self, case: str | int, order: str = "sorted") -> np.ndarray:
        """Signed % error of ``case`` against ``full``, (angle, speed, mode) (docs/theory.md §12)."""
        f = self.frequency(order=order)
        return percent_error(f[:, :, self.case_index(case), :], f[:, :, self.case_index("full"), :])

    def elements_per_link(self) -> tuple[int, ...]:
        """Elements per link (root attribute ``elements``; else counted from the mesh)."""
        el = self.attrs.get("elements")
        if el is not None:
            return tuple(int(n) for n in np.atleast_1d(el))
        if self.mesh is None:
            return ()
        links = self.mesh.node_link[self.mesh.elem_nodes[:, 0]]
        return tuple(int(np.sum(links == k)) for k in range(len(self.mesh.link_names)))

    # ------------------------------------------------------------------- run information
    def errors(self) -> list:
        """Points that failed or did not converge: ``PointError(angle_deg, speed_rad_s, case,
        status, message)`` rows from ``/errors`` (:func:`fkev_slepc.archive.views.errors`)."""
        from fkev_slepc.archive.views import errors

        return errors(self)

    def settings(self) -> dict:
        """How the archive was computed: effective solver settings, thresholds, mesh, ranks,
        software versions (:func:`fkev_slepc.archive.views.settings`)."""
        from fkev_slepc.archive.views import settings

        return settings(self)

    def to_xarray(self):
        """The gridded data as an ``xarray.Dataset`` (needs xarray): dimensions crank_angle_deg,
        speed_rad_s, case, mode; ``status`` as names ("ok", ...), ``frequency_hz`` masked to
        converged points."""
        from fkev_slepc.archive.views import to_xarray

        return to_xarray(self)

    # ------------------------------------------------------------------------ mode shapes
    def mode_shape(self, angle_index: int, speed_index: int, case_index: int) -> np.ndarray:
        """Complex mode shapes (n_free, n_mode) at one grid point, read from the archive."""
        if not self.has_mode_shapes:
            raise ArchiveError(f"{self.path}: this archive has no mode shapes; produce one with "
                               "`fkev run SCENE --mode-shapes` (or `mode_shapes = true` in the scene's [analysis])")
        import h5py

        with h5py.File(self.path, "r") as h5:
            return np.asarray(h5[P.on_plane(P.SHAPE, self.table_plane).path][angle_index, speed_index, case_index])


# ------------------------------------------------------------------------------ loading
def load(path: str | Path, cls: type[SweepResults] = SweepResults, verify: bool = True,
         plane: str | None = None) -> SweepResults:
    """Read a sweep archive into :class:`SweepResults` (or the subclass ``cls``; mode shapes
    stay on disk); ``plane`` ("in", "out"): that plane's sweep (:meth:`SweepResults.on_plane`),
    default the archive's root sweep (in plane, or the one plane of an ``--plane out`` archive).

    ``verify`` (default): check it first (:func:`fkev_slepc.archive.verify.verify`, in a child
    process): an archive whose values or attributes changed since its run finished is read
    with a :class:`DamagedArchiveWarning`; one whose metadata HDF5 cannot decode, or that a
    live run is still writing, is refused. ``verify=False`` reads without checking.

    Raises
    ------
    ArchiveError
        The file is missing, is not HDF5, is not an fkev archive of a supported version, has
        damaged metadata, or is being written.
    """
    import h5py

    path = Path(path)
    if not path.is_file():
        raise ArchiveError(f"{path}: no such archive")
    if verify:
        checked(path, stacklevel=3)
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise ArchiveError(f"{path}: not an HDF5 file ({exc})") from None
    with h5:
        attrs = {k: _decode(v) for k, v in h5.attrs.items()}
        if attrs.get("format") != ARCHIVE_FORMAT:
            raise ArchiveError(f"{path}: not an fkev archive (root attribute format={attrs.get('format')!r})")
        version = int(attrs.get("format_version", -1))
        if version not in SUPPORTED_VERSIONS:
            raise ArchiveError(f"{path}: archive format_version {version} is not supported (reader knows 1)")
        missing = [v.path for v in P.SWEEP.variables if v.required and v.path not in h5]
        if missing:
            raise ArchiveError(f"{path}: archive lacks dataset(s) {', '.join(missing)}")
        mesh = _read_mesh(h5) if P.NODE_LINK.path in h5 else None
        has_shapes = P.SHAPE.path in h5
        node_xy = np.asarray(h5[P.NODE_XY.path][()]) if has_shapes and P.NODE_XY.path in h5 else None
        scene_toml = str(attrs.get("scene_toml", ""))
        title = attrs.get("title") or scene_title(scene_toml, attrs.get("scene_source", path.stem))
        res = cls(
            path=path,
            crank_angle_deg=np.asarray(h5[P.ANGLE][()], dtype=float),
            speed_rad_s=np.asarray(h5[P.SPEED][()], dtype=float),
            cases=tuple(_strings(h5[P.CASE])),
            modes=np.asarray(h5[P.MODE][()], dtype=int),
            status=np.asarray(h5[P.STATUS_VAR.path][()], dtype=np.uint8),
            eigenvalue=np.asarray(h5[P.EIGENVALUE.path][()], dtype=complex),
            frequency_hz=np.asarray(h5[P.FREQUENCY.path][()], dtype=float),
            tracked_frequency_hz=np.asarray(h5[P.TRACKED.path][()], dtype=float),
            residual=np.asarray(h5[P.RESIDUAL.path][()], dtype=float),
            damping_ratio=_damping_ratio(h5),
            max_real=np.asarray(h5[P.MAX_REAL.path][()], dtype=float),
            title=str(title),
            scene_toml=scene_toml,
            mesh=mesh,
            has_mode_shapes=bool(has_shapes),
            node_xy=node_xy,
            attrs=attrs,
            status_flags=_flags(h5[P.STATUS_VAR.path].attrs),
            plane_names=("in", "out") if P.PLANE_OUT.status in h5 else (),
        )
    return res if plane is None else res.on_plane(plane)


def _damping_ratio(h5) -> np.ndarray:
    if P.DAMPING.path in h5:
        return np.asarray(h5[P.DAMPING.path][()], dtype=float)
    from fkev_slepc.solve.stability import damping_ratio

    return damping_ratio(h5[P.EIGENVALUE.path][()])


def solver_settings(res: SweepResults) -> dict:
    """The archived effective solver settings (root attribute ``solver_settings``, JSON)."""
    from fkev_slepc.archive.views import json_attr

    return json_attr(res.attrs.get("solver_settings"))


def _flags(attrs) -> dict[int, str]:
    """CF ``flag_values`` / ``flag_meanings`` as {value: name} (empty if the archive has none)."""
    if "flag_values" not in attrs or "flag_meanings" not in attrs:
        return {}
    names = _decode(attrs["flag_meanings"]).split()
    return {int(v): n for v, n in zip(np.atleast_1d(attrs["flag_values"]), names)}


def _read_mesh(h5) -> NodeDofMap:
    def arr(v, dtype):
        return np.asarray(h5[v.path][()], dtype=dtype) if v.path in h5 else None

    return NodeDofMap(
        node_link=arr(P.NODE_LINK, int), node_s=arr(P.NODE_S, float), node_dofs=arr(P.NODE_DOFS, int),
        elem_nodes=arr(P.ELEM_NODES, int),
        link_names=tuple(_strings(h5[P.LINKS.path])) if P.LINKS.path in h5 else (),
        node_axis=arr(P.NODE_AXIS, float),
    )


def _strings(dset) -> list[str]:
    return [_decode(v) for v in np.atleast_1d(dset[()])]


def _decode(v):
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray) and v.dtype.kind in "OS":
        return [_decode(x) for x in v.tolist()]
    return v


def _describe_grid(values: Iterable[float]) -> str:
    v = np.asarray(list(values), dtype=float)
    if v.size > 6:
        step = np.diff(v)
        if np.allclose(step, step[0]):
            return f"{v[0]:g} to {v[-1]:g} step {step[0]:g}"
        return f"{v.size} values from {v.min():g} to {v.max():g}"
    return ", ".join(f"{x:g}" for x in v)
