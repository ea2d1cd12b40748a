"""The HDF5 sweep archive (writer side of the archive contract).

The reader is ``fkev_slepc/archive/reader.py``.

Layout (see ``docs/archive.md``): the grid scales ``crank_angle_deg``, ``speed_rad_s``,
``case``, ``mode`` and every gridded dataset live in the root group, which is what xarray's
h5netcdf engine needs to open the file as one labelled Dataset. ``/errors``, ``/mesh``,
``/tracking`` and the optional ``/modes`` group hold what is not on that grid.

Life cycle of a run:

1. :func:`create` (rank 0, serial driver) writes every dataset at full size, filled with NaN /
   ``pending``, with its storage allocated at once, under the temporary name
   :func:`partial_path`. Rank 0 does this alone because parallel HDF5 1.10 cannot write
   variable-length strings (the ``case`` scale, ``/mesh/link_names``); the other ranks wait
   at a barrier, so the file exists at full size before any solve.
2. :class:`archive_writer.Writer` (every rank) opens it again: with the ``mpio`` driver when h5py has MPI and
   there is more than one rank (each rank writes its own points with independent hyperslab
   writes; ``flush`` and the resizing of ``/errors`` are collective), otherwise only rank 0
   opens it and the others send it their results at each sync. The results of an angle are
   written when it completes (mpio) or at the next sync (rank 0); their ``status`` only at the
   sync, after a first flush has put the data on disk, so a point marked done after a crash
   always has its data. Syncs come about every 2 s of work.
3. :func:`finalize` (rank 0, serial) writes the run attributes, drops stale error rows, and
   renames the file to its final name (the tracked frequencies are already written, by
   :func:`fkev_slepc.archive.tracks.write_tracking`).

Resuming (:func:`open_for_resume`) reopens the temporary file (or moves a finished archive
back to it), refuses when the scene or grid differ, and lists the points left to do.
"""

from __future__ import annotations

import datetime
import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.groups import build, describe_groups, number_error_rows, present
from fkev_slepc.archive.products import FORMAT, FORMAT_VERSION, MESSAGE_BYTES, STABILITY_SCOPE, Grid  # noqa: F401
from fkev_slepc.archive.verify import ROOT_DIGEST_ATTR, stamp, verify
from fkev_slepc.status import RETRYABLE, Status, codes, converged_codes


class ArchiveMismatch(ValueError):
    """A resume asked for a run the archive does not hold (message names what differs)."""


def partial_path(path: str | Path) -> Path:
    """Temporary name of an archive being written (renamed to ``path`` when complete)."""
    path = Path(path)
    return path.with_name(path.name + ".part")


def create(path, grid: Grid, attrs: dict, mesh: dict | None = None, n_free: int = 0,
           mode_shapes: bool = False, tracking_dofs: np.ndarray | None = None,
           transmission_deg: np.ndarray | None = None) -> None:
    """Write a new, empty archive at ``path`` (serial; rank 0 only).

    Parameters
    ----------
    path : path of the file to write (normally :func:`partial_path` of the output).
    grid : the sweep grid.
    attrs : root attributes (scene_toml, scene_source, command_line, solver_settings (dict or
        JSON string), elements, imag_tol, damping_tol, n_ranks, versions, ...).
    mesh : ``node_link, node_s, node_dofs, elem_nodes`` arrays and ``link_names``.
    n_free : number of free DOFs (size of a mode shape).
    mode_shapes : create ``/modes/shape`` and ``/modes/node_xy``.
    tracking_dofs : free-DOF indices whose eigenvector entries are stored in
        ``/tracking/signature`` for mode tracking; None when nothing is tracked (one angle).
    transmission_deg : smallest transmission angle at each crank angle (``kinematics``), stored
        as ``transmission_angle_deg`` (it depends on the angle only: the same for every speed
        and case of the angle's points).
    """
    values = grid.scale_values()
    needs, data = set(), {}
    if mesh is not None:
        needs.add("mechanism")
        n_node, n_el = len(mesh[P.NODE_LINK.source]), len(mesh[P.ELEM_NODES.source])
        values.update({P.NODE: np.arange(n_node), P.ELEMENT: np.arange(n_el), P.M_NODE: np.arange(n_node),
                       P.LINK_NAMES: list(mesh[P.LINKS.source])})
        data.update({v.path: np.asarray(mesh[v.source]) for v in P.MESH_ARRAYS if v.source in mesh})
        if P.NODE_AXIS.source in mesh:
            needs.add("node_axis")
    if tracking_dofs is not None:
        needs.add("signatures")
        values[P.DOFS] = np.asarray(tracking_dofs, dtype="i4")
    if mode_shapes:
        if mesh is None:
            raise ValueError("an archive with mode shapes needs the mesh (node positions)")
        needs.add("shapes")
        values[P.FREE_DOF] = np.arange(n_free)
    if transmission_deg is not None:
        needs.add("transmission")
        data[P.TRANSMISSION.path] = np.asarray(transmission_deg, dtype=float)
    with h5py.File(path, "w") as f:
        build(f, present(P.SWEEP, needs), values, data)
        describe_groups(f, P.SWEEP)
        now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        f.attrs.update(format=FORMAT, format_version=FORMAT_VERSION, created=now, wall_time_s=0.0, complete=0)
        _set_attrs(f, attrs)


def _set_attrs(f, attrs: dict) -> None:
    for key, value in attrs.items():
        if isinstance(value, dict):
            value = json.dumps(value, sort_keys=True, default=str)
        elif isinstance(value, (tuple, list)):
            value = np.asarray(value)
        f.attrs[key] = value


def text(v) -> str:
    """An HDF5 string (bytes or str) as str."""
    return v.decode("utf-8") if isinstance(v, bytes) else str(v)


# ----------------------------------------------------------------------------------- resume
@dataclass(frozen=True)
class ArchiveState:
    """What a (partial) archive already holds: per-point status and |λ1| (NaN if unknown)."""

    status: np.ndarray  # (angle, speed, case) uint8
    lam1: np.ndarray  # (angle, speed, case) |eigenvalue of mode 1| of converged points

    def todo(self, retry_failed: bool = False) -> np.ndarray:
        """Mask of the points to solve: pending ones, and with ``retry_failed`` the failed and
        not-converged ones too (e.g. again with other PETSc options)."""
        again = [Status.PENDING] + (list(RETRYABLE) if retry_failed else [])
        return np.isin(self.status, codes(again))


def modulus(z) -> np.ndarray:
    """|z| as sqrt(re² + im²) with one correctly rounded ufunc per operation, so that it is
    bitwise the same for one value and for a whole array (``np.abs`` of complex is not: its
    vectorised and scalar loops can differ in the last bit). Continuation hints computed
    during a run and read back by a resume must be identical."""
    z = np.asarray(z, dtype=complex)
    return np.sqrt(np.add(np.multiply(z.real, z.real), np.multiply(z.imag, z.imag)))


def read_status(path, product: P.Product = P.SWEEP) -> np.ndarray | None:
    """The per-point status codes of ``product`` (shaped like its point axes), None if the
    archive does not hold it yet. With :func:`fkev_slepc.sweep.units.pending` it gives the
    points a resumed run of any product still has to solve."""
    with h5py.File(path, "r") as f:
        return np.asarray(f[product.status][()], dtype=np.uint8) if product.status in f else None


def add_product(path, product: P.Product, values: dict, data: dict | None = None, needs=()) -> None:
    """Create the datasets of ``product`` (those of the options ``needs``) in the archive
    ``path`` (serial, rank 0, before the ranks open it with :class:`~fkev_slepc.archive.writer.Writer`):
    its scales from ``values`` (by path; scales already in the file, e.g. the root
    ``speed_rad_s``, are reused), its data from ``data``, the rest at full size, filled and
    pending. A product already there is replaced. A finished archive must first be copied back
    to its ``.part`` (:func:`reopen_finished`), so that :func:`finalize` re-stamps its checksums."""
    with h5py.File(path, "r+") as f:
        rows = [v for v in present(product, set(needs)) if not (v.scale and v.path in f and v.path not in values)]
        build(f, rows, values, data)
        describe_groups(f, product)


def read_state(path, plane: str = "in") -> ArchiveState:
    """Status and |λ1| of every point of the sweep of ``plane`` (|λ1| only where the point converged;
    "out": the ``/planes/out`` product of a two-plane archive)."""
    with h5py.File(path, "r") as f:
        status = np.asarray(f[P.on_plane(P.STATUS_VAR, plane).path][()], dtype=np.uint8)
        lam1 = modulus(f[P.on_plane(P.EIGENVALUE, plane).path][..., 0])
    lam1[~np.isin(status, converged_codes())] = np.nan
    return ArchiveState(status, lam1)


def open_for_resume(path, grid: Grid, expect: dict) -> Path:
    """Check that the archive of ``path`` holds the run described, and return the temporary
    file to continue writing (a finished archive is renamed back to its temporary name only
    by :func:`reopen_finished`).

    ``expect`` holds root attributes that must match exactly (scene_toml, elements,
    mode_shapes, n_free). Raises :class:`ArchiveMismatch` naming every difference or the damage
    ``fkev verify`` finds (:func:`refuse_damaged`, before anything is decoded here), or
    FileNotFoundError when there is nothing to resume.
    """
    path = Path(path)
    part = partial_path(path)
    src = part if part.exists() else path
    if not src.exists():
        raise FileNotFoundError(f"{path}: nothing to resume (neither it nor {part.name} exists)")
    refuse_damaged(src)
    problems = []
    try:
        f = h5py.File(src, "r")
    except OSError as exc:
        raise ArchiveMismatch(f"{src}: cannot be opened to resume ({exc})") from None
    with f:
        if text(f.attrs.get("format", "")) != FORMAT:
            raise ArchiveMismatch(f"{src}: not an fkev archive")
        for key, value in expect.items():
            have = f.attrs.get(key, "in" if key == "plane" else None)  # archives before plane: in plane
            if key == "scene_toml":
                diff = scene_difference(text(have) if have is not None else "", value)
                if diff:
                    problems.append(f"the scene changed since the archive was written: {diff}")
            elif have is None or not np.array_equal(np.asarray(have), np.asarray(value)):
                problems.append(f"{key}: archive has {_show(have)}, this run {_show(value)}")
        want = grid.scale_values()
        for flag, name in (("angles_deg", P.ANGLE), ("speeds_rad_s", P.SPEED), ("modes", P.MODE)):  # API names
            have = f[name][()]
            if have.shape != want[name].shape or not np.array_equal(have, want[name]):
                problems.append(f"{flag}: archive has {_show(have)}, this run {_show(want[name])}")
        cases = tuple(text(c) for c in f[P.CASE][()])
        if cases != tuple(grid.cases):
            problems.append(f"cases: archive has {','.join(cases)}, this run {','.join(grid.cases)}")
    if problems:
        raise ArchiveMismatch(f"{src}: cannot resume: " + "; ".join(problems))
    return src


def refuse_damaged(src: Path) -> None:
    """Raise :class:`ArchiveMismatch` when ``fkev verify`` finds ``src`` damaged: checked in a child
    process before this one decodes anything of it (damaged metadata can crash HDF5), so that a
    resume never re-stamps damaged values as verified (the caller holds the archive's lock)."""
    check = verify(src, held=True)
    if not check.ok:
        more = f"; and {len(check.problems) - 3} more" if len(check.problems) > 3 else ""
        raise ArchiveMismatch(f"{src}: damaged, not resumed (a resume would stamp the damage as verified): "
                              + "; ".join(check.problems[:3]) + more
                              + f"; see `fkev verify {src}`; start over with --force or write another -o")


def scene_difference(archived: str, current: str) -> str | None:
    """The first field in which two scene texts differ once parsed (comments, layout, key
    order and number spelling do not count), e.g. ``links[1].length_m: archive has 0.2794,
    the scene now 0.28``; None when they describe the same scene."""
    import tomllib

    try:
        a, b = tomllib.loads(archived), tomllib.loads(current)
    except tomllib.TOMLDecodeError:
        return None if archived == current else "the archived scene text cannot be parsed and differs"
    return _first_difference(a, b, "")


def _first_difference(a, b, path: str) -> str | None:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in list(a) + [k for k in b if k not in a]:
            sub = f"{path}.{key}" if path else str(key)
            if key not in b:
                return f"{sub}: in the archive, removed from the scene"
            if key not in a:
                return f"{sub}: added to the scene (not in the archive)"
            found = _first_difference(a[key], b[key], sub)
            if found:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list):
        for i, (x, y) in enumerate(zip(a, b)):
            found = _first_difference(x, y, f"{path}[{i}]")
            if found:
                return found
        if len(a) != len(b):
            return f"{path}: archive has {len(a)} entries, the scene now {len(b)}"
        return None
    if a == b and type(a) is type(b) or (isinstance(a, (int, float)) and isinstance(b, (int, float)) and a == b):
        return None
    return f"{path}: archive has {a!r}, the scene now {b!r}"


def _show(v) -> str:
    a = np.atleast_1d(np.asarray(v))
    if a.size > 6:
        return f"{a.size} values {a[0]!r}..{a[-1]!r}"
    return ",".join(text(x) if isinstance(x, bytes) else f"{x:g}" if np.isreal(x) and a.dtype.kind in "fiu"
                    else str(x) for x in a.tolist())


def reopen_finished(path) -> Path:
    """Copy a finished archive to its temporary name (to add points to it), marked incomplete.

    A copy, not a move: the finished archive stays untouched until the resumed run completes
    and replaces it, so a run that fails never damages an existing archive."""
    part = partial_path(path)
    shutil.copyfile(path, part)
    with h5py.File(part, "r+") as f:
        f.attrs["complete"] = 0
        f.attrs.pop(ROOT_DIGEST_ATTR, None)  # its checksums go stale with the first point written
    return part


# ------------------------------------------------------------------------------ completion
def read_tracking_inputs(path, plane: str = "in") -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(frequency_hz, status, tracking signature or None) of every point (of the sweep of ``plane``)."""
    sig, freq, status = (P.on_plane(v, plane).path for v in (P.SIGNATURE, P.FREQUENCY, P.STATUS_VAR))
    with h5py.File(path, "r") as f:
        return f[freq][()], np.asarray(f[status][()], dtype=np.uint8), f[sig][()] if sig in f else None


def finalize(part, path, attrs: dict, add_wall_time: float = 0.0) -> Path:
    """Rank 0, after every rank closed the file: store the run attributes, add ``add_wall_time``
    to ``wall_time_s`` (summed over resumed runs), keep one error row per point that still
    failed (the newest; for every product in the file), set ``complete=1``, stamp the
    checksums and rename ``part`` to ``path``."""
    with h5py.File(part, "r+") as f:
        for product in P.PRODUCTS:
            if product.errors is not None and product.status in f:
                _compact_errors(f, product)
        _set_attrs(f, attrs)
        f.attrs["wall_time_s"] = float(f.attrs.get("wall_time_s", 0.0)) + float(add_wall_time)
        f.attrs["complete"] = 1
        stamp(f)  # last: the checksums cover every value and attribute written above
    os.replace(part, path)
    return Path(path)


def _compact_errors(f, product: P.Product) -> None:
    e = product.errors
    index, status, message = e.index.path, e.status.path, e.message.path
    if index not in f:
        return
    idx = f[index][()]
    if idx.shape[0] == 0:
        return number_error_rows(f, product)
    point_status = f[product.status][()]
    bad = codes(RETRYABLE)
    # newest row of each point: reverse, take the first occurrence
    flat = np.ravel_multi_index(idx.T, point_status.shape)
    _, first = np.unique(flat[::-1], return_index=True)
    keep = np.sort(idx.shape[0] - 1 - first)
    keep = keep[np.isin(point_status.ravel()[flat[keep]], bad)]
    rows = {name: f[name][()][keep] for name in (index, status, message)}
    for name, data in rows.items():
        f[name].resize(len(keep), axis=0)
        if len(keep):
            f[name][...] = data
    number_error_rows(f, product)


def status_counts(status: np.ndarray) -> dict[str, int]:
    """Number of points of each status, by lower-case name."""
    counts = np.bincount(np.asarray(status, dtype=np.int64).ravel(), minlength=len(Status))
    return {s.value: int(counts[s.code]) for s in Status}
