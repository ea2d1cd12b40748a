"""Stage 1 — scene files: TOML -> a validated, frozen :class:`Scene` in SI units.

``model`` holds the dataclasses, ``schema`` the generic key/value reader, ``sections`` one reader
per TOML section of the linkage (``settings``: of ``[analysis]`` and ``[solver]``), ``reader`` the
entry points, ``cases`` Table 3.1 as data. Nothing here imports PETSc, MPI or h5py.
"""

from fkev_slepc.scene.model import (
    END_NAMES,
    DAMPING_TOL,
    IMAG_TOL,
    ELEMENT_NAMES,
    THIRD,
    Analysis,
    Damping,
    Drive,
    Driver,
    Joint,
    Link,
    LinkEnd,
    LumpedMass,
    Material,
    Problem,
    Scene,
    SceneError,
    Segment,
    Solver,
    with_elements,
)
from fkev_slepc.scene.reader import load_scene, parse_scene

__all__ = [
    "DAMPING_TOL", "IMAG_TOL", "ELEMENT_NAMES", "END_NAMES", "THIRD", "Analysis", "Damping", "Drive", "Driver", "Joint",
    "Link", "LinkEnd",
    "LumpedMass", "Material", "Problem", "Scene", "SceneError", "Segment", "Solver", "with_elements", "load_scene",
    "parse_scene",
]
