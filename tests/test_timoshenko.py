"""The Timoshenko frame element (docs/theory.md §22) against closed forms: the simply supported
beam's dispersion relation, Huang's clamped-free frequency equation, the slender limit (no
locking) and SLEPc ≡ dense on a Timoshenko mechanism."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import brentq

from builders import cantilever, frequencies
from fkev_slepc.model import timoshenko as tim
from fkev_slepc.model.element_types import element_type
from fkev_slepc.scene import Analysis
from fkev_slepc.scene.shapes import cowper

E, NU, RHO, H = 2.07e11, 0.3, 7760.0, 0.02  # steel, a square section h x h
G = E / (2 * (1 + NU))
KAPPA = cowper(("rectangle", 0.0), NU)
A, I = H * H, H**4 / 12
R = np.sqrt(I / A)


def props():
    return dict(youngs_modulus=E, density=RHO, area=A, second_moment=I, shear_modulus=G, shear_coefficient=KAPPA)


def beam(n_el, L, element="timoshenko"):
    """Free-free beam of n_el equal elements: assembled M, K (DOFs u, v, ψ per node)."""
    l = np.full(n_el, L / n_el)
    et = element_type(element)
    sh = tim.Shear(np.full(n_el, KAPPA * G * A), np.full(n_el, RHO * I))
    ra, ea, ei = np.full(n_el, RHO * A), np.full(n_el, E * A), np.full(n_el, E * I)
    if element == "timoshenko":
        m, k = et.mass(ra, l, sh, ei), et.structural(ea, ei, l, sh)
    else:
        m, k = et.mass(ra, l), et.structural(ea, ei, l)
    n = 3 * (n_el + 1)
    M, K = np.zeros((n, n)), np.zeros((n, n))
    for e in range(n_el):  # test-side reference assembly
        d = slice(3 * e, 3 * e + 6)
        M[d, d] += m[e]
        K[d, d] += k[e]
    return M, K


def bending_frequencies(M, K, fixed, count=4):
    free = np.setdiff1d(np.arange(M.shape[0]), fixed)
    w2 = eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], eigvals_only=True)
    return np.sqrt(np.abs(w2))


def ss_exact(n, L):
    k = n * np.pi / L
    kga, ei = KAPPA * G * A, E * I
    a, b, m, j = kga * k**2, ei * k**2 + kga, RHO * A, RHO * I
    # (a − m x)(b − j x) = (κGAk)², x = ω²: the lower root, in the cancellation-free form
    p, q = a * j + b * m, a * b - (kga * k) ** 2
    return np.sqrt(2 * q / (p + np.sqrt(p * p - 4 * m * j * q)))


def test_structural_is_the_classical_matrix():
    l, ei, kga = 0.1, E * I, KAPPA * G * A
    phi = 12 * ei / (kga * l * l)
    k = tim.structural(np.array([E * A]), np.array([ei]), np.array([kga]), np.array([l]), np.array([phi]))[0]
    c = ei / ((1 + phi) * l**3)
    ref = c * np.array([[12, 6 * l, -12, 6 * l], [6 * l, (4 + phi) * l * l, -6 * l, (2 - phi) * l * l],
                        [-12, -6 * l, 12, -6 * l], [6 * l, (2 - phi) * l * l, -6 * l, (4 + phi) * l * l]])
    assert np.allclose(k[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])], ref, rtol=1e-13, atol=0)
    B, w = tim.strains(np.array([E * A]), np.array([ei]), np.array([kga]), np.array([l]), np.array([phi]))
    assert np.allclose(np.einsum("esi,es,esj->eij", B, w, B)[0], k, rtol=1e-12, atol=1e-9 * np.abs(k).max())


def converged(L, fixed_of, count=4, meshes=(128, 256)):
    """The lowest ``count`` bending frequencies on two meshes and their Richardson extrapolation
    at the observed rate: the IIE element's frequencies converge like h² at finite Φ (the
    element-constant shear strain follows a dynamic mode to O(h)), h⁴ in the slender limit."""
    w = []
    for n_el in meshes:
        M, K = beam(n_el, L)
        w.append(bending_frequencies(M, K, fixed_of(n_el))[:count + 2])
    return w


def nearest(w, targets):
    return np.array([w[np.argmin(np.abs(w - x))] for x in targets])


@pytest.mark.parametrize("slender", [10.0, 30.0])
def test_simply_supported_dispersion(slender):
    """Pinned ends, bending only: the first four frequencies of the lower branch to 1e-6."""
    L = slender * R
    exact = np.array([ss_exact(n, L) for n in (1, 2, 3, 4)])
    fixed = lambda n: np.r_[np.arange(0, 3 * n + 3, 3), 1, 3 * n + 1]  # noqa: E731  v = 0 at the ends; u held
    w = [nearest(x, exact) for x in converged(L, fixed, meshes=(128, 256, 512))]
    e = [np.abs(x - exact) / exact for x in w]
    rate = np.log2(e[1] / e[2])
    assert np.all(np.abs(rate - 2) < 0.05)  # observed h² (1.99-2.00)
    extrapolated = (4 * w[2] - w[1]) / 3
    assert np.max(np.abs(extrapolated - exact) / exact) < 1e-6


def huang(b, r2, s2):
    a2 = np.sqrt((r2 - s2) ** 2 + 4 / b**2)
    al = np.sqrt(0.5 * (-(r2 + s2) + a2))
    be = np.sqrt(0.5 * ((r2 + s2) + a2))
    return (2 + (b**2 * (r2 - s2) ** 2 + 2) * np.cosh(b * al) * np.cos(b * be)
            - b * (r2 + s2) / np.sqrt(1 - b**2 * r2 * s2) * np.sinh(b * al) * np.sin(b * be))


def huang_roots(r2, s2, top, count=4):
    grid = np.linspace(0.3, top, 20000)
    vals = huang(grid, r2, s2)
    i = np.nonzero(vals[:-1] * vals[1:] < 0)[0][:count]
    return np.array([brentq(huang, grid[k], grid[k + 1], args=(r2, s2), xtol=1e-15) for k in i])


@pytest.mark.parametrize("slender", [10.0, 30.0])
def test_clamped_free_huang(slender):
    """Clamped-free against Huang (1961), b² = ρAL⁴ω²/EI, below the cut-off b²r²s² < 1."""
    L = slender * R
    r2, s2 = I / (A * L * L), E * I / (KAPPA * G * A * L * L)
    scale = np.sqrt(E * I / (RHO * A * L**4))
    roots = huang_roots(r2, s2, 0.9999 / np.sqrt(r2 * s2))
    fixed = lambda n: np.r_[np.arange(0, 3 * n + 3, 3), 1, 2]  # noqa: E731
    w = [nearest(x / scale, roots) for x in converged(L, fixed, count=len(roots), meshes=(256, 512))]
    extrapolated = (4 * w[1] - w[0]) / 3
    assert len(roots) >= 3
    assert np.max(np.abs(extrapolated - roots) / roots) < 1e-6


def test_model_is_the_element():
    """The full model (a driven link at rest, clamped at the hub, element = "timoshenko") gives the
    frequencies of the directly assembled beam: the scene key reaches the element."""
    L = 10 * R
    sc = cantilever(L, props(), elements=16, modes=4)
    sc = dataclasses.replace(sc, analysis=dataclasses.replace(sc.analysis, element="timoshenko"))
    from fkev_slepc.model.operators import Model

    got = np.sort(np.asarray(frequencies(Model(sc), 0.0, 0.0, "full", n=4).frequency_hz, float)) * 2 * np.pi
    M, K = beam(16, L)
    ref = np.sort(bending_frequencies(M, K, [0, 1, 2]))[:4]  # the axial modes included, like the model
    assert np.allclose(got, ref, rtol=1e-9)


@pytest.mark.parametrize("n_el,modes", [(4, 1), (64, 4)])
def test_slender_limit_no_locking(n_el, modes):
    """L/r = 1e4, simply supported: the Timoshenko element differs from the thesis element by the
    continuum's own Timoshenko/Euler-Bernoulli ratio (7e-8 .. 2.4e-6 here, physics, not locking),
    to 1e-8 (4 elements: the first mode; the higher ones are not resolved by 4 elements)."""
    L = 1e4 * R
    fixed = np.r_[np.arange(0, 3 * n_el + 3, 3), 1, 3 * n_el + 1]
    wt = bending_frequencies(*beam(n_el, L), fixed)[:modes]
    we = bending_frequencies(*beam(n_el, L, "thesis"), fixed)[:modes]
    n = np.arange(1, modes + 1)
    ratio = np.array([ss_exact(k, L) for k in n]) / ((n * np.pi / L) ** 2 * np.sqrt(E * I / (RHO * A)))
    assert np.max(np.abs(wt / we - ratio)) < 1e-8


def test_slepc_matches_dense_on_a_timoshenko_mechanism():
    """A four-bar of stocky Timoshenko links in motion: SLEPc ≡ dense to 1e-9."""
    from builders import four_bar
    from fkev_slepc.model.operators import Model
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.slepc import SlepcEngine

    sc = four_bar((0.05, 0.2794, 0.2667), 0.254, props(), (3, 4, 4), speeds=(80.0,), angles=(30.0,))
    sc = dataclasses.replace(sc, analysis=dataclasses.replace(sc.analysis, element="timoshenko"))
    model = Model(sc)
    q = model.qep(model.pieces(np.radians(30.0)), 80.0, "full", None)
    dense, slepc = (postprocess(eng.solve(q, 4), 4).frequency_hz for eng in (DenseEngine(), SlepcEngine()))
    assert np.all(np.isfinite(dense))
    assert np.max(np.abs(slepc - dense) / dense) < 1e-9


def test_scene_keys_and_validation(tmp_path):
    """``element = "timoshenko"`` reads κ from the section shape (Cowper) or shear_coefficient, and a
    link without κ or G is refused naming its field; the slenderness warning names the link."""
    from fkev_slepc.scene import SceneError, load_scene
    from fkev_slepc.scene.validity import slenderness_warnings

    base = """
[materials.steel]
youngs_modulus_pa = 2.07e11
density_kg_m3 = 7760.0
poisson_ratio = 0.3
[[links]]
name = "blade"
length_m = 0.1
elements = 4
{section}
[[joints]]
name = "hub"
connects = ["ground", "blade.root"]
position_m = [0.0, 0.0]
[driver]
link = "blade"
speeds_rad_s = [0.0]
[analysis]
crank_angles_deg = [0.0]
cases = ["full"]
element = "{element}"
"""
    path = tmp_path / "s.toml"
    path.write_text(base.format(section='material = "steel"\nsection = {shape = "rectangle", width_m = 0.01, '
                                        'height_m = 0.02}', element="timoshenko"))
    assert load_scene(path).links[0].shear_coefficient == pytest.approx(10 * 1.3 / (12 + 11 * 0.3), rel=1e-15)
    path.write_text(base.format(section="youngs_modulus_pa = 2.07e11\ndensity_kg_m3 = 7760.0\narea_m2 = 2e-4\n"
                                        "second_moment_m4 = 6.7e-9", element="timoshenko"))
    with pytest.raises(SceneError, match=r"links\[0\].shear_coefficient"):
        load_scene(path)
    path.write_text(base.format(section='material = "steel"\nsection = {shape = "rectangle", width_m = 0.01, '
                                        'height_m = 0.02}', element="thesis"))
    warn = slenderness_warnings(load_scene(path))  # L/r = 17: mode 4 some 20 % off
    assert len(warn) == 1 and "'blade'" in warn[0] and 'element = "timoshenko"' in warn[0]


# -- analyses with no Timoshenko form yet: refused before any work (docs/theory.md §22.7) ------------
IN_PLANE_ONLY = 'analysis.element: "timoshenko" is in-plane only for now'


@pytest.fixture
def flat_rod(tmp_path):
    """The flat-rod slider-crank (both planes' section data) with ``element = "timoshenko"``."""
    from clitools import ROOT

    text = (ROOT / "runs/flat-rod-slider-crank.toml").read_text().replace(
        "modes = 4", 'modes = 4\nelement = "timoshenko"')
    path = tmp_path / "flat-rod-timo.toml"
    path.write_text(text)
    return path


def test_out_of_plane_refused(flat_rod):
    """``fkev point --plane out`` exits 2 naming analysis.element; ``fkev run`` defaults to in plane only;
    the out-of-plane Model refuses too (it would use the thesis element on the same scene)."""
    from clitools import fkev
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene
    from fkev_slepc.sweep.plane_run import default_plane

    r = fkev("point", flat_rod, "--plane", "out", "--angle", "0")
    assert r.returncode == 2 and IN_PLANE_ONLY in r.stderr and "out-of-plane bending and torsion" in r.stderr
    scene = load_scene(flat_rod)
    assert default_plane(scene, None) == "in"
    assert default_plane(dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, element="thesis")),
                         None) == "both"
    with pytest.raises(ValueError, match=IN_PLANE_ONLY):
        Model(scene, plane="out")
    assert fkev("point", flat_rod, "--angle", "0").returncode == 0  # in plane: the element's home


def test_stations_without_speed_refused(flat_rod):
    """Station forces by the thesis shape functions (no speed) are refused on a Timoshenko model; with
    the speed they come from the element's equilibrium, and the deflection at a node is the node's v."""
    from fkev_slepc.api.runup import study_runup
    from fkev_slepc.model.operators import Model
    from fkev_slepc.periodic.stations import default_stations, element_end_stations, station_response
    from fkev_slepc.scene import SceneError, load_scene

    scene = load_scene(flat_rod)
    model = Model(scene)
    theta = np.array([0.3])
    q = np.random.default_rng(1).standard_normal((1, model.mechanism.n_free)) * 1e-4
    with pytest.raises(ValueError, match=IN_PLANE_ONLY + r".*station forces without an operating point"):
        station_response(model, theta, q, default_stations(model.mechanism))
    ends = element_end_stations(model.mechanism)
    sr = station_response(model, theta, q, ends, speed=100.0)
    thesis = Model(dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, element="thesis")))
    se = station_response(thesis, theta, q, ends, speed=100.0)
    assert np.allclose(sr.transverse, se.transverse, rtol=1e-12, atol=1e-15)  # nodes: v is the DOF, any element
    with pytest.raises(SceneError, match=r"analysis\.element.*run-up's stress envelope"):
        study_runup(scene, speed=100.0, revolutions=1)


@pytest.mark.parametrize("a", [0.3, 0.55, 0.8])
def test_point_load_is_exact_in_statics(a):
    """One clamped-free Timoshenko element, a force F and a moment C at x = aL (element_types.point_load
    with Φ): its consistent load gives the exact tip deflection by reciprocity (the interpolation is
    exact under a tip load, §22.2): F[a²(3L − a)/6EI + a/κGA] + C·a(2L − a)/2EI, a here in metres."""
    from fkev_slepc.model.element_types import point_load

    L, F, C = 0.08, 1.0, 0.3  # stocky: Φ ≈ 0.2
    ei, kga = np.array([E * I]), np.array([KAPPA * G * A])
    phi = 12 * ei / (kga * L**2)
    k = tim.structural(np.array([E * A]), ei, kga, np.array([L]), phi)[0]
    f = point_load(np.array([a]), np.array([L]), 6, np.array([[0.0, F, C]]), phi)[0]
    q = np.linalg.solve(k[3:, 3:], f[3:])
    x = a * L
    exact = F * (x**2 * (3 * L - x) / (6 * E * I) + x / kga[0]) + C * x * (2 * L - x) / (2 * E * I)
    assert q[1] == pytest.approx(exact, rel=1e-12)
    thesis = np.linalg.solve(k[3:, 3:], point_load(np.array([a]), np.array([L]), 6, np.array([[0.0, F, C]]))[0][3:])
    assert abs(thesis[1] / exact - 1) > 1e-3  # the Hermite load on Timoshenko DOFs: the wrong number fixed here
