"""The thesis scenes' acceptance grid shared by tests/test_eigen.py and scripts/linkage_checks.py
(a support module, not a test file: the script imports it)."""

from __future__ import annotations

import numpy as np

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.scene.cases import CASE_NAMES

# every pep_type / LU package pair test_acceptance_slepc_matches_dense runs (the LU packages installed)
ACCEPTANCE_SOLVERS = [("toar", "umfpack"), ("linear", "umfpack"), ("toar", "mumps"), ("toar", "superlu"),
                      ("toar", "klu"), ("toar", "petsc")]


def rel(a, b):
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1)))


SCENES = ["runs/bahgat-willmert-1976.toml", "runs/turcic-midha-1984.toml"]
ANGLES, SPEEDS = (0, 10, 90, 180, 270), (0.0, 500.0, 1000.0)


def scene_qeps(path, elements=None):
    scene = load_scene(path)
    model = Model(with_elements(scene, elements) if elements else scene, cases=CASE_NAMES)
    for th in ANGLES:
        pieces = model.pieces(np.radians(th))
        for om in SPEEDS:
            for case in CASE_NAMES:
                yield (th, om, case), model.qep(pieces, om, case)
