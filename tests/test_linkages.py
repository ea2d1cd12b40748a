"""General planar linkages (docs/linkages.md): stepped links, lumped masses anywhere with rotary
inertia, ternary links, prismatic joints (slider-cranks), against closed forms, first-principles
balances and the four-bar special case."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from builders import frequencies

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene, parse_scene
from fkev_slepc.scene.cases import CASE_NAMES

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
RUNS = ROOT / "runs"
PIECES = ("mass", "structural", "coriolis", "tangential", "normal", "pseudo")


def _pieces(model, theta_deg):
    p = model.pieces(np.radians(theta_deg))
    return dict(mass=p.mass, structural=p.structural, coriolis=p.coriolis, tangential=np.stack(p.tangential),
                normal=p.normal, pseudo=np.stack(p.pseudo_normal))


@pytest.mark.parametrize("name", ["bahgat-willmert-1976", "turcic-midha-1984"])
def test_four_bars_reproduce_the_binary_link_model(name):
    """The general path (beams, particles, planned steps) gives the operators and frequencies of
    the binary-link model it replaced, recorded in tests/data/<scene>-operators.npz (made at
    commit 4c77756 with the dense engine at 1000 rad/s): operators to 1e-12 (measured ~5e-16);
    frequencies to 1e-10 (QZ rounding: measured 3e-13 Bahgat-Willmert, 5e-11 Turcic-Midha)."""
    ref = np.load(DATA / f"{name}-operators.npz")
    model = Model(load_scene(RUNS / f"{name}.toml"), cases=CASE_NAMES)
    np.testing.assert_array_equal(model.pattern.indptr, ref["indptr"])
    np.testing.assert_array_equal(model.pattern.indices, ref["indices"])
    for i, angle in enumerate(ref["angles"]):
        got = _pieces(model, angle)
        for key in PIECES:
            want = ref[f"a{i}_{key}"]
            assert np.abs(got[key] - want).max() <= 1e-12 * np.abs(want).max(), (angle, key)
        for case in CASE_NAMES:
            f = frequencies(model, angle, 1000.0, case).frequency_hz
            np.testing.assert_allclose(f, ref[f"a{i}_freq_{case}"], rtol=1e-10)
