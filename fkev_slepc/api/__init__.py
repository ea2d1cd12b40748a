"""Stage "api": the Python face of fkev_slepc (docs/api.md).

``study`` holds :func:`load`, :func:`open`, :class:`Study` and :class:`SweepResults`; ``results``
what a point returns (:class:`PointResult`, :class:`ModeShape`); ``datasets`` :func:`open_dataset`
(any group of an archive as xarray, verified first).
"""

from fkev_slepc.api.datasets import open_dataset
from fkev_slepc.api.results import ModeShape, PointResult
from fkev_slepc.api.study import Study, SweepResults, load, open  # noqa: A004 - fkev_slepc.open(archive)
from fkev_slepc.status import Status

__all__ = ["load", "open", "open_dataset", "Study", "PointResult", "ModeShape", "SweepResults", "Status"]
