"""Signed extreme-fibre stress along whole links (fkev_slepc/periodic/link_stress.py, fkev_slepc/periodic/stations.py,
docs/response.md §4): a bar rotating under its own inertia and a static cantilever under a tip
load against closed forms, and the faces, means and alternating parts the outputs report."""

import numpy as np
import pytest
from clitools import ROOT

from fkev_slepc.api.response import study_response
from fkev_slepc.scene import parse_scene

RHO, E, L, OMEGA = 7850.0, 2.1e11, 0.5, 100.0
B, H = 0.01, 0.02  # out of plane, in plane
A, I, C = B * H, B * H**3 / 12, H / 2
# runs/rotating-cantilever.toml made a 0.5 m, 4-element rectangular bar with a fibre distance
BAR = (ROOT / "runs" / "rotating-cantilever.toml").read_text().replace("length_m = 1.0", f"length_m = {L}").replace(
    "elements = 16", "elements = 4").replace("youngs_modulus_pa = 2.07e11", f"youngs_modulus_pa = {E}").replace(
    "density_kg_m3 = 7760.0", f"density_kg_m3 = {RHO}").replace(
    "area_m2 = 2.0e-5\nsecond_moment_m4 = 6.666666666666667e-12",
    f'section = {{shape = "rectangle", width_m = {B}, height_m = {H}}}').replace(
    "speeds_rad_s = [0.0, 5.96380837, 11.9276167, 17.8914251, 23.8552335, 29.8190419, 35.7828502]",
    f"speeds_rad_s = [{OMEGA}]").replace('cases = ["full", "structure"]', 'cases = ["full"]')


def rotating(element, case, elements=4):
    sc = parse_scene(BAR.replace("elements = 4", f"elements = {elements}") + f'element = "{element}"\n', "bar.toml")
    return study_response(sc, OMEGA, case, [0.0, 120.0], shoot=False).link_stress


def exact_rotating(s):
    return RHO * OMEGA**2 * (L**2 - s**2) / 2


def test_rotating_bar_is_in_tension_on_both_faces():
    """σ(s) = ρΩ²(L² − s²)/2 on both faces at every element end and angle, exact (1e-10) with both
    elements when the centrifugal softening of the axial stiffness is dropped (no_normal): the
    internal forces come from each element's equilibrium under its distributed inertia load ρAΩ²x
    (docs/theory.md §7.4), not from the thesis element's constant u' (which gave the element mean);
    with the softening (full) within its size ρΩ²L²/E."""
    exact = None
    for element, elements in (("cubic", 4), ("thesis", 16), ("thesis", 4)):
        ls = rotating(element, "no_normal", elements)
        exact = exact_rotating(ls.point_s)
        for face in (0, 1):
            np.testing.assert_allclose(ls.sigma[..., face], np.broadcast_to(exact, ls.sigma.shape[:2]),
                                       rtol=1e-10, atol=1e-10 * exact.max())
    full = rotating("cubic", "full")
    assert np.abs(full.sigma[..., 0] / exact.max() - exact / exact.max()).max() < RHO * OMEGA**2 * L**2 / E
    hi, lo, m, a = ls.parts()
    np.testing.assert_allclose(a, 0.0, atol=1e-9 * exact.max())  # steady: nothing alternates
    assert ls.peak(0)["s_m"] == 0.0 and ls.peak(0)["sigma_pa"] > 0


def test_static_cantilever_faces_carry_plus_minus_moment():
    """A cantilever at rest under gravity with a 20 kg tip mass: σ₊ = +M c/I (the face at +c, up,
    in tension), σ₋ = −M c/I, N = 0; M(s) = m g (L − s) + q (L − s)²/2 exactly at every element end:
    the element's equilibrium under the uniform self-weight q (the Hermite element's curvature
    alone would be q l²/12 off at the ends)."""
    sc = parse_scene(BAR.replace(f"[{OMEGA}]", "[0.0]").replace('cases = ["full"]', 'cases = ["full"]\n'
                     "gravity_m_s2 = [0.0, -9.81]") + '[[masses]]\nlink = "beam"\nposition_m = 0.5\nmass_kg = 20.0\n',
                     "cantilever.toml")
    res = study_response(sc, 0.0, "full", [0.0], shoot=False)
    ls, g = res.link_stress, 9.81
    q = RHO * A * g
    M = 20.0 * g * (L - ls.point_s) + q * (L - ls.point_s) ** 2 / 2
    scale = M.max() * C / I
    np.testing.assert_allclose(ls.sigma[0, :, 0], M * C / I, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(ls.sigma[0, :, 1], -M * C / I, rtol=0, atol=1e-10 * scale)
    d = res.as_dict()
    root = d["stations"][0]
    assert root["stress_plus_pa"][0] == pytest.approx(ls.sigma[0, 0, 0], rel=1e-12)
    assert root["stress_minus_pa"][0] == pytest.approx(-root["stress_plus_pa"][0], rel=1e-12)
    assert root["stress_mean_pa"]["plus"] == pytest.approx(root["stress_plus_pa"][0], rel=1e-12)
    assert root["stress_alternating_pa"] == {"plus": 0.0, "minus": 0.0}
    peak = d["links"]["beam"]["peak"]
    assert (peak["face"], peak["s_m"]) == ("plus", 0.0) and peak["stress_pa"] == pytest.approx(M[0] * C / I, rel=1e-12)
