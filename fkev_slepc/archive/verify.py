"""Checksums of an archive's stored data, and their verification (``fkev verify``, ``fkev info``).

Each dataset carries an attribute ``sha256``: the SHA-256 of its values (raw bytes in C order,
variable-length strings joined by NUL) followed by its own attributes; the root group carries
``attrs_sha256`` over the root attributes. They are written by :func:`stamp` when a run
finishes (serial, rank 0), after the last value has been written, and re-stamped by every
resumed run that finishes.

Why not HDF5's Fletcher32 filter: a filter needs chunked storage, and parallel HDF5 1.10
refuses filtered datasets to the independent hyperslab writes every rank makes (docs/archive.md).
A digest per dataset also covers what Fletcher32 cannot: string datasets and attributes.

An archive still being written (``complete = 0``, ``<name>.h5.part``) has no checksums yet;
:func:`verify` then only checks that every dataset reads back.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

DIGEST_ATTR, ROOT_DIGEST_ATTR = "sha256", "attrs_sha256"
# HDF5's dimension-scale bookkeeping (object references, not stable bytes) and our own digests
_SKIP_ATTRS = {"DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "_Netcdf4Dimid", DIGEST_ATTR, ROOT_DIGEST_ATTR}


def _value_bytes(value) -> bytes:
    if isinstance(value, bytes):
        return value
    if isinstance(value, str):
        return value.encode("utf-8")
    a = np.asarray(value)
    if a.dtype.kind == "O":  # variable-length strings
        return b"\0".join(_value_bytes(v) for v in a.ravel())
    return a.dtype.str.encode() + np.ascontiguousarray(a).tobytes()


def _attrs_digest(h, attrs) -> None:
    for key in sorted(k for k in attrs.keys() if k not in _SKIP_ATTRS):
        h.update(key.encode("utf-8") + b"=" + _value_bytes(attrs[key]) + b";")


def _stored_bytes(ds, fh):
    """The bytes of a dataset's storage as they lie in the file (chunk by chunk), or None when
    it has none there (compact or not allocated). Read with plain file I/O, not through HDF5:
    a damaged variable-length string (a heap address) crashes HDF5 when decoded, so nothing is
    decoded before its stored bytes have been checked."""
    dsid = ds.id
    if ds.chunks is not None:
        spans = [dsid.get_chunk_info(i) for i in range(dsid.get_num_chunks())]
        spans = [(c.byte_offset, c.size) for c in spans]
    else:
        offset = dsid.get_offset()
        spans = [] if offset is None else [(offset, dsid.get_storage_size())]
    if not spans:
        return None
    out = bytearray()
    for offset, size in spans:
        fh.seek(offset)
        out += fh.read(size)
    return bytes(out)


def dataset_digest(ds, fh=None) -> str:
    """SHA-256 of a dataset's stored bytes (its values where it has none in the file) and attributes.

    ``fh``: the archive opened for binary reading (its stored bytes are read directly)."""
    h = hashlib.sha256()
    raw = _stored_bytes(ds, fh) if fh is not None else None
    h.update(raw if raw is not None else _value_bytes(ds[()]))
    _attrs_digest(h, ds.attrs)
    return h.hexdigest()


def root_digest(f) -> str:
    h = hashlib.sha256()
    _attrs_digest(h, f.attrs)
    return h.hexdigest()


def _datasets(f) -> list:
    import h5py

    found = []
    f.visititems(lambda name, obj: found.append(obj) if isinstance(obj, h5py.Dataset) else None)
    return found


def stamp(f) -> None:
    """Write the checksum of every dataset and of the root attributes (file open ``r+``)."""
    f.flush()  # every chunk on disk where the file says it is
    with open(f.filename, "rb") as fh:
        digests = {ds.name: dataset_digest(ds, fh) for ds in _datasets(f)}
    for name, digest in digests.items():
        f[name].attrs[DIGEST_ATTR] = digest
    f.attrs[ROOT_DIGEST_ATTR] = root_digest(f)


@dataclass
class Verification:
    """Outcome of :func:`verify`: ``problems`` is empty for an intact archive."""

    path: Path
    complete: bool = False
    n_datasets: int = 0
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems

    def summary(self) -> str:
        if not self.ok:
            what = "DAMAGED: " if self.path.is_file() else ""
            more = f"; and {len(self.problems) - 3} more" if len(self.problems) > 3 else ""
            return f"{self.path}: {what}" + "; ".join(self.problems[:3]) + more
        if not self.complete:
            return f"{self.path}: readable, run not finished ({self.n_datasets} datasets read; no checksums yet)"
        return f"{self.path}: ok ({self.n_datasets} datasets and the root attributes match their SHA-256)"


def verify(path: str | Path) -> Verification:
    """Read every dataset of an archive and compare it with its stored checksum.

    Detects bytes changed in stored values or attributes, datasets that no longer read back,
    and files HDF5 cannot open (truncated, overwritten headers). Never writes.
    """
    import h5py

    out = Verification(Path(path))
    if not out.path.is_file():
        out.problems.append("no such archive")
        return out
    try:
        f = h5py.File(out.path, "r")
    except OSError as exc:
        out.problems.append(f"HDF5 cannot open it ({exc})")
        return out
    with f, open(out.path, "rb") as fh:
        try:
            out.complete = bool(int(f.attrs.get("complete", 0)))
            stamped = ROOT_DIGEST_ATTR in f.attrs
            if out.complete and not stamped:
                out.problems.append("complete but without checksums (written before fkev verify existed, "
                                    "or the checksums were removed)")
            if stamped and f.attrs[ROOT_DIGEST_ATTR] != root_digest(f):
                out.problems.append("root attributes changed since the run finished (checksum mismatch)")
            for ds in _datasets(f):
                out.n_datasets += 1
                want = ds.attrs.get(DIGEST_ATTR) if stamped else None
                try:
                    have = dataset_digest(ds, fh)
                    if not stamped:
                        ds[()]  # an unfinished run: at least every value must read back
                except (OSError, ValueError, TypeError) as exc:
                    out.problems.append(f"dataset {ds.name} cannot be read ({exc})")
                    continue
                if stamped and want is None:
                    out.problems.append(f"dataset {ds.name} has no checksum")
                elif stamped and have != (want.decode() if isinstance(want, bytes) else str(want)):
                    out.problems.append(f"dataset {ds.name} changed since the run finished (checksum mismatch)")
        except (OSError, RuntimeError, KeyError, ValueError) as exc:  # damaged object headers
            out.problems.append(f"HDF5 cannot read its structure ({exc})")
    return out
