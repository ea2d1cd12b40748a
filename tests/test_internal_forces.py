"""Internal forces by element equilibrium (fkev_slepc/periodic/stations.py element_forces,
docs/theory.md §7.4): exact at interior stations, at any mesh, for both elements."""

import numpy as np
import pytest
from test_link_stress import BAR, L, OMEGA, RHO, A

from fkev_slepc.api.response import study_response
from fkev_slepc.scene import parse_scene

S = list(np.linspace(0.0, L, 13))  # nodes and interior stations of 4 and 16 elements


@pytest.mark.parametrize("element", ["thesis", "cubic"])
@pytest.mark.parametrize("n", [4, 16])
def test_rotating_bar_axial_force_is_exact_at_every_station(element, n):
    """N(s) = ρAΩ²(L² − s²)/2 at every station (1e-10 relative), the thesis element included."""
    sc = parse_scene(BAR.replace("elements = 4", f"elements = {n}") + f'element = "{element}"\n', "bar.toml")
    st = study_response(sc, OMEGA, "no_normal", [0.0, 120.0], shoot=False, stations={"beam": S}).stations
    exact = RHO * A * OMEGA**2 * (L**2 - np.array(S) ** 2) / 2
    np.testing.assert_allclose(st.axial_force, np.broadcast_to(exact, st.axial_force.shape), rtol=1e-10,
                               atol=1e-10 * exact.max())


@pytest.mark.parametrize("element", ["thesis", "cubic"])
def test_cantilever_shear_and_moment_under_self_weight(element):
    """A cantilever at rest under gravity bends concave down (away from its left normal, up):
    M(s) = −q (L − s)²/2 and V = −dM/ds = −q (L − s) (q = ρAg) at interior stations, where the
    Hermite curvature is off by up to q l²/12."""
    g = 9.81
    sc = parse_scene(BAR.replace(f"[{OMEGA}]", "[0.0]").replace('cases = ["full"]', 'cases = ["full"]\n'
                     "gravity_m_s2 = [0.0, -9.81]") + f'element = "{element}"\n', "cantilever.toml")
    st = study_response(sc, 0.0, "full", [0.0], shoot=False, stations={"beam": S}).stations
    q, s = RHO * A * g, np.array(S)
    np.testing.assert_allclose(st.moment[0], -q * (L - s) ** 2 / 2, rtol=0, atol=1e-10 * q * L**2 / 2)
    np.testing.assert_allclose(st.shear[0], -q * (L - s), rtol=0, atol=1e-10 * q * L)
    np.testing.assert_allclose(st.axial_force[0], 0.0, atol=1e-10 * q * L)
