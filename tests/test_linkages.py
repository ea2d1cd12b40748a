"""General planar linkages (docs/linkages.md): stepped links, lumped masses anywhere with rotary
inertia, ternary links, prismatic joints (slider-cranks), against closed forms, first-principles
balances and the four-bar special case."""

from __future__ import annotations


import numpy as np
import pytest
from builders import frequencies
from linkage_cases import (
    DATA, PIECES, ROOT, RUNS, SCENES, STEEL_TOML, _pieces, _section, central_mass_equation, dead_centre_rod, driven, joint, link,
    link_eigen, linkage_mechanisms, pinned_beam, slider_crank, tip_inertia_cantilever, tip_inertia_equation,
)

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene, parse_scene
from fkev_slepc.scene.cases import CASE_NAMES

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


def test_slider_crank_guide_frame():
    """The slider node keeps one translation, along the guide; the normal one is a fixed DOF."""
    sc = parse_scene(slider_crank(guide="guide_angle_deg = 30.0\nposition_m = [0.0, 0.02]"), "t.toml")
    mech = Model(sc, cases=("full",)).mechanism
    node = mech.point_node[1, 1]
    assert mech.node_dofs[node, 0] >= 0 and mech.node_dofs[node, 1] == -1
    np.testing.assert_allclose(mech.node_axis[node], [np.cos(np.pi / 6), np.sin(np.pi / 6)])


@pytest.fixture(params=list(linkage_mechanisms()))
def mech(request):
    return linkage_mechanisms()[request.param]()


def test_guide_reaction_balances_the_slider(mech):
    """The rod's force at the slider is the guide's normal reaction only (along the normal)."""
    from fkev_slepc.model.kinematics import solve_kinematics
    from fkev_slepc.model.kinetostatics import solve_loads

    loads = solve_loads(mech, solve_kinematics(mech, np.radians(np.arange(0.0, 360.0, 7.5))))
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
    from fkev_slepc.archive.reader import NodeDofMap
    from fkev_slepc.plots.shapes import element_displacement, guides, linkage_polyline, node_axes

    text = slider_crank(guide="position_m = [0.0, 0.01]\nguide_angle_deg = 20.0")
    model = Model(parse_scene(text, "t.toml"), cases=("full",))
    mech = model.mechanism
    mesh = NodeDofMap(mech.node_link, mech.node_s, mech.node_dofs, mech.elem_nodes, mech.link_names)
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
    mesh6 = NodeDofMap(m6.node_link, m6.node_s, m6.node_dofs, m6.elem_nodes, m6.link_names)
    line = linkage_polyline(mesh6, model6.node_positions(0.3), None, np.array([0.0, 1.0]))
    assert np.isnan(line[:, 0]).sum() == m6.beam_link.size - 1  # one polyline per beam


def test_slider_crank_transmission_angle():
    """In-line slider-crank: μ = 90° − (rod angle to the guide), smallest 90° − asin(r/L) at θ = ±90°."""
    from fkev_slepc.model.kinematics import solve_kinematics
    from fkev_slepc.model.mechanism import build_mechanism

    kin = solve_kinematics(build_mechanism(load_scene(SCENES["slider-crank"])), np.radians([0.0, 90.0, 270.0]))
    np.testing.assert_allclose(np.degrees(kin.transmission), [90.0, *[90.0 - np.degrees(np.arcsin(0.3))] * 2],
                               rtol=1e-12)
