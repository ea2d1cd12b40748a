"""Regression tests of the reliability defects of issue 27 (stress campaign, round three): each
reproducer either gets an honest answer or is refused/flagged, never a wrong answer marked ok, a
traceback, nor damage passed on as verified.

"B-W 1-1-1" is runs/bahgat-willmert-1976.toml with ``--elements 1``.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from clitools import BW, fkev

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
