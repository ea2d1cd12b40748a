"""Archive for other tools (issue 12, Deliver 5): every group opens with xarray, status carries
CF flags and decodes to names, units and long names everywhere; ``fkev info`` prints the
solver settings as a table and lists Campbell crossings; ``fkev export`` writes a long table."""

import csv
import io
import math

import h5py
import numpy as np
import pytest
import xarray as xr

from clitools import BW, digest, fkev

SPEEDS = (0.0, 300.0, 600.0, 900.0, 1200.0)


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    out = tmp_path_factory.mktemp("arch") / "bw.h5"
    r = fkev("run", BW, "--angles", "0,10,20", "--speeds", ",".join(map(str, SPEEDS)), "--cases", "structure,full",
             "--mode-shapes", "--solver", "dense", "-q", "-o", out, "-fkev_max_pair_error", "1e-3")
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.parametrize("group", [None, "errors", "mesh", "tracking", "modes"])
def test_every_group_opens_with_xarray_with_units_and_long_names(archive, group):
    with xr.open_dataset(archive, group=group, engine="h5netcdf") as ds:
        assert ds.variables
        for name, var in ds.variables.items():
            assert var.attrs.get("units") and var.attrs.get("long_name"), (group, name)
        if group == "tracking":
            assert ds.signature.dims == ("crank_angle_deg", "speed_rad_s", "case", "dofs", "mode")
        if group == "modes":
            assert ds.shape.sizes["free_dof"] == 15 and ds.node_xy.dims == ("crank_angle_deg", "node", "xy")
        if group == "mesh":
            assert list(ds.component.values) == ["U", "V", "Phi"]


def test_status_has_cf_flags_and_decodes_to_names(archive):
    from fkev_slepc.archive.reader import load
    from fkev_slepc.status import Status

    with h5py.File(archive) as f:
        for ds in (f["status"], f["errors/status"]):
            assert list(ds.attrs["flag_values"]) == [s.code for s in Status]
            assert ds.attrs["flag_meanings"].split() == [s.value for s in Status]
    res = load(archive)
    names = res.status_names
    assert names.shape == res.status.shape
    assert set(names[:, :, 0].ravel()) == {"ok"}  # structure: no motion terms
    assert np.all(names[:, 0, :] == "ok")  # speed 0: every case is the structure
    assert np.array_equal(names == "unstable", res.status == Status.UNSTABLE.code)


def test_info_settings_table_and_rpm(archive, tmp_path):
    r = fkev("info", archive)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    i = next(n for n, ln in enumerate(lines) if ln.startswith("  solver"))
    assert lines[i] == "  solver      engine dense"
    assert lines[i + 1].split() == ["max_pair_error", "0.001"]
    assert not any("{" in ln for ln in lines)  # no JSON blob
    out = tmp_path / "rpm.h5"
    scene = tmp_path / "rpm.toml"
    scene.write_text(BW.read_text().replace("speeds_rad_s = [0.0, 500.0, 1000.0]", "speeds_rpm = [0, 6000]"))
    assert fkev("run", scene, "--angles", "10", "--cases", "structure", "-q", "-o", out).returncode == 0
    r = fkev("info", out)
    assert "  speed       0, 628.319 rad/s (0, 6000 rpm)" in r.stdout.splitlines()


def test_info_crossings_of_the_structure_case_are_exact(archive):
    """Structure frequencies do not depend on speed, so order k meets mode m at Ω = 2π f_m / k exactly."""
    from fkev_slepc.archive.reader import load

    r = fkev("info", archive, "--crossings", "--angle", "10", "--orders", "8")
    assert r.returncode == 0, r.stderr
    f = load(archive).frequency_hz[1, 0, 0]  # θ = 10°, Ω = 0, structure
    got = [ln.split() for ln in r.stdout.splitlines() if ln.startswith("    structure ") and " x order " in ln]
    want = [(m + 1, k, 2 * math.pi * f[m] / k) for m in range(4) for k in range(1, 9)
            if 2 * math.pi * f[m] / k <= SPEEDS[-1]]
    assert want, "the speed range must contain crossings"
    assert len(got) == len(want)
    for words, (mode, k, omega) in zip(got, want):
        assert words[2] == str(mode) and words[5] == f"{k}:"
        assert float(words[8]) == pytest.approx(omega, rel=1e-5)  # printed with 6 digits
    r = fkev("info", archive, "--crossings", "--angle", "15")
    assert r.returncode == 2 and "15 deg is not on the archive's crank-angle grid" in r.stderr


def test_export_csv_long_table(archive, tmp_path):
    from fkev_slepc.archive.reader import load

    res = load(archive)
    r = fkev("export", archive, "--format", "csv")
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(io.StringIO(r.stdout)))
    assert list(rows[0]) == ["crank_angle_deg", "speed_rad_s", "case", "mode", "frequency_hz", "damping_ratio",
                             "status"]
    assert len(rows) == res.frequency_hz.size == 3 * 5 * 2 * 4
    lam = res.eigenvalue.ravel()
    freq = np.array([float(x["frequency_hz"]) for x in rows])
    zeta = np.array([float(x["damping_ratio"]) for x in rows])
    np.testing.assert_array_equal(freq, res.frequency_hz.ravel())  # full precision round trip
    np.testing.assert_allclose(freq, lam.imag / (2 * np.pi), rtol=1e-14)
    np.testing.assert_allclose(zeta, -lam.real / np.abs(lam), rtol=1e-14, atol=0)
    # unstable points of the full case have a mode with a negative damping ratio (a growing mode)
    unstable = [x for x in rows if x["status"] == "unstable"]
    assert unstable and all(x["case"] == "full" for x in unstable)
    assert min(float(x["damping_ratio"]) for x in unstable) < 0
    first = rows[0]
    assert (first["crank_angle_deg"], first["speed_rad_s"], first["case"], first["mode"]) == ("0.0", "0.0",
                                                                                               "structure", "1")
    out = tmp_path / "t.csv"
    assert fkev("export", archive, "-o", out).returncode == 0 and out.read_text() == r.stdout


@pytest.mark.parametrize("cmd", ["export", "plot"])
@pytest.mark.parametrize("target,needle", [
    ("/proc/x", "directory /proc is not writable"),
    ("{tmp}/missing/x", "directory {tmp}/missing does not exist (create it first)"),
    ("{tmp}", "{tmp}: is a directory"),
])
def test_output_path_problems_are_one_line_and_touch_nothing(archive, tmp_path, cmd, target, needle):
    before = digest(archive)
    ext = ".csv" if cmd == "export" else ".png"
    target = target.format(tmp=tmp_path) + (ext if not target.startswith("{tmp}") or "missing" in target else "")
    extra = ["--kind", "stability"] if cmd == "plot" else []
    r = fkev(cmd, archive, *extra, "-o", target)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and needle.format(tmp=tmp_path) in r.stderr and r.stderr.startswith(f"fkev {cmd}: -o ")
    assert digest(archive) == before and not (tmp_path / "missing").exists()


def test_figures_show_rpm_when_the_scene_used_rpm(tmp_path):
    from fkev_slepc.plots import draw, maps
    from fkev_slepc.archive.reader import load

    scene = tmp_path / "rpm.toml"
    scene.write_text(BW.read_text().replace("speeds_rad_s = [0.0, 500.0, 1000.0]", "speeds_rpm = [0, 3000, 6000]"))
    out = tmp_path / "rpm.h5"
    r = fkev("run", scene, "--angles", "0,10", "--cases", "full", "--solver", "dense", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    res = load(out)
    assert res.speeds_in_rpm
    legend = [t.get_text() for t in draw.freq_angle(res).axes[0].get_legend().get_texts()]
    assert "Ω = 628.319 rad/s (6000 rpm)" in legend
    fig = maps.campbell(res)
    top = [a for a in fig.axes[0].child_axes if a.get_xlabel() == "crank speed (rpm)"]
    assert len(top) == 1
    fig.savefig(io.BytesIO(), format="png")  # lays out the secondary axis
    assert top[0].get_xlim() == pytest.approx(tuple(x / (2 * math.pi / 60) for x in fig.axes[0].get_xlim()))
