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
    frequencies to 1e-10 (QZ rounding: measured 3e-13 Bahgat-Willmert, 6e-11 Turcic-Midha)."""
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


# --------------------------------------------------------------------------------------------
# Scenes written as TOML (the parser is part of what is tested)
STEEL_TOML = """
[link_defaults]
youngs_modulus_pa = 2.07e11
density_kg_m3 = 7850.0
area_m2 = 1.8e-4
second_moment_m4 = 4.86e-9
"""


def link(name, length, elements, extra="") -> str:
    return f'[[links]]\nname = "{name}"\nlength_m = {length!r}\nelements = {elements}\n{extra}\n'


def joint(name, connects, xy=None, extra="") -> str:
    where = "" if xy is None else f"position_m = [{xy[0]!r}, {xy[1]!r}]\n"
    return f'[[joints]]\nname = "{name}"\nconnects = {connects!r}\n{where}{extra}\n'.replace("'", '"')


def driven(name) -> str:
    return f'[driver]\nlink = "{name}"\nspeeds_rad_s = [0.0]\n'


def slider_crank(stiff=1.0, slider_mass=0.45, rod_elements=8, extra="", guide="") -> str:
    """runs/slider-crank.toml's linkage: crank E scaled by ``stiff``, no big-end mass; ``guide``
    adds keys to the prismatic joint (its guide point is the origin unless given)."""
    crank = f"youngs_modulus_pa = {2.07e11 * stiff!r}\narea_m2 = 4.2e-4\nsecond_moment_m4 = 3.15e-8"
    point = None if "position_m" in guide else (0.0, 0.0)
    return (STEEL_TOML + link("crank", 0.045, 2, crank) + link("rod", 0.15, rod_elements)
            + joint("O", ["ground", "crank.root"], (0.0, 0.0)) + joint("A", ["crank.tip", "rod.root"])
            + joint("P", ["ground", "rod.tip"], point, f'type = "prismatic"\nslider_mass_kg = {slider_mass!r}\n{guide}')
            + extra + "\n" + driven("crank"))


def pinned_beam(n=32, mass="", length=1.0) -> str:
    """A beam pinned to ground at its root, its tip on a slider guided along its axis (transverse
    displacement held, axial free): a pinned-pinned beam. A lone crank is the driver."""
    return (STEEL_TOML + link("crank", 0.1, 1) + link("beam", length, n)
            + joint("O1", ["ground", "crank.root"], (0.0, -1.0)) + joint("O2", ["ground", "beam.root"], (0.0, 0.0))
            + joint("S", ["ground", "beam.tip"], (0.0, 0.0), 'type = "prismatic"') + mass + "\n" + driven("crank"))


def tip_inertia_cantilever(j, n=32, length=0.5) -> str:
    """A driven cantilever (clamped at its hub) with rotary inertia j·ρAL³ at its free end."""
    inertia = j * 7850.0 * 1.8e-4 * length**3
    mass = f'[[masses]]\nlink = "blade"\nposition_m = {length!r}\nmass_kg = 0.0\ninertia_kg_m2 = {inertia!r}\n'
    return STEEL_TOML + link("blade", length, n) + joint("hub", ["ground", "blade.root"], (0.0, 0.0)) + mass + driven("blade")


def tip_inertia_equation(x, j):
    """Clamped-free beam, tip rotary inertia j = J/ρAL³, at λ = βL (zero at a natural frequency)."""
    S, C, s, c = np.sinh(x), np.cosh(x), np.sin(x), np.cos(x)
    return (S - s) * ((S + s) - j * x**3 * (C - c)) - (C + c) * ((C + c) - j * x**3 * (S + s))


def central_mass_equation(a, r):
    """Pinned-pinned beam, central mass r·ρAL, a = βL/2: symmetric modes (zero at a frequency)."""
    return 2 * np.cos(a) - r * a * (np.sin(a) - np.cos(a) * np.tanh(a))


def link_eigen(model, link, theta=0.0):
    """Ω = 0 natural frequencies (rad/s) of the DOFs of one link (decoupled from the rest)."""
    import scipy.linalg as la

    mech = model.mechanism
    p = model.pieces(theta)
    dofs = np.unique(mech.node_dofs[mech.node_link == mech.link_names.index(link)])
    dofs = dofs[dofs >= 0]
    K = model.pattern.matrix(p.structural).toarray()[np.ix_(dofs, dofs)]
    M = model.pattern.matrix(p.mass).toarray()[np.ix_(dofs, dofs)]
    return np.sqrt(la.eigh(K, M, eigvals_only=True))


def _section(text):
    sc = parse_scene(text, "t.toml")
    lk = sc.links[-1]
    return sc, lk, lk.youngs_modulus * lk.second_moment, lk.density * lk.area


# --------------------------------------------------------------------------------------------
# Masses anywhere, rotary inertia
def test_mid_span_mass_on_a_pinned_pinned_link():
    """Symmetric modes of a pinned-pinned beam with a central mass m (ratio r = m/ρAL):
    2 cos a = r a (sin a - cos a tanh a), a = βL/2, ω = β² √(EI/ρA)."""
    from scipy.optimize import brentq

    r = 1.0
    sc, lk, ei, rho_a = _section(pinned_beam(mass=f"""
[[masses]]
link = "beam"
position_m = 0.5
mass_kg = {r * 7850.0 * 1.8e-4!r}
"""))
    a = brentq(central_mass_equation, 0.5, np.pi / 2, args=(r,))
    exact = (2 * a / lk.length) ** 2 * np.sqrt(ei / rho_a)
    w = link_eigen(Model(sc, cases=("structure",)), "beam")
    assert abs(w[0] / exact - 1) < 1e-6
    # without the mass: (π/L)² √(EI/ρA)
    sc0, *_ = _section(pinned_beam())
    w0 = link_eigen(Model(sc0, cases=("structure",)), "beam")
    assert abs(w0[0] / ((np.pi / lk.length) ** 2 * np.sqrt(ei / rho_a)) - 1) < 1e-6


def test_rotary_inertia_at_a_free_end():
    """Cantilever (the driven link, clamped at its hub) with a tip rotary inertia J, j = J/ρAL³:
    (S-s)[(S+s) - jλ³(C-c)] - (C+c)[(C+c) - jλ³(S+s)] = 0 at λ = βL (S = sinh λ, c = cos λ, ...)."""
    from scipy.optimize import brentq

    j = 0.05
    sc, lk, ei, rho_a = _section(tip_inertia_cantilever(j))
    det = lambda x: tip_inertia_equation(x, j)  # noqa: E731

    lam = brentq(det, 0.5, 1.875104)  # below the bare cantilever's 1.8751
    exact = (lam / lk.length) ** 2 * np.sqrt(ei / rho_a)
    w = link_eigen(Model(sc, cases=("structure",)), "blade")
    assert abs(w[0] / exact - 1) < 1e-6


def test_mass_inserts_a_node_and_moves_the_centroid():
    """A mass between nodes gets its own node; the link's rigid-body mass and centroid include it."""
    from fkev_slepc.model.mechanism import build_mechanism

    sc, *_ = _section(pinned_beam(n=4, mass='[[masses]]\nlink = "beam"\nposition_m = 0.3\nmass_kg = 2.0'))
    mech = build_mechanism(sc)
    beam = mech.link_names.index("beam")
    np.testing.assert_allclose(np.sort(mech.node_s[mech.node_link == beam]), [0, 0.25, 0.3, 0.5, 0.75, 1.0])
    m_beam = 7850.0 * 1.8e-4 * 1.0
    assert mech.body_mass[beam] == pytest.approx(m_beam + 2.0, rel=1e-14)
    assert mech.body_centroid[beam, 0] == pytest.approx((m_beam * 0.5 + 2.0 * 0.3) / (m_beam + 2.0), rel=1e-14)


# --------------------------------------------------------------------------------------------
# Stepped links
STEPPED = """
[[links]]
name = "blade"
[[links.segments]]
length_m = 0.3
area_m2 = 4.0e-4
second_moment_m4 = 2.0e-8
elements = 3
[[links.segments]]
length_m = 0.2
youngs_modulus_pa = 7.1e10
density_kg_m3 = 2710.0
elements = 5
""" + joint("hub", ["ground", "blade.root"], (0.0, 0.0)) + driven("blade")


def test_stepped_link_static_tip_stiffness_and_mass():
    """Two segments, each with its own section, material and element count: the tip deflection
    under a transverse tip load is P(L³ - b³)/3EI₁ + Pb³/3EI₂ (cubic elements are exact for a
    static point load), and the translational mass is ρ₁A₁a + ρ₂A₂b."""
    sc = parse_scene(STEEL_TOML + STEPPED, "t.toml")
    model = Model(sc, cases=("structure",))
    mech = model.mechanism
    assert mech.elem_length.size == 8 and sc.links[0].length == pytest.approx(0.5)
    p = model.pieces(0.0)
    K = model.pattern.matrix(p.structural).toarray()
    M = model.pattern.matrix(p.mass).toarray()
    tip = mech.node_dofs[mech.point_node[0, 1]]
    force = np.zeros(K.shape[0])
    force[tip[1]] = 1.0
    delta = np.linalg.solve(K, force)[tip[1]]
    a, b, ei1, ei2 = 0.3, 0.2, 2.07e11 * 2.0e-8, 7.1e10 * 4.86e-9
    exact = ((a + b) ** 3 - b**3) / (3 * ei1) + b**3 / (3 * ei2)
    assert delta == pytest.approx(exact, rel=1e-10)
    ux = np.zeros(K.shape[0])
    ux[mech.node_dofs[:, 0][mech.node_dofs[:, 0] >= 0]] = 1.0
    # the clamped root's U is not a DOF: its share of the first element, (140 + 2·70)/420 of
    # ρ₁A₁l₁ with l₁ = a/3, is missing from a rigid axial motion of the free DOFs
    total = 7850.0 * 4.0e-4 * a + 2710.0 * 1.8e-4 * b
    assert ux @ M @ ux == pytest.approx(total - 2 / 3 * 7850.0 * 4.0e-4 * a / 3, rel=1e-12)


def test_one_segment_link_is_the_uniform_link():
    """A four-bar whose coupler is written as two identical segments (2 + 2 elements) has the
    operators of the same four-bar with a uniform 4-element coupler."""
    base = (RUNS / "bahgat-willmert-1976.toml").read_text()
    uniform = base.replace('length_m = 0.2794\nelements = 2', 'length_m = 0.2794\nelements = 4')
    stepped = base.replace('length_m = 0.2794\nelements = 2', """length_m = 0.2794
[[links.segments]]
length_m = 0.1397
elements = 2
[[links.segments]]
length_m = 0.1397
elements = 2""")
    assert uniform != base and stepped != base
    m1 = Model(parse_scene(uniform, "u.toml"), cases=CASE_NAMES)
    m2 = Model(parse_scene(stepped, "s.toml"), cases=CASE_NAMES)
    for angle in (10.0, 200.0):
        p1, p2 = _pieces(m1, angle), _pieces(m2, angle)
        for key in PIECES:
            assert np.abs(p1[key] - p2[key]).max() <= 1e-12 * np.abs(p1[key]).max(), key


# --------------------------------------------------------------------------------------------
# Slider-crank
@pytest.mark.parametrize("element", ["thesis", "cubic"])
def test_slider_crank_at_dead_centre_has_a_pinned_pinned_rod(element):
    """θ = 0, a crank 10⁴ times stiffer, a massless slider, Ω = 0: the rod (16 elements) is held
    at A by the crank and normal to the guide at the slider, so its transverse frequencies are
    ωₙ = (nπ)² √(EI/(ρA L⁴)) (its axial motion is free at the slider: other modes). Both element
    types (the guide frame includes the cubic element's internal DOFs)."""
    got, exact = dead_centre_rod(element=element)
    assert np.abs(got / exact - 1).max() < 1e-4


def dead_centre_rod(n_modes=3, element="thesis"):
    """(FE, closed-form) rod transverse frequencies (rad/s) of the stiff-crank slider-crank at θ = 0."""
    text = slider_crank(stiff=1e4, slider_mass=0.0, rod_elements=16) + f'[analysis]\nelement = "{element}"\n'
    sc = parse_scene(text, "t.toml")
    rod = sc.links[1]
    scale = np.sqrt(rod.youngs_modulus * rod.second_moment / (rod.density * rod.area * rod.length**4))
    exact = (np.arange(1, n_modes + 1) * np.pi) ** 2 * scale
    w = 2 * np.pi * frequencies(Model(sc, cases=("structure",)), 0.0, 0.0, "structure", n=6).frequency_hz
    return np.array([w[np.argmin(np.abs(w / x - 1))] for x in exact]), exact


def test_slider_crank_guide_frame():
    """The slider node keeps one translation, along the guide; the normal one is a fixed DOF."""
    sc = parse_scene(slider_crank(guide="guide_angle_deg = 30.0\nposition_m = [0.0, 0.02]"), "t.toml")
    mech = Model(sc, cases=("full",)).mechanism
    node = mech.point_node[1, 1]
    assert mech.node_dofs[node, 0] >= 0 and mech.node_dofs[node, 1] == -1
    np.testing.assert_allclose(mech.node_axis[node], [np.cos(np.pi / 6), np.sin(np.pi / 6)])


SCENES = {"slider-crank": RUNS / "slider-crank.toml", "stephenson-six-bar": RUNS / "stephenson-six-bar.toml"}
THETA = np.radians(np.arange(0.0, 360.0, 7.5))


@pytest.fixture(params=list(SCENES) + ["inclined-offset-slider"])
def mech(request):
    from fkev_slepc.model.mechanism import build_mechanism

    if request.param == "inclined-offset-slider":
        text = slider_crank(extra='[[masses]]\nlink = "rod"\nposition_m = 0.05\nmass_kg = 0.1\ninertia_kg_m2 = 3e-5',
                            guide="position_m = [0.0, 0.012]\nguide_angle_deg = 25.0")
        return build_mechanism(parse_scene(text, "inclined.toml"))
    return build_mechanism(load_scene(SCENES[request.param]))


def test_closure(mech):
    """Every link point sits on its joint; a slider on its guide; to 1e-12 of the longest link."""
    from fkev_slepc.model.kinematics import point_local, solve_kinematics

    kin = solve_kinematics(mech, THETA)
    assert kin.ok.all()
    worst = 0.0
    for jj, here in enumerate(mech.attach):
        for lk, k in here:
            p = point_local(kin, [lk], mech.link_points[lk, k][None])[0][:, 0]
            worst = max(worst, np.abs(p - kin.pos[:, jj]).max())
        if not np.isnan(mech.joint_guide[jj, 0]):
            n = np.array([-mech.joint_guide[jj, 1], mech.joint_guide[jj, 0]])
            worst = max(worst, np.abs((kin.pos[:, jj] - mech.joint_guide_point[jj]) @ n).max())
    assert worst < 1e-12 * mech.length.max()


def test_derivatives_equal_finite_differences(mech):
    from fkev_slepc.model.kinematics import solve_kinematics

    h = 1e-5
    k0, kp, km = (solve_kinematics(mech, THETA + d) for d in (0.0, h, -h))
    unwrap = lambda a: np.angle(np.exp(1j * a))  # noqa: E731
    np.testing.assert_allclose(unwrap(kp.phi - km.phi) / (2 * h), k0.dphi, atol=1e-7)
    np.testing.assert_allclose(unwrap(kp.phi - 2 * k0.phi + km.phi) / h**2, k0.ddphi,
                               atol=2e-4 * np.abs(k0.ddphi).max())
    for x, dx, ddx in ((k0.pos, k0.dpos, k0.ddpos), (k0.root, k0.droot, k0.ddroot)):
        xp, xm = (kp.pos, km.pos) if x is k0.pos else (kp.root, km.root)
        np.testing.assert_allclose((xp - xm) / (2 * h), dx, atol=1e-9)
        np.testing.assert_allclose((xp - 2 * x + xm) / h**2, ddx, atol=1e-5 * max(1.0, np.abs(ddx).max()))


@pytest.mark.parametrize("omega,alpha", [(500.0, 0.0), (300.0, 4e4), (0.0, -2e5)])
def test_newton_euler_of_every_link(mech, omega, alpha):
    from balance import newton_euler_residual

    assert newton_euler_residual(mech, THETA, omega, alpha) <= 1e-9


def test_driving_power_equals_rate_of_kinetic_energy(mech):
    from balance import power_residual

    power, dE = power_residual(mech, THETA)
    np.testing.assert_allclose(power, dE, rtol=1e-6, atol=1e-6 * np.abs(power).max())


def test_guide_reaction_balances_the_slider(mech):
    """The rod's force at the slider is the guide's normal reaction only (along the normal)."""
    from fkev_slepc.model.kinematics import solve_kinematics
    from fkev_slepc.model.kinetostatics import solve_loads

    loads = solve_loads(mech, solve_kinematics(mech, THETA))
    for jj in np.flatnonzero(~np.isnan(mech.joint_guide[:, 0])):
        lk, k = mech.attach[jj][0]
        f = loads.end_force[0][:, lk, k]
        n = np.array([-mech.joint_guide[jj, 1], mech.joint_guide[jj, 0]])
        np.testing.assert_allclose(f @ mech.joint_guide[jj], 0.0, atol=1e-12 * np.abs(f).max())
        np.testing.assert_allclose(f @ n, loads.guide_reaction[0][:, jj], rtol=1e-12)


@pytest.mark.parametrize("name", list(SCENES))
def test_dense_and_slepc_agree(name):
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.slepc import SlepcEngine

    sc = load_scene(SCENES[name])
    model = Model(sc, cases=("full",))
    with SlepcEngine() as engine:
        for angle, omega in ((0.0, 0.0), (40.0, 314.0), (190.0, 300.0)):
            q = model.qep(model.pieces(np.radians(angle)), omega, "full")
            a = postprocess(engine.solve(q, 4), 4).frequency_hz
            b = postprocess(DenseEngine().solve(q, 4), 4).frequency_hz
            assert np.abs(a / b - 1).max() <= 1e-9, (angle, omega, a, b)


# --------------------------------------------------------------------------------------------
# Bad input: tests/data/bad_*.toml of the linkage keys (checked by tests/test_scene.py, which
# merges this table into its BAD table): file stem -> start of the expected problem line.
BAD_LINKAGES = {
    "bad_segment_key": "links[4].segments[1].lenght_m: unknown key (did you mean 'links[4].segments[1].length_m'?)",
    "bad_segment_length": "links[4].length_m: must equal the sum of the segment lengths 0.26 (got 0.3)",
    "bad_third_reference": "joints[5].connects[1]: link 'rocker2' has no third joint point: give it third_joint_m",
    "bad_third_position": "links[1].third_joint_m: x must lie along the link, 0 <= x <= 0.2794 (got [0.4, 0.07])",
    "bad_prismatic_ends": "joints[2].connects: a prismatic joint connects 'ground' (its guide) and exactly one link end",
    "bad_guide_key": "joints[2].guide_angle: unknown key (did you mean 'joints[2].guide_angle_deg'?)",
    "bad_guide_on_revolute": "joints[1].guide_angle_deg: only a prismatic joint takes it (type is 'revolute')",
    "bad_slider_mass": "joints[2].slider_mass_kg: must be >= 0.0 (got -0.45)",
    "bad_slider_branch": "joints[2].assembly: must be one of 'ahead', 'behind' (got 'left')",
    "bad_slider_offset": "analysis.crank_angles_deg[0]: the linkage cannot be assembled for θ in [0.00°, 360.00°]",
    "bad_mass_position": "masses[0].position_m: must be <= the length 0.15 of link 'rod' (got 0.2)",
    "bad_mass_inertia": "masses[0].inertia_kg_m2: must be >= 0.0 (got -2e-05)",
    "bad_mass_both": "masses[0].position_m: give joint or position_m (along the link), not both",
}


def test_new_scenes_check_clean():
    """`fkev check` accepts the shipped linkage scenes (every key validated, assembly at every angle)."""
    from fkev_slepc.cli import main

    assert main(["check", str(SCENES["slider-crank"]), str(SCENES["stephenson-six-bar"])]) == 0


@pytest.mark.mpi
@pytest.mark.parametrize("name", list(SCENES))
def test_two_rank_run_and_mode_shape_plot(name, tmp_path):
    """`mpiexec -n 2 fkev run` on a tiny grid of each new scene gives the frequencies of a
    direct dense solve, and `fkev plot --kind mode-shape` draws it (guides, branches)."""
    import os
    import shutil
    import subprocess
    import sys

    from fkev_slepc.archive.reader import load

    if shutil.which("mpiexec") is None:  # pragma: no cover - part of the stack
        pytest.skip("mpiexec not found")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
    out = tmp_path / "a.h5"
    cmd = ["mpiexec", "-n", "2", sys.executable, "-m", "fkev_slepc", "run", str(SCENES[name]), "-o", str(out),
           "--angles", "0,90,200", "--speeds", "0,300", "--cases", "structure,full", "--mode-shapes",
           "--solver", "dense", "--quiet"]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode in (0, 3), r.stderr
    res = load(out)
    model = Model(load_scene(SCENES[name]), cases=("structure", "full"))
    for a, angle in enumerate((0.0, 90.0, 200.0)):
        f = frequencies(model, angle, 300.0, "full", n=res.modes.size).frequency_hz
        np.testing.assert_allclose(res.frequency_hz[a, 1, 1], f, rtol=1e-10)
    png = tmp_path / "m.png"
    r = subprocess.run([sys.executable, "-m", "fkev_slepc", "plot", str(out), "--kind", "mode-shape", "--angle", "90",
                        "-o", str(png)], env=env, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert png.stat().st_size > 10_000


def test_mode_shape_moves_the_slider_along_its_guide():
    """The plot reads the slider's guide from the scene text: a slider node's one translational
    DOF is drawn along the guide, and the branch of a ternary link is its own polyline."""
    from fkev_slepc.archive.reader import Mesh
    from fkev_slepc.plots.shapes import element_displacement, guides, linkage_polyline, node_axes

    text = slider_crank(guide="position_m = [0.0, 0.01]\nguide_angle_deg = 20.0")
    model = Model(parse_scene(text, "t.toml"), cases=("full",))
    mech = model.mechanism
    mesh = Mesh(mech.node_link, mech.node_s, mech.node_dofs, mech.elem_nodes, mech.link_names)
    xy = model.node_positions(np.radians(40.0))
    lines = guides(text)
    axes = node_axes(mesh, xy, lines)
    node = mech.point_node[1, 1]
    t = np.array([np.cos(np.radians(20.0)), np.sin(np.radians(20.0))])
    np.testing.assert_allclose(axes[node], t)
    q = np.zeros(mech.n_free)
    q[mech.node_dofs[node, 0]] = 1e-3
    d = element_displacement(mesh, xy, q, np.array([1.0]), axes)[-1, 0]  # the rod's last element, at the slider
    np.testing.assert_allclose(d, 1e-3 * t, atol=1e-15)
    model6 = Model(load_scene(SCENES["stephenson-six-bar"]), cases=("full",))
    m6 = model6.mechanism
    mesh6 = Mesh(m6.node_link, m6.node_s, m6.node_dofs, m6.elem_nodes, m6.link_names)
    line = linkage_polyline(mesh6, model6.node_positions(0.3), None, np.array([0.0, 1.0]))
    assert np.isnan(line[:, 0]).sum() == m6.beam_link.size - 1  # one polyline per beam


def test_slider_crank_transmission_angle():
    """In-line slider-crank: μ = 90° − (rod angle to the guide), smallest 90° − asin(r/L) at θ = ±90°."""
    from fkev_slepc.model.kinematics import solve_kinematics
    from fkev_slepc.model.mechanism import build_mechanism

    kin = solve_kinematics(build_mechanism(load_scene(SCENES["slider-crank"])), np.radians([0.0, 90.0, 270.0]))
    np.testing.assert_allclose(np.degrees(kin.transmission), [90.0, *[90.0 - np.degrees(np.arcsin(0.3))] * 2],
                               rtol=1e-12)
