"""Regression tests of the reliability defects of issue 27 (stress campaign, round three): each
reproducer either gets an honest answer or is refused/flagged, never a wrong answer marked ok, a
traceback, nor damage passed on as verified.

"B-W 1-1-1" is runs/bahgat-willmert-1976.toml with ``--elements 1``.
"""

from __future__ import annotations

import json
import sys

import h5py
import numpy as np
import pytest
from clitools import BW, ROOT, fkev

sys.path.insert(0, str(ROOT / "scripts"))
from stress_products import ADVERSARIAL, arguments  # noqa: E402 (the campaign's table of adversarial inputs)

B_W_111 = (BW, "--elements", "1")


def test_a_reduced_monodromy_whose_truncation_did_not_converge_is_not_ok(tmp_path):
    """B-W 1-1-1 at 350 rad/s on a basis of 1 mode per angle: the truncation changes max|μ| by 0.029
    (not converged; the full model gives 1.0294, unstable). Reported ok before (max|μ| - 1 = 1.75e-13,
    exit 0); now the speed is not_converged (exit 3), the archive says so and the report names it."""
    out = tmp_path / "f.h5"
    r = fkev("floquet", *B_W_111, "--speeds", "350", "--reduce", "1", "--angles", "0:360:90", "--no-critical",
             "--json", "-o", out)
    assert r.returncode == 3, r.stderr
    o = json.loads(r.stdout)
    assert o["status"] == ["not_converged"] and o["truncation_converged"] == [0]
    assert o["truncation_max_abs"][0] > 1e-3
    with h5py.File(out, "r") as f:
        assert f["floquet/truncation_converged"][0, 0] == 0
    from fkev_slepc.cli.floquet import lines

    assert any("1 not converged (no verdict)" in ln for ln in lines(o) if "cycle verdict" in ln), lines(o)


@pytest.mark.parametrize("key, bad", [("links[0].length_m", "0.3"),  # crank 0.3 m: no assembly over 160-199 deg
                                      ("links[0].youngs_modulus_pa", "1e155"),  # K overflows double precision
                                      ("links[1].length_m", "1e155")])  # no assembly at any angle
def test_design_refuses_a_design_value_that_is_not_a_valid_scene(tmp_path, key, bad):
    """``fkev design`` exited 0 with failed design points and printed cycle minima over the angles
    that happened to solve. Every design value is now checked as ``fkev check`` checks a scene
    (assembly at every crank angle, modes, operator overflow) before anything is solved: exit 2,
    the design point and key named, no archive."""
    out = tmp_path / "d.h5"
    r = fkev("design", BW, "--set", f"{key}=0.127,{bad}" if key == "links[0].length_m" else f"{key}=0.2794,{bad}"
             if key == "links[1].length_m" else f"{key}=2.07e11,{bad}", "--angles", "0:360:10", "--speeds", "100",
             "--cases", "full", "-o", out)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert f"design point 1 ({key} = {float(bad):g})" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and "min [Hz]" not in r.stdout
    assert not out.exists()


FLOQUET_SMALL = ("floquet", *B_W_111, "--speeds", "100", "--angles", "0:360:90", "--no-critical", "--reduce", "none")


@pytest.fixture(scope="module")
def floquet_archive(tmp_path_factory):
    """B-W 1-1-1 at 100 rad/s: a finished Floquet archive (seconds)."""
    out = tmp_path_factory.mktemp("floquet") / "f.h5"
    r = fkev(*FLOQUET_SMALL, "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="module")
def product_archives(tmp_path_factory):
    """B-W 1-1-1: a finished response-vs-speed archive and a one-point design archive (seconds)."""
    folder = tmp_path_factory.mktemp("products")
    response, design = folder / "r.h5", folder / "d.h5"
    r = fkev("response", *B_W_111, "--speeds", "50", "--angles", "0:360:90", "--harmonics", "4", "--no-shooting",
             "-q", "-o", response)
    assert r.returncode == 0, r.stderr
    r = fkev("design", BW, "--set", "links[0].length_m=0.127", "--angles", "0:360:90", "--speeds", "100",
             "--cases", "full", "-q", "-o", design)
    assert r.returncode == 0, r.stderr
    return response, design


def _changed_byte(src, dst, path):
    """A copy of ``src`` with one byte of the stored values of dataset ``path`` changed."""
    import shutil

    shutil.copyfile(src, dst)
    with h5py.File(dst, "r") as f:
        offset = f[path].id.get_offset()
    with open(dst, "r+b") as fh:
        fh.seek(offset + 3)
        b = fh.read(1)
        fh.seek(offset + 3)
        fh.write(bytes([b[0] ^ 0x10]))
    return dst


def test_resume_refuses_a_damaged_archive_never_restamps_it(floquet_archive, tmp_path):
    """One changed byte in /floquet/max_abs_multiplier (``fkev verify``: DAMAGED): ``fkev floquet
    --resume`` exited 0 and re-stamped the damaged value as verified. Now the resume refuses it
    before anything is decoded or solved (exit 2, naming the dataset and ``fkev verify``), and the
    file is left as it was (still DAMAGED, not re-stamped)."""
    from clitools import digest

    from fkev_slepc.archive.verify import verify

    bad = _changed_byte(floquet_archive, tmp_path / "bad.h5", "floquet/max_abs_multiplier")
    assert not verify(bad).ok
    before = digest(bad)
    r = fkev(*FLOQUET_SMALL, "--resume", "-o", bad)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "damaged" in r.stderr and "/floquet/max_abs_multiplier" in r.stderr and "Traceback" not in r.stderr
    assert digest(bad) == before and not verify(bad).ok
    assert not (tmp_path / "bad.h5.part").exists()


@pytest.mark.parametrize("path, word", [("case", b"full"), ("mesh/link_names", b"follower")])
def test_checksums_cover_the_content_of_variable_length_strings(floquet_archive, tmp_path, path, word):
    """A case renamed ``full`` -> ``fuXl`` or a link ``follower`` -> ``follXwer`` in its heap passed
    ``fkev verify`` (the digest hashed the stored heap references, not the strings). Each
    occurrence of the word in the file is changed in turn; every change that alters the decoded
    strings of the dataset is now DAMAGED."""
    from fkev_slepc.archive.store import text
    from fkev_slepc.archive.verify import verify

    data = floquet_archive.read_bytes()
    with h5py.File(floquet_archive, "r") as f:
        want = [text(v) for v in f[path][()]]
    seen, start = 0, 0
    while (at := data.find(word, start)) >= 0:
        start = at + 1
        bad = bytearray(data)
        bad[at + 2] = ord("X")
        dst = tmp_path / f"s{at}.h5"
        dst.write_bytes(bytes(bad))
        with h5py.File(dst, "r") as f:
            have = [text(v) for v in f[path][()]]
        if have != want:
            seen += 1
            check = verify(dst)
            assert not check.ok and any(f"/{path}" in p for p in check.problems), (at, check.problems)
    assert seen >= 1


def test_product_readers_warn_on_a_damaged_archive(floquet_archive, product_archives, tmp_path):
    """``read_floquet``, ``read_response`` and ``open_design`` returned changed values without a word
    on archives ``fkev verify`` flags; each now verifies first, as ``fk.open`` does, and warns with
    DamagedArchiveWarning (the intact archive reads without one)."""
    import warnings

    from fkev_slepc.api.response_archive import read_response
    from fkev_slepc.archive.reader import DamagedArchiveWarning
    from fkev_slepc.design.results import open_design
    from fkev_slepc.sweep.floquet_run import read_floquet

    response, design = product_archives
    for reader, good, path in ((read_floquet, floquet_archive, "floquet/max_abs_multiplier"),
                               (read_response, response, "response/max_abs_multiplier"),
                               (open_design, design, "design/frequency_hz")):
        with warnings.catch_warnings():
            warnings.simplefilter("error", DamagedArchiveWarning)
            reader(good)
        bad = _changed_byte(good, tmp_path / f"bad-{good.name}", path)
        with pytest.warns(DamagedArchiveWarning, match=f"/{path}"):
            reader(bad)


def test_info_and_export_report_damaged_link_name_text(floquet_archive, tmp_path):
    """A byte of a link name in /mesh/link_names made invalid UTF-8: ``fkev info`` and ``fkev export``
    died with UnicodeDecodeError (verify passed: the heap text was not checksummed). Now both say
    DAMAGED in one line, exit 2."""
    data = bytearray(floquet_archive.read_bytes())
    at = data.find(b"follower")
    data[at + 2] = 0xFF
    bad = tmp_path / "bad.h5"
    bad.write_bytes(bytes(data))
    for args in (("info", bad), ("export", bad, "-o", tmp_path / "x.csv")):
        r = fkev(*args)
        assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
        assert "DAMAGED" in r.stderr and "/mesh/link_names" in r.stderr, r.stderr


def test_resume_of_damaged_metadata_is_refused_never_a_crash(floquet_archive, tmp_path):
    """Flipped bytes in the object header of /floquet/status: ``--resume`` died with SIGSEGV or a
    traceback (KeyError, TypeError, RuntimeError) while decoding it. The resume now verifies in a
    child process first: a damaged file is refused in one line (exit 2); a byte HDF5 does not use
    leaves an intact archive that resumes with nothing to solve."""
    with h5py.File(floquet_archive, "r") as f:
        info = h5py.h5o.get_info(f["floquet/status"].id)
    refused = 0
    for k in (0, 16, 60, 61):
        data = bytearray(floquet_archive.read_bytes())
        data[info.addr + k] ^= 0xFF
        bad = tmp_path / f"h{k}.h5"
        bad.write_bytes(bytes(data))
        r = fkev(*FLOQUET_SMALL, "--resume", "-o", bad)
        assert r.returncode in (0, 2) and "Traceback" not in r.stderr, (k, r.returncode, r.stderr)
        refused += r.returncode == 2 and "damaged, not resumed" in r.stderr
    assert refused >= 2  # offsets 0 and 16 are decoded (version, a message type); 60 and 61 unused here


@pytest.mark.parametrize("case", list(ADVERSARIAL))
def test_accepted_input_is_refused_in_one_line_before_any_work(tmp_path, case):
    """Issue 27 items 6 and 10 (the table is ``scripts/stress_products.ADVERSARIAL``, also run by
    ``scripts/stress.py products``): each of these ended in a traceback (OverflowError, ValueError,
    a matplotlib format error, IsADirectoryError with a .tmp left, MemoryError) or ran for minutes
    without an estimate. Now: exit 2, a line naming the flag (or scene key) and its value, no
    traceback, nothing written."""
    args, named = arguments(case, tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    r = fkev(*args, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr, (r.returncode, r.stderr[-2000:])
    assert named in r.stderr, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no archive, figure or .tmp left


def test_a_negative_value_after_any_numeric_flag_is_a_value():
    """``--gravity -981,0`` was refused as an unknown option (as ``--speed -5e2`` was, issue 17): a
    leading minus now starts a value for every option that takes numbers, lists and ranges too.
    At rest (Ω = 0) the loads are linear in g: the driving torque under -g is minus that under g."""
    out = {}
    for g in ("-9.81,0", "9.81,0"):
        r = fkev("loads", *B_W_111, "--speed", "0", "--gravity", g, "--angles", "-90:90:90", "--json")
        assert r.returncode == 0, r.stderr
        out[g] = json.loads(r.stdout)
    assert out["-9.81,0"]["gravity_m_s2"] == [-9.81, 0.0] and out["-9.81,0"]["crank_angle_deg"] == [-90.0, 0.0, 90.0]
    minus, plus = (np.array(out[g]["driving_torque_n_m"]) for g in ("-9.81,0", "9.81,0"))
    np.testing.assert_allclose(minus, -plus, rtol=1e-12, atol=1e-12 * np.max(np.abs(plus)))  # linear in g at rest


def test_info_on_an_unfinished_floquet_archive_says_what_is_pending_and_how_to_resume(floquet_archive, tmp_path):
    """``fkev info`` on an unfinished Floquet archive printed a verdict ("0 of 1 grid speed
    unstable") over pending speeds and suggested ``fkev run ... --resume``. Now it says which
    product has how many units pending, gives no verdict for it, and prints the ``fkev floquet``
    command that continues it."""
    import shutil

    from fkev_slepc.archive import store

    out = tmp_path / "f.h5"
    shutil.copyfile(floquet_archive, out)
    part = store.reopen_finished(out)  # what a resumed floquet run works on, here stopped before its speed
    with h5py.File(part, "r+") as f:
        f["floquet/status"][0, 0] = 0
    r = fkev("info", part)
    assert r.returncode == 0, r.stderr
    assert "INCOMPLETE: floquet 1 of 1 units pending" in r.stdout, r.stdout
    assert "pending (1 of 1 speeds not solved yet" in r.stdout and "grid speed unstable" not in r.stdout
    resume = [ln for ln in r.stdout.splitlines() if ln.startswith("  resume")]
    assert len(resume) == 1 and resume[0].split()[1:3] == ["fkev", "floquet"] and resume[0].endswith("--resume")
    assert "fkev run" not in r.stdout


def test_integer_scene_keys_can_be_designed(tmp_path):
    """``--set links[1].elements=2,3`` was refused ("must be an integer (got 2.0)": values parsed as
    floats). Now it runs; nested conforming meshes at rest (Rayleigh–Ritz): every frequency of the
    3-element coupler is at most that of the 2-element one."""
    from fkev_slepc.design.results import open_design

    out = tmp_path / "d.h5"
    r = fkev("design", BW, "--set", "links[1].elements=2,3", "--angles", "0:360:90", "--speeds", "0", "--cases",
             "structure", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    f = open_design(out).frequency_min_hz.sel(speed_rad_s=0.0, case="structure").values  # (point, mode)
    assert np.all(np.isfinite(f)) and np.all(f[1] <= f[0] * (1 + 1e-12)) and np.any(f[1] < f[0])


@pytest.mark.parametrize("args, line", [
    (("design", BW, "--set", "links[0].length_m=0.127", "--set", "links[0].length_m=0.13"),
     "--set: links[0].length_m is given twice"),
    (("margins", "{archive}", "--speed", "nan"), "--speed: must be a finite crank speed"),
    (("margins", "{archive}", "--speed", "100", "--modes", ","), "--modes: give at least one mode number"),
])
def test_messages_name_the_flag_and_the_real_reason(floquet_archive, tmp_path, args, line):
    """Issue 27 item 11: a repeated ``--set`` key silently kept one value; ``margins --speed nan``
    quoted "got 0" and ``--modes ''`` printed an empty table with exit 0. Each is now refused in one
    line naming the flag, exit 2."""
    more = ("-o", tmp_path / "d.h5") if args[0] == "design" else ()
    r = fkev(*[str(a).replace("{archive}", str(floquet_archive)) for a in args], *more)
    assert r.returncode == 2 and line in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_absurd_angles_and_scales_are_refused_naming_the_flag(tmp_path):
    """Issue 27 item 11: ``--angles 1e155`` (a double no longer resolves the angle) and ``--scale``
    nan, inf, 0 or -1 were accepted; now exit 2, one line naming the flag, nothing written."""
    from clitools import BW, fkev

    r = fkev("run", BW, "--angles", "1e155", "--speeds", "0", "--cases", "structure", "-o", tmp_path / "a.h5")
    assert r.returncode == 2 and "--angles" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "a.h5").exists()
    for bad in ("nan", "inf", "0", "-1"):
        r = fkev("response", BW, "--elements", "1", "--speed", "100", "--scale", bad, "--plot", tmp_path / "d.png")
        assert r.returncode == 2 and "--scale" in r.stderr and "Traceback" not in r.stderr, (bad, r.stderr)
        assert not (tmp_path / "d.png").exists()


@pytest.mark.parametrize("key, value, instead", [("driver.speeds_rad_s", "1", "--speeds"),
                                                 ("analysis.crank_angles_deg[0]", "3", "--angles"),
                                                 ("analysis.modes", "2,3", "--modes"),
                                                 ("solver.petsc.pep_max_it", "1,2", "--solver")])
def test_design_refuses_a_key_the_study_holds_fixed(tmp_path, key, value, instead):
    """Issue 27 item 11: ``fkev design --set driver.speeds_rad_s=1`` ran with no effect (every design
    point is solved on the study's grid, with one eigen-solver). Such a key is now refused before
    any work: exit 2, one line naming --set, the key, why and the flag that sets it; nothing written."""
    out = tmp_path / "d.h5"
    r = fkev("design", BW, "--set", "links[0].length_m=0.127", "--set", f"{key}={value}", "-o", out)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    line = [ln for ln in r.stderr.splitlines() if f"--set[{key}]" in ln]
    assert len(line) == 1 and "cannot vary over a design study" in line[0] and instead in line[0], r.stderr
    assert "links[0].length_m" not in r.stderr and not out.exists() and r.stdout == ""


def test_study_design_names_its_own_argument_for_a_fixed_key(tmp_path):
    """The API refuses the same keys in its own words (``speeds=``), before anything is written."""
    import fkev_slepc as fk
    from fkev_slepc.scene import SceneError

    with pytest.raises(SceneError, match=r"params\[driver.speeds_rad_s\]: cannot vary .*; use speeds="):
        fk.load(BW).design({"driver.speeds_rad_s": [1.0, 2.0]}, output=tmp_path / "d.h5")
    assert not (tmp_path / "d.h5").exists()


def test_a_designed_crank_acceleration_takes_effect(tmp_path):
    """The keys a design study does not hold fixed change its points: at rest the driving torque is
    linear in the crank acceleration (τ = J(θ)·α), so designing ``driver.acceleration_rad_s2`` =
    -100, 0, +100 gives torque ranges that are each other's negatives (τ_min(-α) = -τ_max(α)), and
    α = 0 gives none."""
    r = fkev("design", BW, "--set", "driver.acceleration_rad_s2=-100,0,100", "--angles", "0:360:90", "--speeds", "0",
             "--cases", "structure", "--json", "-q", "-o", tmp_path / "d.h5")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["rows"]
    assert [row["driver.acceleration_rad_s2"] for row in rows] == [-100.0, 0.0, 100.0]
    lo, zero, hi = ((row["torque_min_n_m"], row["torque_max_n_m"]) for row in rows)
    scale = max(abs(v) for v in hi)
    assert scale > 1e-3 and max(abs(v) for v in zero) < 1e-12 * scale
    np.testing.assert_allclose(lo, [-hi[1], -hi[0]], rtol=1e-12, atol=1e-12 * scale)


def test_sensitivity_to_a_typo_is_an_unknown_key_with_close_matches():
    """``fkev point --sensitivity links[1].lenght_m`` said "is not set in the scene: set it first
    (Study.replace)" after the solve: API wording, and the wrong advice for a typo. Now it is
    refused before any work (nothing on stdout) as an unknown key with the closest numeric keys of
    the scene; the API keeps its own wording."""
    import fkev_slepc as fk
    from fkev_slepc.scene import SceneError

    r = fkev("point", *B_W_111, "--sensitivity", "links[1].lenght_m", "--speed", "100")
    assert r.returncode == 2 and r.stdout == "" and "Traceback" not in r.stderr, (r.stdout, r.stderr)
    line = [ln for ln in r.stderr.splitlines() if "--sensitivity" in ln]
    assert len(line) == 1 and "links[1].lenght_m: unknown key" in line[0], r.stderr
    assert "did you mean 'links[1].length_m'" in line[0] and "Study.replace" not in r.stderr, r.stderr
    point = fk.load(BW, elements=1).point(0.0, 100.0, "full")
    with pytest.raises(SceneError, match=r"set it first \(Study.replace\)"):
        point.sensitivity("links[1].lenght_m")


def test_a_design_point_that_fails_in_its_solve_gives_exit_3_and_no_minima(tmp_path):
    """Issue 27 item 4, second part: a design point that passes every up-front scene check and then
    fails in its solve. SLEPc limited to one outer iteration through the options database
    (``-fkev_pep_max_it 1``) converges on the 1-element coupler (9 free DOFs) and not on the
    30-element one: exit 3, the failed point flagged in the table and in /design/status, its
    minima absent (the converged point's are printed, and equal dense QZ's to 1e-9)."""
    from fkev_slepc.design.results import open_design

    out = tmp_path / "d.h5"
    r = fkev("design", BW, "--set", "links[1].elements=1,30", "--angles", "0", "--speeds", "100", "--cases", "full",
             "--solver", "slepc", "-q", "-o", out, "-fkev_pep_max_it", "1")
    assert r.returncode == 3 and "Traceback" not in r.stderr, (r.returncode, r.stderr)
    summary = r.stdout.split("design check at")[0].splitlines()  # the minima table, not the design check's
    rows = {ln.split()[0]: ln for ln in summary if ln.split() and ln.split()[0] in ("1", "30")}
    assert "no minima" in rows["30"] and "no minima" not in rows["1"], r.stdout
    ds = open_design(out)
    assert ds.status.values.ravel().tolist() == ["ok", "not_converged"]
    assert np.isnan(ds.frequency_min_hz.values[1]).all()
    dense = fkev("point", BW, "--elements", "1,1,2", "--angle", "0", "--speed", "100", "--case", "full", "--solver",
                 "dense", "--json")
    assert dense.returncode == 0, dense.stderr
    np.testing.assert_allclose(ds.frequency_min_hz.values[0].ravel(), json.loads(dense.stdout)["frequency_hz"], rtol=1e-9)


def test_info_on_a_one_angle_one_speed_archive_is_no_traceback(tmp_path):
    """``fkev info`` died with KeyError 'ambiguous_links' on every archive of one crank angle and one
    speed (nothing to track: only the tracking thresholds are written). It now says so."""
    out = tmp_path / "r.h5"
    r = fkev("run", *B_W_111, "--angles", "0", "--speeds", "100", "--cases", "full", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    r = fkev("info", out)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert "  tracking    none (one angle and one speed)" in r.stdout.splitlines(), r.stdout


def test_xarray_reads_of_every_product_are_verified(floquet_archive, product_archives, tmp_path):
    """A user's own ``xr.open_dataset(path, group=...)`` returns a changed value without a word (it
    cannot verify). ``fkev_slepc.open_dataset`` verifies first, as ``fk.open`` does: one changed byte
    in a dataset of the root sweep, /mesh, /floquet, /response or /design warns naming it; the
    intact archive reads without a warning and gives what xarray reads; a missing group is refused."""
    import warnings

    import xarray as xr

    import fkev_slepc as fk
    from fkev_slepc.archive.verified import ArchiveError, DamagedArchiveWarning

    response, design = product_archives
    for good, group, path in ((floquet_archive, None, "frequency_hz"), (floquet_archive, "mesh", "mesh/node_s"),
                              (floquet_archive, "floquet", "floquet/max_abs_multiplier"),
                              (response, "response", "response/max_abs_multiplier"),
                              (design, "design", "design/frequency_hz")):
        var = path.rpartition("/")[2]
        with warnings.catch_warnings():
            warnings.simplefilter("error", DamagedArchiveWarning)
            ours = fk.open_dataset(good, group=group)
        with xr.open_dataset(good, group=group, engine="h5netcdf") as raw:
            np.testing.assert_array_equal(ours[var].values, raw[var].values)
        bad = _changed_byte(good, tmp_path / f"bad-{group}-{good.name}", path)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # the raw read: no warning, a changed value
            with xr.open_dataset(bad, group=group, engine="h5netcdf") as raw:
                changed = raw[var].values
        assert changed.tobytes() != ours[var].values.tobytes(), path
        with pytest.warns(DamagedArchiveWarning, match=f"/{path}"):
            fk.open_dataset(bad, group=group)
    with pytest.raises(ArchiveError, match="no group 'respons'"):
        fk.open_dataset(response, group="respons")


def test_verify_calls_a_single_point_file_not_verifiable_never_damaged(tmp_path):
    """An intact ``fkev loads -o`` file (format ``fkev-loads``, no checksums) was called DAMAGED
    by ``fkev verify`` and warned about by ``fk.open``: it is a file of another format, intact."""
    import warnings

    import fkev_slepc as fk
    from fkev_slepc.archive.reader import ArchiveError, DamagedArchiveWarning

    out = tmp_path / "loads.h5"
    r = fkev("loads", *B_W_111, "--speed", "100", "--angles", "0:360:90", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    v = fkev("verify", out)
    assert v.returncode == 2 and "DAMAGED" not in v.stdout + v.stderr
    assert "not verifiable: a single-point file of format 'fkev-loads'" in v.stdout + v.stderr
    with warnings.catch_warnings():
        warnings.simplefilter("error", DamagedArchiveWarning)
        with pytest.raises(ArchiveError, match="not an fkev archive"):
            fk.open(out)
