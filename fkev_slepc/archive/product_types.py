"""The vocabulary of the archive's product tables (fkev_slepc/archive/products.py and the
per-product table modules beside it): :class:`Var` (one dataset), :class:`Product` (the datasets of
one kind of run and its unit of work), :class:`ErrorTable`, the format constants and the names of the
root scales. Nothing here names a dataset of a product."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FORMAT, FORMAT_VERSION = "fkev-archive", 1
SUPPORTED_VERSIONS = (1,)
MESSAGE_BYTES = 1024  # error messages: fixed-length UTF-8 (parallel HDF5 1.10 cannot write VL data)

# dtypes named in the tables besides numpy's: the status enum, UTF-8 strings (variable length),
# error messages (fixed length, MESSAGE_BYTES)
STATUS, STRING, MESSAGE = "status", "str", "message"

ANGLE, SPEED, CASE, MODE = "crank_angle_deg", "speed_rad_s", "case", "mode"  # the root scales
CNAN = complex(np.nan, np.nan)


@dataclass(frozen=True, eq=False)
class Var:
    """One dataset: path, dimensions (scale paths), dtype, units, long name, fill.

    ``scale``: the dataset is a dimension scale (its ``NAME`` is its last path component).
    ``growable``: its first axis grows (error rows); ``chunks`` its chunk shape then.
    ``needs``: the option of the run it exists with ("" always; ``mechanism``, ``node_axis``,
    ``signatures``, ``shapes``, ``transmission``, ``tracked``, ``speed_tracked``, ``refined``; a design
    study's ``stress``, ``sensitivity``). ``required``: a reader refuses an archive without it. ``source``: the attribute of a point result (:class:`fkev_slepc.solve.modes.PointModes`)
    or of the mechanism it holds; ``rows``: a dimension whose values select the rows of that
    attribute (the tracked DOFs of an eigenvector). ``values``: the fixed values of a scale
    (``U, V, Phi``). ``attrs``: further attributes.
    """

    path: str
    dims: tuple[str, ...]
    dtype: str
    units: str
    long_name: str
    fill: object = None
    scale: bool = False
    growable: bool = False
    chunks: tuple | None = None
    needs: str = ""
    required: bool = False
    source: str | None = None
    rows: str | None = None
    values: tuple | None = None
    attrs: dict = field(default_factory=dict)

    @property
    def name(self) -> str:
        """Last component of the path (the dataset's name in its group)."""
        return self.path.rpartition("/")[2]

    @property
    def group(self) -> str:
        """Path of the group holding it ("" for the root group)."""
        return self.path.rpartition("/")[0]


@dataclass(frozen=True)
class Product:
    """Datasets written by one kind of run, with its unit of work (see the module docstring).

    ``status``: the per-point status dataset (HDF5 enum of :class:`fkev_slepc.status.Status`);
    a point is done when its status is not ``pending``. ``errors``: its :class:`ErrorTable`
    (one row per failed or not-converged point: index over ``unit_dims + point_dims``,
    status, message). ``groups``: description attribute of each group it creates.
    """

    name: str
    unit_dims: tuple[str, ...]
    point_dims: tuple[str, ...]
    status: str
    variables: tuple[Var, ...]
    errors: "ErrorTable | None" = None
    groups: dict = field(default_factory=dict)

    @property
    def point_axes(self) -> tuple[str, ...]:
        return self.unit_dims + self.point_dims

    def var(self, path: str) -> Var:
        for v in self.variables:
            if v.path == path:
                return v
        raise KeyError(f"product {self.name!r} has no dataset {path!r}")

    def per_point(self) -> tuple[Var, ...]:
        """Datasets on the points (every axis of the unit and of its points first): written with them."""
        n = len(self.point_axes)
        return tuple(v for v in self.variables
                     if v.dims[:n] == self.point_axes and not v.scale and v.source is not None)

    def per_unit(self) -> tuple[Var, ...]:
        """Datasets on the units only (e.g. node positions per crank angle): written with them."""
        n, u = len(self.point_axes), len(self.unit_dims)
        return tuple(v for v in self.variables
                     if v.dims[:u] == self.unit_dims and v.dims[:n] != self.point_axes and not v.scale
                     and v.source is not None)

    def written(self) -> tuple[Var, ...]:
        """Every dataset the per-rank writer fills, the status included."""
        return self.per_point() + self.per_unit()


@dataclass(frozen=True)
class ErrorTable:
    """The error rows of a product: a growable row scale, the point index (over the product's
    point axes, named by the ``axis`` scale), the status and the solver's message."""

    row: Var
    axis: Var
    index: Var
    status: Var
    message: Var

    @property
    def rows(self) -> tuple[Var, ...]:
        return (self.row, self.axis, self.index, self.status, self.message)


def error_table(group: str, labels: tuple[str, ...]) -> ErrorTable:
    """The error table of a product in ``group``; ``labels`` name the index columns."""
    row, axis = f"{group}/error", f"{group}/point_axis"
    what = ", ".join(labels)
    return ErrorTable(
        Var(row, (row,), "i4", "1", "row number", scale=True, growable=True, chunks=(256,)),
        Var(axis, (axis,), STRING, "1", f"axis of the ({what}) index", scale=True, values=labels),
        Var(f"{group}/index", (row, axis), "i4", "1", f"({what}) indices of the point", growable=True,
            chunks=(256, len(labels)), required=True),
        Var(f"{group}/status", (row,), STATUS, "1", "outcome of the point (failed or not_converged)",
            growable=True, chunks=(256,), required=True),
        Var(f"{group}/message", (row,), MESSAGE, "1", f"the solver's message (cut at {MESSAGE_BYTES} bytes)",
            growable=True, chunks=(64,), required=True),
    )
