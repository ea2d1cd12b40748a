"""Figures from real archives: the plotted data must be the archive's data.

The archives are produced once per session by the real sweep (`fkev run`, in this process,
dense engine on small thesis models). Expected values are read straight from the HDF5 file
with h5py, independently of :mod:`fkev_slepc.archive.reader`, and compared with what the returned
``Figure`` holds (line data, labels, units), never with pixels. A few assertions are physical
(docs/theory.md §16): the structure's frequency parameter is 1, the pseudo-normal-free fundamental
falls while the full one rises, neglecting the tangential term is the smallest error.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from matplotlib.collections import PathCollection, QuadMesh

from fkev_slepc.plots import draw as plots
from fkev_slepc.plots.shapes import element_displacement, mode_shape
from fkev_slepc.archive.reader import ArchiveError, DamagedArchiveWarning, load
from fkev_slepc.status import converged_codes

ROOT = Path(__file__).resolve().parents[1]
# 0, 10 (the thesis's study angle), 30, 60, ..., 330
ANGLES = "0,10," + ",".join(str(a) for a in range(30, 360, 30))
SIMPLIFIED = ["no_coriolis", "no_tangential", "no_normal", "no_pseudo_normal"]


def cli(*args) -> int:
    """``fkev ARGS`` in this process. The CLI configures the package logger; it is restored so
    other tests' caplog still works."""
    import logging

    from fkev_slepc.cli import main

    log = logging.getLogger("fkev_slepc")
    saved = (list(log.handlers), log.level, log.propagate)
    try:
        return main([str(a) for a in args])
    finally:
        log.handlers[:], log.propagate = saved[0], saved[2]
        log.setLevel(saved[1])


def fkev(*args, check=True) -> int:
    """``fkev run ...`` in this process (the sweep code path of ``fkev run``); its exit code."""
    code = cli(*args)
    if check and code != 0:
        raise AssertionError(f"fkev {' '.join(map(str, args))} -> {code}")
    return code


def fkev_plot(capsys, *args):
    """`fkev plot ...` in this process: (exit code, out, err)."""
    capsys.readouterr()
    code = cli("plot", *args)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="session")
def archives(tmp_path_factory):
    d = tmp_path_factory.mktemp("plot_archives")
    bw, tm1, tm2 = d / "bw.h5", d / "tm1.h5", d / "tm2.h5"
    # Bahgat-Willmert, 5 elements, all six cases, with mode shapes: 12 x 3 x 6 = 216 points
    fkev("run", ROOT / "runs/bahgat-willmert-1976.toml", "-o", bw, "--angles", ANGLES,
         "--speeds", "0,500,1000", "--modes", 3, "--mode-shapes", "--solver", "dense", "--quiet")
    # Turcic-Midha (light links): flutter and divergence appear by 100-200 rad/s (stability map)
    fkev("run", ROOT / "runs/turcic-midha-1984.toml", "-o", tm1, "--elements", 1, "--angles", ANGLES,
         "--speeds", "0,100,200", "--cases", "structure,full", "--modes", 3, "--solver", "dense", "--quiet",
         check=False)  # exit code 3 would only mean some points did not converge: checked below
    fkev("run", ROOT / "runs/turcic-midha-1984.toml", "-o", tm2, "--elements", 2, "--angles", ANGLES,
         "--speeds", "0", "--cases", "structure", "--modes", 3, "--solver", "dense", "--quiet")
    assert tm1.is_file()
    return {"bw": bw, "tm1": tm1, "tm2": tm2}


def raw(path):
    """The archive's arrays read directly with h5py."""
    with h5py.File(path, "r") as f:
        out = {k: f[k][()] for k in ("crank_angle_deg", "speed_rad_s", "mode", "frequency_hz",
                                     "tracked_frequency_hz", "status", "max_real", "damping_ratio")}
        out["case"] = [c.decode() if isinstance(c, bytes) else c for c in f["case"][()]]
        out["title"] = load(path).title
        if "modes" in f:
            out["shape"] = f["modes/shape"][()]
            out["node_xy"] = f["modes/node_xy"][()]
            out["node_dofs"] = f["mesh/node_dofs"][()]
            out["elem_nodes"] = f["mesh/elem_nodes"][()]
            out["node_link"] = f["mesh/node_link"][()]
            out["node_s"] = f["mesh/node_s"][()]
    return out


def lines_by_label(ax):
    return {ln.get_label(): ln for ln in ax.get_lines()}


def test_archive_loads_with_labels(archives):
    res, r = load(archives["bw"]), raw(archives["bw"])
    assert res.cases == tuple(r["case"]) and len(res.cases) == 6
    np.testing.assert_array_equal(res.frequency_hz, r["frequency_hz"])
    assert res.title.startswith("Bahgat-Willmert")
    assert res.has_mode_shapes and res.mesh is not None and res.mesh.n_free == 15
    assert res.elements_per_link() == (1, 2, 2)
    assert res.angle_index(360.0) == 0 and res.speed_index(500) == 1
    assert res.case_index(4) == res.cases.index("no_normal")
    with pytest.raises(ArchiveError, match="not on the archive's crank-angle grid"):
        res.angle_index(20.0)


def test_freq_angle_lines_are_the_tracked_archive_data(archives):
    """Each tracked line is the archive's tracked data at the grid angles and, in angle order, at
    the extra angles its line was refined at (/tracking/refined: dotted points, counted in the title)."""
    r = raw(archives["bw"])
    fig = plots.freq_angle(load(archives["bw"]))
    full = r["case"].index("full")
    assert r["title"] in fig._suptitle.get_text()
    assert len(fig.axes) == 3
    with h5py.File(archives["bw"], "r") as f:
        g = f["tracking/refined"]
        ref_angles, ref_f, ref_status = g["crank_angle_deg"][()], g["tracked_frequency_hz"][()], g["status"][()]
    drawn = set()
    for m, ax in enumerate(fig.axes):
        assert ax.get_title() == f"mode {m + 1}"
        assert "(deg)" in ax.get_xlabel() and "(Hz)" in ax.get_ylabel()
        lines = lines_by_label(ax)
        assert sorted(lines) == sorted(f"Ω = {s:g} rad/s" for s in r["speed_rad_s"])
        for s, omega in enumerate(r["speed_rad_s"]):
            ln = lines[f"Ω = {omega:g} rad/s"]
            x, y = np.asarray(ln.get_xdata()), np.asarray(ln.get_ydata())
            assert np.all(np.diff(x) > 0)
            grid = np.isin(x, r["crank_angle_deg"])
            np.testing.assert_array_equal(x[grid], r["crank_angle_deg"])
            np.testing.assert_array_equal(y[grid], r["tracked_frequency_hz"][:, s, full, m])
            solved = np.isin(ref_status[:, s, full], converged_codes())  # refined for this line, converged
            np.testing.assert_array_equal(x[~grid], ref_angles[solved])
            np.testing.assert_array_equal(y[~grid], ref_f[solved, s, full, m])
            assert list(ln.get_markevery()) == np.flatnonzero(~grid).tolist()
            drawn.update(x[~grid].tolist())
    assert drawn, "the 30° grid at 1000 rad/s has veerings the sweep refines"
    assert f"dots: {len(drawn)} extra angles solved where the MAC was ambiguous" in fig._suptitle.get_text()
    # the sorted order on request, for one speed and one mode, another case
    fig = plots.freq_angle(load(archives["bw"]), cases=["no_normal"], speeds=[500], modes=[2], order="sorted")
    (ax,) = fig.axes
    c = r["case"].index("no_normal")
    (ln,) = ax.get_lines()
    assert ln.get_label() == "Ω = 500 rad/s, no_normal"
    np.testing.assert_array_equal(ln.get_ydata(), r["frequency_hz"][:, 1, c, 1])


def test_freq_angle_overlays_meshes(archives):
    """Turcic-Midha 3- and 6-element structure: one curve per mesh, labelled by its elements.
    The 6-element mesh nests the 3-element one, so (Rayleigh-Ritz) every sorted frequency falls."""
    a, b = load(archives["tm1"]), load(archives["tm2"])
    fig = plots.freq_angle([a, b], cases=["structure"], speeds=[0], order="sorted")
    assert "meshes: 3 el (1+1+1), 6 el (2+2+2)" in fig._suptitle.get_text()
    for m, ax in enumerate(fig.axes):
        lines = lines_by_label(ax)
        l3 = lines["Ω = 0 rad/s, structure, 3 el (1+1+1)"]
        l6 = lines["Ω = 0 rad/s, structure, 6 el (2+2+2)"]
        np.testing.assert_array_equal(l3.get_ydata(), raw(archives["tm1"])["frequency_hz"][:, 0, 0, m])
        np.testing.assert_array_equal(l6.get_ydata(), raw(archives["tm2"])["frequency_hz"][:, 0, 0, m])
        assert np.all(l6.get_ydata() <= l3.get_ydata() * (1 + 1e-12))


def test_param_speed_is_ratio_to_structure(archives):
    r = raw(archives["bw"])
    a = list(r["crank_angle_deg"]).index(10.0)
    fig = plots.param_speed(load(archives["bw"]))  # default angle: 10 deg
    s0 = r["case"].index("structure")
    f = r["frequency_hz"][a]
    w1 = 2 * np.pi * f[0, s0, 0]
    assert "θ = 10°" in fig._suptitle.get_text()
    for m, ax in enumerate(fig.axes):
        assert "α" in ax.get_xlabel() and "ω" in ax.get_ylabel()
        lines = lines_by_label(ax)
        assert sorted(lines) == sorted(plots.case_label(c) for c in r["case"])
        for c, name in enumerate(r["case"]):
            ln = lines[plots.case_label(name)]
            np.testing.assert_allclose(ln.get_xdata(), r["speed_rad_s"] / w1, rtol=1e-12)
            np.testing.assert_allclose(ln.get_ydata(), f[:, c, m] / f[:, s0, m], rtol=1e-12)
        # C3: the structure's curve is the horizontal line 1
        np.testing.assert_allclose(lines[plots.case_label("structure")].get_ydata(), 1.0, rtol=1e-9)
    # C7 at θ = 10°: at the top speed the full fundamental stiffens, the pseudo-normal-free one softens
    lines = lines_by_label(fig.axes[0])
    assert lines[plots.case_label("full")].get_ydata()[-1] > 1.05
    assert lines[plots.case_label("no_pseudo_normal")].get_ydata()[-1] < 0.95


def test_error_angle_is_percent_error_vs_full(archives):
    r = raw(archives["bw"])
    fig = plots.error_angle(load(archives["bw"]), order="sorted")  # default: highest speed, cases 2-5
    s = 2
    full = r["case"].index("full")
    assert "Ω = 1000 rad/s" in fig._suptitle.get_text()
    peak = {}
    for m, ax in enumerate(fig.axes):
        assert "(%)" in ax.get_ylabel() and "(deg)" in ax.get_xlabel()
        lines = lines_by_label(ax)
        shown = sorted(k for k in lines if not k.startswith("_"))
        assert shown == sorted(plots.case_label(c) for c in SIMPLIFIED)
        for name in SIMPLIFIED:
            c = r["case"].index(name)
            f_c, f_full = r["frequency_hz"][:, s, c, m], r["frequency_hz"][:, s, full, m]
            want = (f_c - f_full) / f_full * 100
            y = lines[plots.case_label(name)].get_ydata()
            np.testing.assert_allclose(y, want, rtol=1e-12, atol=1e-12)
            peak[name] = max(peak.get(name, 0.0), float(np.max(np.abs(y))))
    # C5/C10 on this grid: tangential neglect is small, pseudo-normal neglect the largest
    assert peak["no_tangential"] < 1.0 < peak["no_normal"] < peak["no_pseudo_normal"]


def test_error_angle_compares_mac_matched_modes(archives):
    """Default: mode i of full against the mode of each case with the same shape (MAC on the
    archived eigenvector entries, recomputed here by hand), gaps and × where no match is clear."""
    r = raw(archives["bw"])
    with h5py.File(archives["bw"], "r") as f:
        sig = f["tracking/signature"][:, 2]  # 1000 rad/s
    fig = plots.error_angle(load(archives["bw"]))
    full = r["case"].index("full")
    flagged = 0
    for m, ax in enumerate(fig.axes):
        lines = lines_by_label(ax)
        for name in SIMPLIFIED:
            c = r["case"].index(name)
            y = lines[plots.case_label(name)].get_ydata()
            u = sig[:, full, :, m]
            macs = np.abs(np.einsum("ak,akj->aj", u.conj(), sig[:, c])) ** 2 / (
                np.einsum("ak,ak->a", u.conj(), u).real[:, None] * np.einsum("akj,akj->aj", sig[:, c].conj(), sig[:, c]).real)
            j = np.argmax(macs, axis=1)
            f_c = r["frequency_hz"][np.arange(len(j)), 2, c, j]
            want = (f_c - r["frequency_hz"][:, 2, full, m]) / r["frequency_hz"][:, 2, full, m] * 100
            shown = np.isfinite(y)
            np.testing.assert_allclose(y[shown], want[shown], rtol=1e-12, atol=1e-12)
            assert np.all(macs[shown, j[shown]] >= 0.8)  # never a comparison of different shapes
            marks = [ln for ln in ax.get_lines() if ln.get_label() == f"_nomatch {name}"]
            n_marks = len(marks[0].get_xdata()) if marks else 0
            assert n_marks == np.count_nonzero(~shown)
            flagged += n_marks
    assert flagged > 0 and f"× {flagged} points with no MAC match" in fig._suptitle.get_text()
    # matched, the neglect of the tangential term stays small at every matched point (docs/theory.md §16)
    y = lines_by_label(fig.axes[0])[plots.case_label("no_tangential")].get_ydata()
    assert np.nanmax(np.abs(y)) < 1.0


def _hermite_mid(mesh_dofs, elem_nodes, xy, q):
    """Displacement at the middle of each element, written out from docs/theory.md §4 at ξ = 1/2:
    u = (u1+u2)/2, v = (v1+v2)/2 + l(φ1−φ2)/8, in the element frame."""
    vals = np.append(q, 0.0)[mesh_dofs]
    n1, n2 = elem_nodes.T
    d = xy[n2] - xy[n1]
    ln = np.hypot(d[:, 0], d[:, 1])
    e = d / ln[:, None]
    en = np.c_[-e[:, 1], e[:, 0]]
    u = 0.5 * ((vals[n1, :2] * e).sum(1) + (vals[n2, :2] * e).sum(1))
    v = 0.5 * ((vals[n1, :2] * en).sum(1) + (vals[n2, :2] * en).sum(1)) + ln * (vals[n1, 2] - vals[n2, 2]) / 8
    return u[:, None] * e + v[:, None] * en


def element_rows(r, pts):
    """Rows of the drawn polyline belonging to each mesh element: links are separated by a
    NaN row, and within a link the elements follow from its root, N_SUB samples each."""
    from fkev_slepc.plots.shapes import N_SUB

    n1 = r["elem_nodes"][:, 0]
    order = np.lexsort((r["node_s"][n1], r["node_link"][n1]))
    valid = np.flatnonzero(~np.isnan(pts[:, 0]))
    assert valid.size == N_SUB * n1.size
    return {k: valid[j * N_SUB:(j + 1) * N_SUB] for j, k in enumerate(order)}


def test_mode_shape_draws_interpolated_archive_shapes(archives):
    r = raw(archives["bw"])
    res = load(archives["bw"])
    a, s = list(r["crank_angle_deg"]).index(30.0), 2  # 30 deg, 1000 rad/s
    fig = mode_shape(res, angle=30, speed=1000, cases=["structure", "full", "no_pseudo_normal"], modes=[1, 2])
    assert "θ = 30°" in fig._suptitle.get_text() and "Ω = 1000 rad/s" in fig._suptitle.get_text()
    xy = r["node_xy"][a]
    n1, n2 = r["elem_nodes"].T
    for m, ax in enumerate(fig.axes):
        assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
        lines = lines_by_label(ax)
        und = np.c_[lines["undeformed"].get_xdata(), lines["undeformed"].get_ydata()]
        rows = element_rows(r, und)
        for k in range(n1.size):  # the undeformed line runs through the archived node positions
            np.testing.assert_allclose(und[rows[k][[0, -1]]], xy[[n1[k], n2[k]]], atol=1e-15)
        for name in ("structure", "full", "no_pseudo_normal"):
            c = r["case"].index(name)
            ln = lines[f"{plots.case_label(name)}: {r['frequency_hz'][a, s, c, m]:.1f} Hz"]
            disp = np.c_[ln.get_xdata(), ln.get_ydata()] - und
            x = r["shape"][a, s, c, :, m]
            # element ends: the drawn displacement is Re(z·x) at the node translations for one
            # complex z (scale and phase); find z by least squares, then check every node
            xe = np.append(x, 0)  # index -1 (constrained) reads 0
            U = np.array([xe[r["node_dofs"][nd, :2]] for k in range(n1.size) for nd in (n1[k], n2[k])])
            D = np.array([disp[rows[k][i]] for k in range(n1.size) for i in (0, -1)])
            A = np.c_[np.r_[U.real[:, 0], U.real[:, 1]], -np.r_[U.imag[:, 0], U.imag[:, 1]]]
            zr, zi = np.linalg.lstsq(A, np.r_[D[:, 0], D[:, 1]], rcond=None)[0]
            z = complex(zr, zi)
            tol = 1e-9 * np.abs(D).max()
            np.testing.assert_allclose(np.real(z * U), D, atol=tol)
            # mid-element points follow the cubic Hermite interpolation of the same shape
            mid = _hermite_mid(r["node_dofs"], r["elem_nodes"], xy, np.real(z * x))
            for k in range(n1.size):
                np.testing.assert_allclose(disp[rows[k][len(rows[k]) // 2]], mid[k], atol=tol)


def test_element_displacement_reproduces_nodal_values(archives):
    """At ξ = 0 and 1 the interpolated displacement equals the nodal translations, for any
    DOF vector; rigid translations of the whole mesh are drawn exactly."""
    res = load(archives["bw"])
    xy = res.node_xy[0]
    rng = np.random.default_rng(1)
    q = rng.normal(size=res.mesh.n_free)
    d = element_displacement(res.mesh, xy, q, np.array([0.0, 1.0]))
    vals = np.append(q, 0.0)[res.mesh.node_dofs]
    np.testing.assert_allclose(d[:, 0], vals[res.mesh.elem_nodes[:, 0], :2], atol=1e-14)
    np.testing.assert_allclose(d[:, 1], vals[res.mesh.elem_nodes[:, 1], :2], atol=1e-14)


def test_mode_shape_without_shapes_is_a_clear_error(archives, capsys):
    with pytest.raises(ArchiveError, match="fkev run SCENE --mode-shapes"):
        plots.draw(load(archives["tm1"]), "mode-shape")
    code, _, err = fkev_plot(capsys, archives["tm1"], "--kind", "mode-shape")
    assert code == 2
    assert "no mode shapes" in err and "fkev run SCENE --mode-shapes" in err


def test_stability_map_holds_min_damping_ratio_and_marks_divergence(archives):
    r = raw(archives["tm1"])
    c = r["case"].index("full")
    st = r["status"][:, :, c]
    assert np.any(st == 3) and np.any(st == 4)  # this light linkage flutters and diverges
    fig = plots.stability(load(archives["tm1"]))
    ax = fig.axes[0]
    meshes = [ch for ch in ax.get_children() if isinstance(ch, QuadMesh)]
    drawn = np.asarray(meshes[-1].get_array()).reshape(st.shape[::-1])  # the ζ layer (grey divergence below)
    want = np.where(np.isin(st, (1, 3)), np.nanmin(r["damping_ratio"][:, :, c], axis=-1), np.nan)
    np.testing.assert_array_equal(np.ma.filled(drawn, np.nan), want.T)
    assert np.all(want[st == 3] < -1e-6) and np.all(want[st == 1] >= -1e-6)  # the colour's sign is the verdict
    norm = meshes[-1].norm
    assert norm.vmin == -norm.vmax and meshes[-1].get_cmap().name == "RdBu"  # diverging, centred on ζ = 0
    assert "(deg)" in ax.get_xlabel() and "(rad/s)" in ax.get_ylabel()
    assert "damping ratio" in fig.axes[-1].get_ylabel()  # colour bar
    marks = {col.get_label().split(":")[0]: col for col in ax.collections if isinstance(col, PathCollection)}
    ia, i_s = np.nonzero(st == 4)
    got = marks["divergent (real λ > 0 in the spectrum)"].get_offsets()
    np.testing.assert_array_equal(np.asarray(got), np.c_[r["crank_angle_deg"][ia], r["speed_rad_s"][i_s]])
    assert "full" in fig._suptitle.get_text() and r["title"] in fig._suptitle.get_text()


def test_campbell_lines_orders_and_crossings(archives):
    r = raw(archives["bw"])
    full = r["case"].index("full")
    fig = plots.campbell(load(archives["bw"]), angle=0, orders=8, order="sorted")
    ax = fig.axes[0]
    assert "(rad/s)" in ax.get_xlabel() and "(Hz)" in ax.get_ylabel()
    lines = lines_by_label(ax)
    for m in range(3):
        ln = lines[f"mode {m + 1}"]
        np.testing.assert_array_equal(ln.get_xdata(), r["speed_rad_s"])
        np.testing.assert_array_equal(ln.get_ydata(), r["frequency_hz"][0, :, full, m])
    orders = {ln.get_gid(): ln for ln in ax.get_lines() if (ln.get_gid() or "").startswith("order-")}
    assert sorted(orders) == sorted(f"order-{k}" for k in range(1, 9))
    for k in range(1, 9):
        x, y = orders[f"order-{k}"].get_data()
        np.testing.assert_allclose(y, k * np.asarray(x) / (2 * np.pi))
    # every crossing lies on an order line and on a mode curve (linear between grid speeds)
    (cross,) = [c for c in ax.collections if c.get_label().startswith("crossings")]
    pts = np.asarray(cross.get_offsets())
    om, f = r["speed_rad_s"], r["frequency_hz"][0, :, full, :3]
    expected = sum(
        int(np.sum(np.diff(np.sign(f[:, m] - k * om / (2 * np.pi))) != 0))
        for m in range(3)
        for k in range(1, 9)
    )
    assert len(pts) == expected > 0
    for x, y in pts:
        k = y * 2 * np.pi / x
        assert abs(k - round(k)) < 1e-9
        assert min(abs(np.interp(x, om, f[:, m]) - y) for m in range(3)) < 1e-9 * y


def test_campbell_tracks_modes_along_speed_or_says_sorted(archives):
    with h5py.File(archives["bw"], "r") as f:
        trk, fb = f["speed_tracked_frequency_hz"][()], f["tracking/speed_fallback"][()]
    r = raw(archives["bw"])
    full = r["case"].index("full")
    for a, angle in enumerate(r["crank_angle_deg"]):
        fig = plots.campbell(load(archives["bw"]), angle=angle, orders=2)
        lines = lines_by_label(fig.axes[0])
        want = r["frequency_hz"] if fb[a, full] else trk
        for m in range(3):
            np.testing.assert_array_equal(lines[f"mode {m + 1}"].get_ydata(), want[a, :, full, m])
        title = fig._suptitle.get_text()
        assert ("sorted modes" in title) == bool(fb[a, full]) and ("tracked" in title) != bool(fb[a, full])
    # speed 0 is the start of the walk: the sorted order
    np.testing.assert_array_equal(trk[:, 0], np.where(np.isin(r["status"][:, 0], [1, 3, 4])[..., None],
                                                      r["frequency_hz"][:, 0], np.nan))


@pytest.mark.parametrize("kind", plots.KINDS)
def test_cli_writes_every_kind(archives, tmp_path, capsys, kind):
    src = archives["tm1"] if kind == "stability" else archives["bw"]
    out = tmp_path / f"{kind}.png"
    args = [src, "--kind", kind, "-o", out]
    if kind in ("param-speed", "campbell", "mode-shape"):
        args += ["--angle", "30"]
    code, stdout, _ = fkev_plot(capsys, *args)
    assert code == 0 and stdout.strip() == str(out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.stat().st_size < 200_000


def test_cli_default_output_and_vector_formats(archives, tmp_path, capsys):
    src = tmp_path / "copy.h5"
    src.write_bytes(archives["bw"].read_bytes())
    code, stdout, _ = fkev_plot(capsys, src, "--kind", "error-angle", "--speed", "500", "--modes", "1,2")
    assert code == 0 and stdout.strip() == str(tmp_path / "copy_error-angle.png")
    for ext, magic in ((".svg", b"<?xml"), (".pdf", b"%PDF")):
        code, _, _ = fkev_plot(capsys, src, "--kind", "freq-angle", "-o", tmp_path / f"f{ext}")
        assert code == 0 and (tmp_path / f"f{ext}").read_bytes().startswith(magic)


def test_cli_bad_requests_exit_2(archives, tmp_path, capsys):
    bw = archives["bw"]
    for args, text in (
        (["--kind", "param-speed", "--angle", "20"], "20 deg is not on the archive's crank-angle grid"),
        (["--kind", "error-angle", "--case", "no_norml"], "unknown case 'no_norml'"),
        (["--kind", "error-angle", "--speed", "700"], "700 rad/s is not on the archive's speed grid"),
        (["--kind", "campbell", "--angle", "0,30"], "--angle: this kind takes one value"),
        (["--kind", "freq-angle", "--modes", "9"], "mode 9 is not in this archive"),
        (["--kind", "freq-angle", "-o", tmp_path / "x.jpg"], "unsupported format"),
    ):
        code, _, err = fkev_plot(capsys, bw, *args)
        assert code == 2, (args, err)
        assert text in err, (args, err)
    code, _, err = fkev_plot(capsys, tmp_path / "missing.h5", "--kind", "stability")
    assert code == 2 and "no such archive" in err
    code, _, err = fkev_plot(capsys, archives["tm1"], "--kind", "param-speed", "--case", "no_normal")
    assert code == 2 and "case 'no_normal' is not in this archive" in err
    code, _, err = fkev_plot(capsys, archives["tm2"], "--kind", "error-angle")
    assert code == 2 and "no 'full' case" in err
    code, _, err = fkev_plot(capsys, archives["bw"], archives["tm1"], "--kind", "stability")
    assert code == 2 and "only freq-angle overlays several" in err


def test_title_names_scene_mesh_and_completeness(archives, tmp_path):
    """The title is the scene's; a re-meshed run (--elements) and an unfinished archive say so."""
    fig = plots.stability(load(archives["tm1"]))
    head = fig._suptitle.get_text().splitlines()[0]
    assert head == "Turcic-Midha crank-rocker (Table 3.2), 9 elements [re-meshed: 3 el (1+1+1)]"
    part = tmp_path / "bw.h5.part"
    part.write_bytes(archives["bw"].read_bytes())
    with h5py.File(part, "r+") as f:
        f.attrs["complete"] = 0
    with pytest.warns(DamagedArchiveWarning, match="checksum mismatch"):  # the edit above is damage
        unfinished = load(part)
    assert plots.error_angle(unfinished)._suptitle.get_text().splitlines()[0].endswith("[incomplete archive]")
    assert "[" not in plots.error_angle(load(archives["bw"]))._suptitle.get_text().splitlines()[0]


# --------------------------------------------------- issue 20 item 5: maps draw what was computed
@pytest.fixture(scope="module")
def two_speeds(tmp_path_factory):
    out = tmp_path_factory.mktemp("two_speeds") / "sc.h5"
    fkev("run", ROOT / "runs/turcic-midha-1984.toml", "-o", out, "--elements", 1, "--angles", "0:90:30",
         "--speeds", "0,150", "--cases", "full", "--modes", 2, "--solver", "dense", "--quiet", check=False)
    return load(out)


def _overlaps(fig, artist, ax) -> bool:
    fig.canvas.draw()
    a, b = artist.get_window_extent(), ax.get_window_extent()
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_stability_map_covers_only_the_computed_speeds_and_its_legend_no_data(two_speeds):
    """A 2-speed archive (0, 150 rad/s) drew its y axis to 225 rad/s, never computed, and the
    legend over divergent cells: the cells now end at the first and last speed and angle, the
    legend sits below the axes."""
    fig = plots.stability(two_speeds, "full")
    ax = fig.axes[0]
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
    xy = mesh.get_coordinates()
    assert (xy[..., 1].min(), xy[..., 1].max()) == (0.0, 150.0)
    assert (xy[..., 0].min(), xy[..., 0].max()) == (0.0, 90.0)
    leg = ax.get_legend()
    if leg is not None:  # only when some point is divergent or did not converge
        assert not _overlaps(fig, leg, ax)


def test_campbell_from_two_speeds_warns_instead_of_marking_crossings(two_speeds):
    with pytest.warns(UserWarning, match="from 2 crank speed"):
        fig = plots.campbell(two_speeds, angle=30.0, orders=4)
    ax = fig.axes[0]
    assert not any(c.get_label().startswith("crossings") for c in ax.collections)
    assert "crossings not marked" in fig._suptitle.get_text()
    assert not _overlaps(fig, ax.get_legend(), ax)
