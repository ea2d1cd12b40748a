"""Stage "api": the Python face of fkev_slepc (docs/api.md).

``study`` holds :func:`load`, :func:`open`, :class:`Study` and :class:`SweepResults`; ``results``
what a point returns (:class:`PointResult`, :class:`ModeShape`).
"""

from fkev_slepc.api.results import ModeShape, PointResult
from fkev_slepc.api.study import Study, SweepResults, load, open  # noqa: A004 - fkev_slepc.open(archive)
from fkev_slepc.status import Status

__all__ = ["load", "open", "Study", "PointResult", "ModeShape", "SweepResults", "Status"]
