"""Readers survive damaged archives and never use damaged data silently (issue 17, item 6).

- one flipped byte in the object header of ``/errors/status`` crashed ``fkev verify`` and
  ``fkev info`` (SIGSEGV inside HDF5): the archive is now decoded in a child process first;
- ``fkev export`` exported archives ``fkev verify`` flags, ``fk.open`` read them without a word;
- damage to a dimension scale's ``NAME`` passed verify (the checksums leave HDF5's bookkeeping
  out) but broke xarray;
- a ``.part`` a live run writes was reported "DAMAGED: ... unable to lock file".
"""

from __future__ import annotations

import shutil
import warnings

import h5py
import numpy as np
import pytest

from clitools import BW, fkev
from fkev_slepc.archive import products as P
from fkev_slepc.archive import store
from fkev_slepc.archive.lock import ArchiveLock
from fkev_slepc.archive.reader import ArchiveError, DamagedArchiveWarning, load
from fkev_slepc.archive.verify import verify
from fkev_slepc.status import Status

# bytes of the /errors/status object header: 60-70 hold the messages whose damage crashed HDF5
# (SIGSEGV at 61, 62, 69, 70, SIGABRT at 60 on this layout), 0 its version, 16 a message type
FLIPS = (0, 16, 60, 61, 62, 69, 70, 233, 313, 448, 536)


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    out = tmp_path_factory.mktemp("damage") / "bw.h5"
    r = fkev("run", BW, "--angles", "0,10,20", "--speeds", "0,900", "--cases", "structure,full", "--modes", "3",
             "--solver", "dense", "-q", "-o", out)
    assert r.returncode == 0, r.stderr
    return out


def _flipped(src, dst, offset):
    data = bytearray(src.read_bytes())
    data[offset] ^= 0xFF
    dst.write_bytes(bytes(data))
    return dst


def test_flipped_header_bytes_of_errors_status_are_reported_never_a_crash(archive, tmp_path):
    with h5py.File(archive, "r") as f:
        info = h5py.h5o.get_info(f[P.ERRORS.status.path].id)
    crashed = 0
    for k in (k for k in FLIPS if k < info.hdr.space.total):
        bad = _flipped(archive, tmp_path / f"flip{k}.h5", info.addr + k)
        check = verify(bad)  # would have died with SIGSEGV in this process
        crashed += check.crashed
        if check.ok:  # then nothing HDF5 decodes may differ: the byte was one it does not use
            with h5py.File(bad, "r") as f, h5py.File(archive, "r") as g:
                assert np.array_equal(f[P.ERRORS.status.path][()], g[P.ERRORS.status.path][()]), k
        else:
            assert check.summary().startswith(f"{bad}: DAMAGED: "), check.summary()
    assert crashed >= 1, "some flip must reach the bytes that crashed HDF5"
    bad = _flipped(archive, tmp_path / "segv.h5", info.addr + 61)
    for cmd in ("verify", "info", "export"):
        r = fkev(cmd, bad)
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and "DAMAGED" in r.stderr, (cmd, r.returncode, r.stderr)
        assert "Traceback" not in r.stderr
    with pytest.raises(ArchiveError, match="DAMAGED"):
        load(bad)


def test_readers_do_not_use_a_flagged_archive_silently(archive, tmp_path):
    bad = tmp_path / "status.h5"
    shutil.copyfile(archive, bad)
    with h5py.File(bad, "r") as f:  # where the stored statuses lie
        offset = f[P.STATUS_VAR.path].id.get_offset()
        first = int(f[P.STATUS_VAR.path][0, 1, 1])
    assert first == Status.OK.code or first == Status.UNSTABLE.code
    with open(bad, "r+b") as fh:  # a status flipped to divergent
        fh.seek(offset + 3)
        fh.write(bytes([Status.DIVERGENT.code]))
    assert not verify(bad).ok
    r = fkev("export", bad)
    assert r.returncode == 2 and "DAMAGED" in r.stderr and "--no-verify" in r.stderr and not r.stdout
    r = fkev("export", bad, "--no-verify")
    assert r.returncode == 0 and "divergent" in r.stdout
    import fkev_slepc as fk

    with pytest.warns(DamagedArchiveWarning, match="changed since the run finished"):
        res = fk.open(bad)
    assert res.status[0, 1, 1] == Status.DIVERGENT.code  # read, but not silently
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fk.open(bad, verify=False)
        fk.open(archive)  # an intact archive: no warning


def test_verify_covers_dimension_scale_names(archive, tmp_path):
    """The checksums leave HDF5's dimension-scale bookkeeping out; the table check covers it."""
    bad = tmp_path / "name.h5"
    shutil.copyfile(archive, bad)
    with h5py.File(bad, "r+") as f:  # what one flipped byte of the NAME attribute does
        f[P.SPEED].attrs.modify("NAME", np.bytes_(b"speed_rad_x"))
    check = verify(bad)
    assert not check.ok and any("NAME" in p and "/speed_rad_s" in p for p in check.problems), check.problems
    r = fkev("info", bad)
    assert r.returncode == 2 and "NAME" in r.stderr


def test_an_archive_being_written_is_reported_as_such_with_its_points(archive, tmp_path):
    out = tmp_path / "live.h5"
    shutil.copyfile(archive, out)
    part = store.reopen_finished(out)  # a resumed run's .part (no checksums yet)
    with ArchiveLock(out), h5py.File(part, "r+") as f:  # a live run: its lock and HDF5's file lock held
        f[P.STATUS_VAR.path][2] = Status.PENDING.code
        f.flush()
        for cmd in ("info", "verify"):
            r = fkev(cmd, part)
            assert r.returncode == 0, (cmd, r.stderr)
            assert "being written by fkev pid" in r.stdout and "lock" in r.stdout and "DAMAGED" not in r.stdout
            assert "8 of 12 points done" in r.stdout, r.stdout
        with pytest.raises(ArchiveError, match="being written"):
            load(part)
    r = fkev("info", part)  # the run is gone: an unfinished archive, summarised as usual
    assert r.returncode == 0 and "INCOMPLETE" in r.stdout
