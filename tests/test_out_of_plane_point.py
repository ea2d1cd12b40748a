"""Out of plane on the analysis engines: ``Study.point(..., plane="out")``, ``Study.critical``,
``fkev point --plane out`` (docs/theory.md §19)."""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from fkev_slepc import load
from fkev_slepc.cli import main
from fkev_slepc.scene import SceneError

ROOT = Path(__file__).resolve().parents[1]
BW = ROOT / "runs/bahgat-willmert-1976.toml"
TM = ROOT / "runs/turcic-midha-1984.toml"
# Bahgat-Willmert's 0.25 in x 1 in steel bar, 1 in in the plane: I_out = h b³/12, J of the rectangle (b/a = 1/4)
BW_OUT = "second_moment_out_of_plane_m4 = 5.42e-10\ntorsion_constant_m4 = 1.826e-9\nshear_modulus_pa = 7.96e10\n"
# Turcic-Midha's thin aluminium bars, their wide side out of the plane (one value for all links: a test copy)
TM_OUT = "second_moment_out_of_plane_m4 = 2.26e-9\ntorsion_constant_m4 = 1.0e-10\nshear_modulus_pa = 2.67e10\n"
FLAT = ROOT / "runs/flat-rod-slider-crank.toml"


def with_out_of_plane(src: Path, keys: str, tmp_path: Path) -> Path:
    """A copy of ``src`` with out-of-plane section keys in its ``[link_defaults]``."""
    text = src.read_text().replace("[link_defaults]\n", "[link_defaults]\n" + keys, 1)
    out = tmp_path / src.name
    out.write_text(text)
    return out


def point(capsys, *args):
    try:
        code = main(["point", *map(str, args)])
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_fkev_point_plane_out_and_in_plane_unchanged(capsys, tmp_path):
    """--plane out: a symmetric problem (no C), SLEPc ≡ dense; the in-plane answer of the scene with
    out-of-plane data equals that of the scene without it, with and without --plane in."""
    scene = with_out_of_plane(BW, BW_OUT, tmp_path)
    base = ("--angle", "10", "--speed", "300", "--case", "full", "--json")
    code, stdout, stderr = point(capsys, scene, *base, "--plane", "out", "--cross-check")
    assert code == 0, stderr
    out = json.loads(stdout)
    assert out["plane"] == "out" and out["kind"] == "linear_symmetric" and out["n_free"] == 12
    assert out["cross_check_max_rel_diff"] < 1e-9 and out["max_real"] == 0.0
    runs = [json.loads(point(capsys, s, *base, *extra)[1]) for s, extra in
            ((BW, ()), (scene, ()), (scene, ("--plane", "in")))]
    assert all(r["plane"] == "in" for r in runs)
    for r in runs[1:]:
        np.testing.assert_allclose(np.array(r["eigenvalue"]), np.array(runs[0]["eigenvalue"]), rtol=1e-12)
    assert not np.allclose(out["frequency_hz"], runs[0]["frequency_hz"], rtol=0.01)


def test_turcic_midha_out_of_plane_slepc_matches_dense(tmp_path):
    """With lumped masses (on w) and 9 elements: SLEPc ≡ dense QZ to 1e-9, at rest and at speed."""
    st = load(with_out_of_plane(TM, TM_OUT, tmp_path))
    for speed in (0.0, 40.0):
        r = st.point(10, speed, "full", plane="out", cross_check=True, solver="slepc")
        assert r.plane == "out" and r.converged and r.cross_check < 1e-9


def test_weak_axis_divergence_speed(tmp_path):
    """Out of plane the compressed links buckle about their weak axis (docs/theory.md §19): the
    divergence speed at θ = 10° is far below the in-plane one, the point just below it is stable
    and the point just above divergent; there is no flutter out of plane (symmetric K, no C)."""
    st = load(with_out_of_plane(BW, BW_OUT, tmp_path))
    w_out, _ = st.critical("full", angle_deg=10, plane="out").lowest("divergence_speed")
    w_in, _ = st.critical("full", angle_deg=10).lowest("divergence_speed")
    assert 0 < w_out < 0.5 * w_in
    below, above = (st.point(10, f * w_out, "full", plane="out") for f in (0.999, 1.001))
    assert below.status.value == "ok" and below.divergent.size == 0
    assert above.status.value == "divergent" and above.divergent.size == 1


def test_flat_rod_slider_crank_against_hand_estimate():
    """The 20 x 8 mm rod (20 mm in the plane), 160 mm, of a slider-crank at 1200 rpm, θ = 90°: out of
    plane the slider block holds the rod's end (w = θ = 0) and the crank pin holds the other end
    against w and, through the crank's St-Venant torsion (GJ/L_crank, the crank almost normal to
    the rod), against rotation. Hand estimate: a clamped beam with a pinned end restrained by that
    rotational spring, κ = k L / EI_out: (βL)² sqrt(EI/ρA)/(2π L²). The model is within 3 % of it,
    and between the clamped-pinned and clamped-clamped bounds; in plane it is much stiffer."""
    st = load(FLAT)
    E, rho, G = 2.07e11, 7850.0, 2.07e11 / 2.6
    L, b, h = 0.16, 0.008, 0.020
    ei, rho_a = E * h * b**3 / 12, rho * b * h
    a, c = 0.030, 0.012  # the crank's section, J = a c³/3 (1 - 0.630 c/a) (thin-rectangle series)
    k = G * a * c**3 / 3 * (1 - 0.630 * c / a) / 0.04

    def det(bl, kappa):
        ch, co, sh, si = np.cosh(bl), np.cos(bl), np.sinh(bl), np.sin(bl)
        # w = A(cosh - cos) + B(sinh - sin): clamped at 0; w(L) = 0 and L w''(L) + κ w'(L) = 0 (times L²)
        return (ch - co) * (bl * (sh + si) + kappa * (ch - co)) - (sh - si) * (bl * (ch + co) + kappa * (sh + si))

    to_hz = lambda bl: bl**2 / (2 * np.pi * L**2) * np.sqrt(ei / rho_a)  # noqa: E731
    hand = to_hz(brentq(det, 3.0, 4.72, args=(k * L / ei,)))
    f_out = st.point(90, 1200 * np.pi / 30, "full", plane="out").frequency_hz[0]
    f_in = st.point(90, 1200 * np.pi / 30, "full").frequency_hz[0]
    assert to_hz(3.9266023) < f_out < to_hz(4.7300408)
    assert abs(f_out / hand - 1) < 0.03, (f_out, hand)
    assert f_in > 1.1 * f_out


def test_bad_out_of_plane_arguments_are_named(capsys, tmp_path):
    code, _, err = point(capsys, BW, "--plane", "out")
    assert code == 2 and "--plane: out-of-plane analysis needs every link's out-of-plane section data" in err
    code, _, err = point(capsys, with_out_of_plane(BW, BW_OUT, tmp_path), "--plane", "out", "--sensitivity",
                         "links[0].length_m")
    assert code == 2 and "--sensitivity: sensitivities are in plane only (got --plane out)" in err
    st = load(with_out_of_plane(BW, BW_OUT, tmp_path))
    with pytest.raises(SceneError, match="plane: must be one of in, out .got 'z'"):
        st.point(10, 0, "full", plane="z")
    with pytest.raises(SceneError, match="rel_error: the accuracy plan is in plane only"):
        st.point(10, 0, "full", plane="out", rel_error=1e-3)


def test_fkev_critical_plane_out_weak_axis_buckling_of_the_flat_rod(capsys):
    """``fkev critical --plane out`` at bottom dead centre: the rod, compressed by the carriage's
    and its own inertia, buckles about its weak axis when its mean compression reaches an Euler
    load between the clamped-pinned (2.046 π²EI_out/L²) and clamped-clamped (4 π²EI_out/L²) ones
    (the slider clamps one end, the crank's torsion nearly clamps the other); no flutter out of plane."""
    from fkev_slepc.model.operators import Model

    try:
        code = main(["critical", str(FLAT), "--plane", "out", "--angle", "180", "--json"])
    except SystemExit as exc:
        code = exc.code
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["plane"] == "out" and out["n_free"] == 27 and out["flutter_speed_rad_s"] is None
    w = out["divergence_speed_rad_s"]
    model = Model(load(FLAT).scene, plane="out")
    c = model.angle_state(np.radians([180.0])).axial[0][0]  # per Ω²: F(ξ) = c₀ + c₁ξ + c₂ξ²
    rod = model.mechanism.elem_link == 1
    mean = -np.mean(c[rod, 0] + c[rod, 1] / 2 + c[rod, 2] / 3) * w**2
    ei, L = 2.07e11 * 0.020 * 0.008**3 / 12, 0.16
    assert 2.046 * np.pi**2 * ei / L**2 < mean < 4 * np.pi**2 * ei / L**2


def test_scene_bearing_stiffness_is_the_model_bearing(tmp_path, capsys):
    """``bearing_stiffness_nm_rad = [k_t, k_b]`` on a joint is ``Model(..., bearings=...)``, in the
    scene's units (N mm/rad under mm-N-t); a bad value is one problem naming the key."""
    from fkev_slepc.model.operators import Model
    from builders import frequencies

    base = with_out_of_plane(BW, BW_OUT, tmp_path)
    text = base.read_text().replace('name = "A"\n', 'name = "A"\nbearing_stiffness_nm_rad = [300.0, 800.0]\n')
    path = tmp_path / "bearing.toml"
    path.write_text(text)
    st = load(path)
    got = st.point(37, 0, "structure", plane="out").frequency_hz
    rigid = load(base).point(37, 0, "structure", plane="out").frequency_hz
    model = Model(load(base).scene, plane="out", bearings={"A": (300.0, 800.0)})
    np.testing.assert_allclose(got, frequencies(model, 37, 0, "structure").frequency_hz, rtol=1e-12)
    assert np.all(got < rigid)
    assert st.scene.joints[1].bearing_stiffness == (300.0, 800.0)
    mm = tmp_path / "mm.toml"
    mm.write_text(text.replace("[300.0, 800.0]", "[3e5, 8e5]") + '\n[units]\nsystem = "mm-N-t"\n')
    from fkev_slepc.scene import load_scene

    assert load_scene(mm).joints[1].bearing_stiffness == pytest.approx((300.0, 800.0), rel=1e-12)
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[300.0, 800.0]", "[0.0, 800.0]"))
    try:
        code = main(["check", str(bad)])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and "joints[1].bearing_stiffness_nm_rad: must be two stiffnesses > 0, N m/rad" in err


def test_out_of_plane_mode_shapes(tmp_path):
    """shapes=True out of plane: (w, θ_X, θ_Y) per node. The slider-crank's rod is clamped by the
    slider (w = θ = 0 there); the rotating cantilever's first flapwise mode grows to the tip with
    the sign convention w' = -β (β = θ_Y for a link along X); the figure has one axes per mode
    and its twin (the twist)."""
    from builders import cantilever, rect_strip
    from fkev_slepc.api.study import Study

    r = load(FLAT).point(90, 0, "structure", modes=2, plane="out", shapes=True)
    m = r.mode_shape(1)
    assert m.plane == "out" and m.displacement.shape == (r.mesh.node_link.size, 3)
    tip = np.flatnonzero(r.mesh.node_link == 1)[np.argmax(r.mesh.node_s[r.mesh.node_link == 1])]
    assert np.all(m.displacement[tip] == 0)  # the slider's node
    fig = r.plot()
    assert len(fig.axes) == 4  # 2 modes, each with its twist axis

    props = rect_strip(0.01, 0.002)
    E, rho = props["youngs_modulus"], props["density"]
    scene = cantilever(1.0, props, 8, cases=("structure",))
    from dataclasses import replace
    from fkev_slepc.scene import Link

    links = tuple(Link(**{**lk.__dict__, "second_moment_out": 0.01 * 0.002**3 / 12, "torsion_constant": 1e-9,
                          "shear_modulus": 8e10, "polar_moment": 1.7e-10}) for lk in scene.links)
    st = Study(replace(scene, links=links), None)
    c = st.point(0, 0, "structure", modes=1, plane="out", shapes=True).mode_shape(1)
    w, th_y = c.displacement[:, 0].real, c.displacement[:, 2].real
    order = np.argsort(c.node_xy[:, 0])
    assert np.all(np.diff(np.abs(w[order])) > 0)  # grows from the root to the tip
    assert np.sign(th_y[order[-1]]) == -np.sign(w[order[-1]])  # w' = -θ_Y


def test_fkev_run_plane_out_archive(tmp_path):
    """``fkev run --plane out``: one plane per archive (root attribute plane, default output
    <stem>-out.h5), its frequencies those of ``Study.point(plane="out")``; mode shapes drawn out of
    plane; a resume with the other plane is refused naming the attribute; in-plane archives say in."""
    import shutil

    from clitools import fkev
    from fkev_slepc import open as open_archive

    scene = tmp_path / FLAT.name
    shutil.copy(FLAT, scene)
    grid = ("--angles", "0,90", "--speeds-rpm", "1200", "--quiet")
    r = fkev("run", scene, "--plane", "out", "--mode-shapes", *grid)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "out" / "flat-rod-slider-crank-out.h5"
    res = open_archive(out)
    assert res.plane == "out" and res.attrs["n_free"] == 27
    f = res.frequency()[:, 0, 0, :]
    for a, angle in enumerate((0.0, 90.0)):
        want = load(scene).point(angle, 1200 * np.pi / 30, "full", plane="out").frequency_hz
        np.testing.assert_allclose(f[a], want, rtol=1e-9)
    from fkev_slepc.plots.shapes import mode_shape

    assert len(mode_shape(res, angle=90, modes=[1, 2]).axes) == 4
    r = fkev("run", scene, "-o", out, "--resume", *grid)
    assert r.returncode == 2 and "plane: archive has out, this run in" in r.stderr + r.stdout
    r = fkev("run", scene, "-o", tmp_path / "in.h5", *grid)
    assert r.returncode == 0 and open_archive(tmp_path / "in.h5").plane == "in"
    r = fkev("run", BW, "--plane", "out", "-o", tmp_path / "x.h5", *grid)
    assert r.returncode == 2 and "--plane: out-of-plane analysis needs" in r.stderr
