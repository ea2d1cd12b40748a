"""One periodic system for Floquet and the response (fkev_slepc/periodic/system.py, fkev_slepc/periodic/cycle_mean.py;
docs/theory.md §18.7, docs/response.md §3): its generator against the independent dense one, the
gravity of the response against a rotated scene, and the one cycle-mean frequency."""

import numpy as np
from clitools import ROOT

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene, with_elements
from fkev_slepc.periodic import magnus as fq
from fkev_slepc.periodic.cycle_mean import cycle_mean
from fkev_slepc.periodic.floquet import floquet_multipliers
from fkev_slepc.periodic.settings import PeriodicSettings
from fkev_slepc.periodic.system import PeriodicSystem

RUNS = ROOT / "runs"


def test_no_coriolis_multipliers_match_the_dense_unscaled_monodromy():
    """Issue 27 item 2: Bahgat-Willmert, 1 element per link, no_coriolis at 600 rad/s. The generator's
    DOF scaling is fixed once per system, so the interpolation check reaches its tolerance (it stalled
    at 3.1e-6 with 1,024 samples when each batch was scaled by its own mean diagonals, and max|μ| was
    1.9e-6 off with a stated error of 1e-10); the multipliers agree with the unscaled dense generator
    (M, C, K) -> [[0, I], [-M⁻¹K, -M⁻¹C]] integrated by the Magnus monodromy directly, within the stated
    error (measured 2.7e-11 on max|μ|, 1.0e-10 on every μ at 4,096 reference steps)."""
    model = Model(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), 1), ("no_coriolis",))
    w = 600.0
    res = floquet_multipliers(PeriodicSystem(model, w, "no_coriolis"),
                              PeriodicSettings(reduce="none", monodromy_tol=1e-10))  # the accuracy of the former default
    assert res.interp_error <= 1e-12 and res.samples < 1024
    system = PeriodicSystem(model, w, "no_coriolis")

    def time_form(theta):  # the equation in θ: Ω²M q'' + ΩC q' + K q = 0
        M, C, K = system.mck(theta)
        return w * w * M, w * C, K

    ref = fq.monodromy(fq.second_order(time_form), 2 * np.pi, steps=4096)
    i, j = fq.match_multipliers(res.multipliers, ref.multipliers)
    gap = np.max(np.abs(res.multipliers[i] - ref.multipliers[j]))
    assert gap < 1e-9 and gap <= res.error + 2 * ref.error
    assert abs(res.max_abs - ref.max_abs) < 1e-10


def test_generator_scaling_is_one_for_every_batch():
    """The generator at one angle is the same whether asked alone or in a batch with others."""
    model = Model(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), 1), ("no_tangential",))
    s = PeriodicSystem(model, 400.0, "no_tangential")
    tau = np.array([0.3, 1.1, 2.9, 4.0])
    alone = s.generator(tau[:1])[0]
    assert np.array_equal(alone, s.generator(tau)[0])


def test_cycle_mean_counts_one_revolution():
    """A uniform sweep 0:360:10 (360° repeats 0°) has the mean over 0:350:10; a non-uniform grid
    is weighted by angle (cos θ over 0, 10, 20, 180 has the periodic-trapezoid mean, not the plain
    mean); an unconverged angle (NaN) is left out of its column only."""
    a = np.arange(0.0, 361.0, 10.0)
    v = np.stack([1.0 + np.sin(np.radians(a)) ** 2, a], axis=1)
    v[-1, 1] = 0.0  # 360° is 0°: the same point, counted once (its first value)
    got = cycle_mean(a, v)
    np.testing.assert_allclose(got, v[:-1].mean(axis=0), rtol=1e-14)
    assert abs(got[0] - 1.5) < 1e-14  # mean of 1 + sin² over a revolution
    b = np.array([0.0, 10.0, 20.0, 180.0])
    f = np.cos(np.radians(b))
    w = np.array([190.0, 20.0, 170.0, 340.0]) / 2 / 360.0  # half the gaps on either side
    assert abs(cycle_mean(b, f) - w @ f) < 1e-15 and abs(cycle_mean(b, f) - f.mean()) > 0.1
    x = np.array([[1.0, 2.0], [np.nan, 4.0], [3.0, 6.0], [5.0, 8.0]])
    np.testing.assert_allclose(cycle_mean([0.0, 90.0, 180.0, 270.0], x), [(135 * 1 + 135 * 3 + 90 * 5) / 360, 5.0])


def _turned(scene, quarter_turns=1):
    """``scene`` turned by 90° per quarter turn about the origin: ground points and guides."""
    from dataclasses import replace

    c, s = np.cos(quarter_turns * np.pi / 2), np.sin(quarter_turns * np.pi / 2)
    turn = lambda p: None if p is None else (c * p[0] - s * p[1], s * p[0] + c * p[1])  # noqa: E731
    joints = tuple(replace(j, ground=turn(j.ground), guide_angle=j.guide_angle + quarter_turns * np.pi / 2)
                   for j in scene.joints)
    return replace(scene, joints=joints)


def test_response_gravity_turns_with_the_scene():
    """Issue 24: the engine slider-crank (piston 0.45 kg, a 0.12 kg lumped mass on the rod) turned by
    90° together with its gravity vector (100 g) has the same stresses, deflections and joint-force
    magnitudes at the same mechanism position (crank angle + 90°) to 1e-10; the X gravity pushed the
    lumped masses and the slider block the wrong way before (peak moment 34-37 % off)."""
    from dataclasses import replace

    from fkev_slepc.api.response import study_response

    base = load_scene(RUNS / "slider-crank.toml")
    links = tuple(replace(lk, elements=1 if lk.name == "crank" else 2, fibre_distance=0.009) for lk in base.links)
    masses = tuple(replace(m, position=0.075) for m in base.masses)  # the rod's midspan node
    scene = replace(base, links=links, masses=masses)
    g, w, a = 100 * 9.81, 300.0, np.arange(0.0, 360.0, 10.0)
    opts = dict(harmonics=12, shoot=False)
    r0 = study_response(scene, w, "full", a, gravity_m_s2=(0.0, -g), **opts)
    r1 = study_response(_turned(scene), w, "full", (a + 90.0) % 360.0, gravity_m_s2=(g, 0.0), **opts)
    for name in ("stress", "moment", "axial_force", "axial_force_rigid", "shear", "transverse", "axial"):
        x0, x1 = getattr(r0.stations, name), getattr(r1.stations, name)
        assert np.abs(x1 - x0).max() <= 1e-10 * np.abs(x0).max(), name
    d0, d1 = (np.hypot(*np.moveaxis(r.node_displacement, -1, 0)) for r in (r0, r1))
    assert np.abs(d1 - d0).max() <= 1e-10 * d0.max()
    gx = study_response(scene, w, "full", a, gravity_m_s2=(g, 0.0), **opts)
    assert np.abs(gx.stations.moment - r0.stations.moment).max() > 0.01 * np.abs(r0.stations.moment).max()


def _lone_beam(elements, slenderness=70.0):
    from dataclasses import replace

    base = with_elements(load_scene(RUNS / "rotating-cantilever.toml"), elements)
    lk = base.links[0]
    lk = replace(lk, second_moment=lk.area * (lk.length / slenderness) ** 2)
    return replace(base, links=(lk,)), lk


def test_lone_rotating_beam_is_one_static_solve():
    """Issue 24 item 3: the lone rotating beam (L/r = 70) is constant in its own frame, so its periodic
    response is one static solve (harmonics 0 and 1 of the frame rotation in global DOFs, exactly) and
    its monodromy one exponential. At λ = 2 the tip stretch is tan(kL)/k − L to the thesis element's
    h² accuracy (measured 6.6e-8 at 32 elements), with no transverse response; a four-bar is not
    constant in its link frames and keeps the harmonic balance."""
    from fkev_slepc.api.response import study_response

    errors = []
    for n in (16, 32):
        scene, lk = _lone_beam(n)
        w = 2.0 / np.sqrt(lk.density * lk.area * lk.length**4 / (lk.youngs_modulus * lk.second_moment))
        k = w * np.sqrt(lk.density / lk.youngs_modulus)
        r = study_response(scene, w, "full", [0.0, 90.0, 200.0])
        assert r.harmonics == 1 and r.hb_error < 1e-13
        tip = r.stations.axial[:, -1]
        errors.append(np.abs(tip / (np.tan(k * lk.length) / k - lk.length) - 1).max())
        assert np.abs(r.stations.transverse).max() < 1e-12 * np.abs(tip).max()
    assert errors[1] < 1e-7 and 3.5 < errors[0] / errors[1] < 4.5  # h²
    res = floquet_multipliers(PeriodicSystem(Model(scene), w, "full"), PeriodicSettings(reduce="none"))
    assert res.monodromy.steps == 1 and np.max(np.abs(np.abs(res.multipliers) - 1.0)) < 1e-10
    four_bar = Model(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), 1))
    assert PeriodicSystem(four_bar, 500.0).link_frame() is None


def test_floquet_progress_reports_every_magnus_run():
    """The progress callback of a Floquet speed sees every Magnus run of the step doubling, the last
    one complete at the monodromy's step count; the run's line names the speed and the steps."""
    from fkev_slepc.sweep.progress import Progress

    calls = []
    model = Model(with_elements(load_scene(RUNS / "bahgat-willmert-1976.toml"), 1), ("full",))
    res = floquet_multipliers(PeriodicSystem(model, 500.0, "full"),
                              PeriodicSettings(reduce="none"), progress=lambda done, steps: calls.append((done, steps)))
    runs = sorted({s for _, s in calls})
    assert runs[-1] == res.monodromy.steps and all(b == 2 * a for a, b in zip(runs, runs[1:]))
    assert all(0 < d <= s for d, s in calls) and calls[-1] == (res.monodromy.steps, res.monodromy.steps)
    line = Progress.line(512, 2048, 2.0, "fkev floquet: 500 rad/s, run of 2048 Magnus steps", "steps")
    assert line == "fkev floquet: 500 rad/s, run of 2048 Magnus steps: 512/2048 steps (25%), 256.0 steps/s, ETA 00:00:06"
