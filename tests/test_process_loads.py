"""Process loads (the scene's [[loads]], docs/response.md §1.2): validation naming the field,
the kinetostatics against virtual work and the power balance, the axial force across a load
inside an element, and the elastic response of a stiff cantilever against beam formulas."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from builders import bahgat_willmert, cantilever
from clitools import ROOT, problem_lines
from clitools import fkev as run_fkev

from fkev_slepc.api.response import study_response
from fkev_slepc.model.joint_loads import joint_loads
from fkev_slepc.model.mechanism import build_mechanism
from fkev_slepc.scene import SceneError, parse_scene
from fkev_slepc.scene.process_loads import ProcessLoad

SLIDER_TEXT = (ROOT / "runs" / "slider-crank.toml").read_text()  # in-line, r = 0.045 m, L = 0.15 m
E, A, I, LENGTH = 2.07e11, 2e-4, 1.6667e-9, 0.2
ARM = cantilever(LENGTH, dict(youngs_modulus=E, density=7850.0, area=A, second_moment=I), elements=4,
                 speeds=(0.1,))  # links[0] "blade", four 0.05 m elements


def on_arm(S, fx, fy, moment=0.0):
    """ARM with a constant link-frame force and moment at S m from its root."""
    return replace(ARM, process_loads=(ProcessLoad("p", f"blade:{S}", "blade", S, None, "link", (0.0,), (fx,),
                                                   (fy,), (moment,)),))


def load_item(at, fx, fy, moment=None, frame="ground", angles=(0.0,), name="p"):
    m = "" if moment is None else f"moment_n_m = {list(moment)}\n"
    return (f'\n[[loads]]\nname = "{name}"\nat = "{at}"\nframe = "{frame}"\ncrank_angle_deg = {list(angles)}\n'
            f"fx_n = {list(fx)}\nfy_n = {list(fy)}\n{m}")


@pytest.mark.parametrize("item,path,words", [
    (load_item("Q", [1], [0]), "loads[0].at", "must be a joint name"),
    (load_item("rod:0.2", [1], [0]), "loads[0].at", "0 <= S <= 0.15"),
    (load_item("rod.tip", [1], [0], frame="guide"), "loads[0].frame", "must be one of"),
    (load_item("P", [1, 2], [0, 0], angles=(0, 90, 180)), "loads[0].fx_n", "one value per crank_angle_deg"),
    (load_item("P", [1, 2], [0, 0], angles=(90, 90)), "loads[0].crank_angle_deg[1]", "must increase"),
    (load_item("P", [1, 2], [0, 0], angles=(0, 360)), "loads[0].crank_angle_deg", "360"),
    (load_item("P", [1], [0], moment=[3]), "loads[0].moment_n_m", "slider block cannot turn"),
    (load_item("P", [1], ["x"]), "loads[0].fy_n[0]", "must be a number"),
])
def test_bad_loads_name_the_field(item, path, words):
    with pytest.raises(SceneError) as err:
        parse_scene(SLIDER_TEXT + item)
    assert any(p.path == path and words in p.message for p in err.value.problems), err.value


def test_cli_refuses_a_bad_load_before_work(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SLIDER_TEXT + load_item("rod:x", [1], [0]))
    r = run_fkev("loads", bad)
    assert r.returncode == 2 and any(ln.startswith("loads[0].at:") for ln in problem_lines(r.stderr)), r.stderr


def test_units_convert_forces_moments_and_the_station():
    """With [units] length mm and force kN, ``at = "rod:0.07"`` is 0.07 mm, 2 kN 2000 N and a
    moment of 1 kN mm 1 N m."""
    units = '\n[units]\nlength = "mm"\nforce = "kN"\n'
    sc = parse_scene(SLIDER_TEXT + load_item("rod:0.07", [2], [3], moment=[1.0]) + units)
    (pl,) = sc.process_loads
    assert pl.point == pytest.approx(0.07e-3, rel=1e-15) and pl.fx == (2000.0,) and pl.moment == (1.0,)


def test_guide_force_over_half_the_stroke_is_virtual_work():
    """A constant force F along the guide over θ in [0°, 180°] changes the driving torque by
    exactly −F ds/dθ (virtual work, s = r cos θ + √(L² − r² sin² θ)) to 1e-10 at every angle, the
    wrist pin takes it (Δpin_x = −F), and the power check τΩ + F·v = dE/dt holds (1e-12), with
    gravity."""
    F = 500.0
    item = load_item("P", [F, F, 0, 0], [0] * 4, angles=(0, 180, 180.001, 359.999), name="cut")
    base, cut = (build_mechanism(parse_scene(SLIDER_TEXT + x)) for x in ("", item))
    th = np.radians(np.r_[np.arange(0.0, 181.0, 10.0), np.arange(190.0, 351.0, 10.0)])
    L0, L1 = (joint_loads(m, th, 200.0, 0.0, (0.0, -9.81)) for m in (base, cut))
    r, L = 0.045, 0.15
    ds = -r * np.sin(th) - r**2 * np.sin(th) * np.cos(th) / np.sqrt(L**2 - r**2 * np.sin(th) ** 2)
    f = np.where(th <= np.pi + 1e-12, F, 0.0)
    assert np.abs((L1.torque - L0.torque) + f * ds).max() <= 1e-10 * F * r
    assert np.abs(L1.pin_force[:, 2, 0] - L0.pin_force[:, 2, 0] + f).max() <= 1e-10 * F
    assert L1.power_residual < 1e-12 and np.abs(L1.process_power).max() > 0.1 * np.abs(L1.power).max()


def test_link_frame_force_and_moment_on_a_four_bar_keep_the_power_balance():
    """A link-frame force and a moment at a coupler station (a table over the cycle) and a
    ground-frame force at the follower's tip: τΩ + Σ(F·v + M ω) = dE/dt to 1e-12 with crank
    acceleration and gravity; without them the reported power would miss by the loads' power."""
    sc = bahgat_willmert()
    loads = (ProcessLoad("a", "coupler:0.1", "coupler", 0.1, None, "link", (0.0, 120.0, 250.0), (30.0, -20.0, 5.0),
                         (-60.0, 40.0, 10.0), (2.0, -1.0, 0.5)),
             ProcessLoad("b", "follower.tip", "follower", "tip", None, "ground", (10.0,), (15.0,), (-25.0,), (0.0,)))
    mech = build_mechanism(replace(sc, process_loads=loads))
    jl = joint_loads(mech, np.radians(np.arange(0.0, 360.0, 10.0)), 150.0, 2e3, (0.0, -9.81))
    assert jl.power_residual < 1e-12
    miss = np.abs(jl.power - jl.energy_rate).max() / np.abs(jl.energy_rate).max()
    assert miss > 1e-3


def test_axial_force_jumps_at_a_load_inside_an_element():
    """At rest, an axial force F at S = 0.07 m (inside the second of four 0.05 m elements) of a
    cantilever arm: N = F at every element end before S, 0 after (exact at the element ends),
    and the root bearing takes −F."""
    F = 300.0
    jl = joint_loads(build_mechanism(on_arm(0.07, F, 0.0)), np.radians([0.0, 33.0]), 0.0)
    s, N = jl.link_axial(0)
    np.testing.assert_allclose(s, [0, 0.05, 0.05, 0.1, 0.1, 0.15, 0.15, 0.2], atol=1e-15)
    np.testing.assert_allclose(N, np.tile([F, F, F, 0, 0, 0, 0, 0], (2, 1)), atol=1e-12 * F)
    np.testing.assert_allclose(jl.end_along[:, 0, 0], -F, rtol=1e-14)


def test_elastic_response_of_a_stiff_arm_under_a_process_load_is_the_beam_formula():
    """Consistent nodal loads of a point force and moment inside an element (link frame, constant)
    on a clamped arm turning slowly (0.1 rad/s, first frequency ~1e4 rad/s): the response minus
    the one without the load gives the tip deflections of the cantilever formulas, axial F_x S/EA
    and transverse F_y S²(3L − S)/(6EI) + M S(2L − S)/(2EI), to 1e-9 (Hermite elements are exact
    at the nodes for point loads)."""
    S, Fx, Fy, M = 0.07, 300.0, 40.0, 5.0
    mech = build_mechanism(ARM)
    tip_node = int(np.argmax(mech.node_s))

    def tip(scene):
        r = study_response(scene, 0.1, "structure", [0.0, 90.0, 200.0], shoot=False)
        d, th = r.node_displacement[:, tip_node], np.radians(r.angle_deg)
        return np.stack([np.cos(th) * d[:, 0] + np.sin(th) * d[:, 1], -np.sin(th) * d[:, 0] + np.cos(th) * d[:, 1]], -1)

    dt = tip(on_arm(S, Fx, Fy, M)) - tip(ARM)
    u = Fx * S / (E * A)
    v = Fy * S**2 * (3 * LENGTH - S) / (6 * E * I) + M * S * (2 * LENGTH - S) / (2 * E * I)
    assert np.abs(dt[:, 0] / u - 1).max() < 1e-9 and np.abs(dt[:, 1] / v - 1).max() < 1e-9


def test_example_scene_reads(tmp_path):
    sc = parse_scene(Path(ROOT / "runs" / "packaging-slider-crank.toml").read_text())
    (cut,) = sc.process_loads
    assert cut.joint == "B" and max(cut.fx) == 800.0


def test_block_load_in_the_elastic_model_stretches_crank_and_rod_in_series():
    """A force F along the guide on the slider block at top dead centre (crank and rod on the
    guide's line): K q = f moves the block by F (L_c/EA_c + L_r/EA_r), the two links' axial
    compliances in series (exact for nodal loads); a force normal to the guide goes into the
    guide (zero load vector)."""
    from fkev_slepc.model.operators import Model
    from fkev_slepc.model.process_loads import process_load_vectors
    from fkev_slepc.periodic.system import PeriodicSystem

    F = 1000.0
    for fx, fy in ((F, 0.0), (0.0, F)):
        model = Model(parse_scene(SLIDER_TEXT + load_item("P", [fx], [fy])), cases=("structure",))
        f = process_load_vectors(model, [0.0])
        if fy:
            assert not f.any()
            continue
        K = PeriodicSystem(model, 0.0, "structure").coefficients(np.array([0.0])).K
        q = np.linalg.solve(K[0], f[0])
        mech = model.mechanism
        block = q[mech.node_dofs[mech.point_node[1, 1], 0]]  # rod tip, along the guide
        crank, rod = model.scene.links
        exact = F * (crank.length / (crank.youngs_modulus * crank.area) + rod.length / (rod.youngs_modulus * rod.area))
        assert abs(block / exact - 1) < 1e-12


@pytest.mark.parametrize("element", ["thesis", "cubic"])
def test_consistent_point_load_of_both_element_types_is_exact_at_the_nodes(element):
    """K q = f with the consistent loads of a force and moment inside an element: the cantilever
    formulas at the tip to 1e-12 for both element types (the cubic one's internal axial DOFs
    take their share)."""
    from fkev_slepc.model.operators import Model
    from fkev_slepc.model.process_loads import process_load_vectors
    from fkev_slepc.solve.accuracy import with_element
    from fkev_slepc.periodic.system import PeriodicSystem

    S, Fx, Fy, M = 0.07, 300.0, 40.0, 5.0
    model = Model(with_element(on_arm(S, Fx, Fy, M), element), cases=("structure",))
    f = process_load_vectors(model, [0.0])
    K = PeriodicSystem(model, 0.0, "structure").coefficients(np.array([0.0])).K
    q = np.linalg.solve(K[0], f[0])
    d = model.mechanism.node_dofs[np.argmax(model.mechanism.node_s)]
    u = Fx * S / (E * A)
    v = Fy * S**2 * (3 * LENGTH - S) / (6 * E * I) + M * S * (2 * LENGTH - S) / (2 * E * I)
    assert abs(q[d[0]] / u - 1) < 1e-12 and abs(q[d[1]] / v - 1) < 1e-12
