"""Checksums of an archive's stored data, and their verification (``fkev verify``, ``fkev info``).

Each dataset carries an attribute ``sha256``: the SHA-256 of its values (raw bytes in C order,
variable-length strings joined by NUL) followed by its own attributes; the root group carries
``attrs_sha256`` over the root attributes. They are written by :func:`stamp` when a run finishes (serial,
rank 0), after the last value has been written, and re-stamped by every resumed run that finishes.

Why not HDF5's Fletcher32 filter: a filter needs chunked storage, and parallel HDF5 1.10 refuses filtered
datasets to the independent hyperslab writes every rank makes (docs/archive.md). A digest per dataset also
covers what Fletcher32 cannot: string datasets and attributes.

An archive still being written (``complete = 0``, ``<name>.h5.part``) has no checksums yet; :func:`verify`
then only checks that every dataset reads back. A ``.part`` that a live run holds (its lock,
``archive/lock.py``, names the pid) is reported as being written, with the points done so far, not as damaged.

**Damaged metadata.** HDF5 decodes object headers, heaps and dimension-scale references with
few checks: one flipped byte in a header can crash the process (SIGSEGV) before any checksum
is compared. So :func:`verify` does the reading in a child process (this file run as a script:
h5py and numpy only, no package import) and reports a crash of the child as damaged metadata.
Beyond the checksums it checks the structure against the product tables
(:mod:`fkev_slepc.archive.products`): every dimension scale's ``NAME`` and ``CLASS`` (which the
checksums leave out, being HDF5 bookkeeping, and whose damage breaks xarray), and the scale
attached to each axis of each dataset.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import signal
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

DIGEST_ATTR, ROOT_DIGEST_ATTR = "sha256", "attrs_sha256"
STRINGS_ATTR = "sha256_strings"  # variable-length string datasets: SHA-256 of the decoded strings
# HDF5's dimension-scale bookkeeping (object references, not stable bytes) and our own digests
_SKIP_ATTRS = {"DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "_Netcdf4Dimid", DIGEST_ATTR, ROOT_DIGEST_ATTR}


def _value_bytes(value) -> bytes:
    if isinstance(value, (bytes, str)):
        return value if isinstance(value, bytes) else value.encode("utf-8")
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


def strings_digest(ds) -> str | None:
    """SHA-256 of the decoded values of a variable-length string dataset (None for other dtypes).
    Its stored bytes are heap references: a changed character in the heap leaves them alone."""
    import h5py

    if ds.dtype.kind != "O" or h5py.check_string_dtype(ds.dtype) is None:
        return None
    return hashlib.sha256(_value_bytes(ds[()])).hexdigest()


def root_digest(f) -> str:
    h = hashlib.sha256()
    _attrs_digest(h, f.attrs)
    return h.hexdigest()


def group_digest(g) -> str:
    """SHA-256 of a group's attributes and of the names of its members (a damaged link name
    renames a member)."""
    h = hashlib.sha256()
    _attrs_digest(h, g.attrs)
    h.update(b"\0".join(k.encode("utf-8", "replace") if isinstance(k, str) else bytes(k) for k in sorted(g.keys())))
    return h.hexdigest()


def _datasets(f) -> list:
    import h5py

    found = []
    f.visititems(lambda name, obj: found.append(obj) if isinstance(obj, h5py.Dataset) else None)
    return found


def _groups(f) -> list:
    import h5py

    found = []
    f.visititems(lambda name, obj: found.append(obj) if isinstance(obj, h5py.Group) else None)
    return found


def stamp(f) -> None:
    """Write the checksum of every dataset and of the root attributes (file open ``r+``): first the
    decoded-string digest of each string dataset (:data:`STRINGS_ATTR`, then covered by its ``sha256``)."""
    for ds in _datasets(f):
        text_digest = strings_digest(ds)
        if text_digest is not None:
            ds.attrs[STRINGS_ATTR] = text_digest
    f.flush()  # every chunk on disk where the file says it is
    with open(f.filename, "rb") as fh:
        digests = {ds.name: dataset_digest(ds, fh) for ds in _datasets(f)}
    for name, digest in digests.items():
        f[name].attrs[DIGEST_ATTR] = digest
    for g in _groups(f):  # their attributes and member names (archives stamped before: none)
        g.attrs[DIGEST_ATTR] = group_digest(g)
    f.attrs[ROOT_DIGEST_ATTR] = root_digest(f)


@dataclass
class Verification:
    """Outcome of :func:`verify`: ``problems`` is empty for an intact archive (or one being written).

    ``writer``: the live run writing it (the lock's text: ``fkev pid N on HOST since T``), else None;
    ``counts``: points by status name, where the status could be read; ``crashed``: HDF5 crashed
    decoding the file (damaged metadata: nothing of it may be decoded in this process)."""

    path: Path
    complete: bool = False
    n_datasets: int = 0
    problems: list[str] = field(default_factory=list)
    writer: str | None = None
    counts: dict = field(default_factory=dict)
    crashed: bool = False
    notes: list[str] = field(default_factory=list)
    other_format: str | None = None  # the ``format`` of a file fkev wrote that is not a checksummed archive

    @property
    def ok(self) -> bool:
        return not self.problems and self.other_format is None

    def points(self) -> str:
        """``12 of 30 points done (ok 10, failed 2)`` from ``counts``."""
        if not self.counts:
            return "points unknown"
        total = sum(self.counts.values())
        done = total - self.counts.get("pending", 0)
        shown = ", ".join(f"{k} {v}" for k, v in self.counts.items() if v and k != "pending")
        return f"{done} of {total} points done" + (f" ({shown})" if shown else "")

    def summary(self) -> str:
        if self.writer is not None:
            return (f"{self.path}: being written by {self.writer}; {self.points()} so far "
                    "(checked when the run finishes)")
        if self.other_format is not None:  # fkev response/loads -o: a file without checksums
            return f"{self.path}: not verifiable: a single-point file of format {self.other_format!r}, without checksums"
        if not self.ok:
            what = "DAMAGED: " if self.path.is_file() else ""
            more = f"; and {len(self.problems) - 3} more" if len(self.problems) > 3 else ""
            return f"{self.path}: {what}" + "; ".join(self.problems[:3]) + more
        if not self.complete:
            return (f"{self.path}: readable, run not finished ({self.n_datasets} datasets read; no checksums yet; "
                    f"{self.points()})")
        return f"{self.path}: ok ({self.n_datasets} datasets and the root attributes match their SHA-256)"


def verify(path: str | Path, isolate: bool = True, held: bool = False) -> Verification:
    """Read every dataset of an archive and compare it with its stored checksum and its table row.

    Detects bytes changed in stored values or attributes, damaged object headers and
    dimension-scale names, datasets that no longer read back, and files HDF5 cannot open
    (truncated, overwritten headers). Never writes. ``isolate`` (default): read in a child
    process, so that damaged metadata that crashes HDF5 is a problem reported, not a crash.
    ``held``: this process holds the archive's lock (a resume checking it before it writes), so
    the lock is not a live writer and every problem counts.
    """
    from fkev_slepc.archive.lock import writer_of

    out = Verification(Path(path))
    if not out.path.is_file():
        out.problems.append("no such archive")
        return out
    out.writer = None if held else writer_of(out.path)
    live = out.writer is not None
    if not isolate:
        return _fill(out, check(out.path, locking=not live), live)
    proc = subprocess.run([sys.executable, __file__, str(out.path), "1" if live else "0"], capture_output=True,
                          text=True, env=dict(os.environ, PYTHONFAULTHANDLER=""))
    if proc.returncode < 0:
        out.crashed = True
        name = signal.Signals(-proc.returncode).name
        out.problems.append(f"HDF5 crashed ({name}) decoding the file's metadata: an object header or heap is damaged")
        return _fill(out, {}, live)
    try:
        result = json.loads(proc.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        err = proc.stderr.strip().splitlines()
        out.crashed = True
        out.problems.append(f"reading it failed (exit {proc.returncode}: {err[-1] if err else 'no message'})")
        return _fill(out, {}, live)
    return _fill(out, result, live)


def _fill(out: Verification, result: dict, live: bool) -> Verification:
    out.complete = bool(result.get("complete", False))
    out.n_datasets = int(result.get("n_datasets", 0))
    out.counts = dict(result.get("counts", {}))
    out.notes, out.other_format = list(result.get("notes", [])), result.get("other_format")
    found = list(result.get("problems", []))
    out.crashed = out.crashed or bool(result.get("crashed", False))
    if live:  # a file being written is not damaged: what could not be read is a note
        out.notes, out.problems = out.notes + found + out.problems, []
        out.crashed = False
    else:
        out.problems += found
    return out


def _products():
    """:mod:`fkev_slepc.archive.products`, also when this file runs as the child (loaded by path,
    without importing the package)."""
    if __package__:
        from fkev_slepc.archive import products

        return products
    name = "fkev_archive_products"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name("products.py"))
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
    return sys.modules[name]


def _text(v) -> str:
    return v.decode("utf-8", "replace").rstrip("\0") if isinstance(v, bytes) else str(v)


def structure_problems(f) -> list[str]:
    """What the checksums cannot see, against the tables of :mod:`fkev_slepc.archive.products`:
    datasets missing or not in the format (a damaged link name), dimension scales whose
    ``CLASS``/``NAME`` changed, dtypes and shapes that disagree with the table and the scales,
    and axes attached to another scale than the table says."""
    import h5py

    P = _products()
    bad = []
    known = {v.path for v in P.datasets()}
    names = []
    f.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
    names = [n.decode("utf-8", "replace") if isinstance(n, bytes) else n for n in names]
    bad += [f"dataset /{n} is not one of the format's (a damaged or renamed link?)" for n in names if n not in known]
    for product in P.PRODUCTS:
        if product.status in f or product is P.PRODUCTS[0]:
            bad += [f"dataset /{v.path} is missing" for v in product.variables if v.required and v.path not in f]
    for v in P.datasets():
        if v.path not in f:
            continue
        ds = f[v.path]
        if v.scale:
            cls, name = ds.attrs.get("CLASS"), ds.attrs.get("NAME")
            if cls is None or _text(cls) != "DIMENSION_SCALE" or name is None or _text(name) != v.name:
                bad.append(f"dimension scale {ds.name} has NAME {_text(name) if name is not None else None!r} "
                           f"(expected {v.name!r}), CLASS {_text(cls) if cls is not None else None!r}")
        kind = _dtype_problem(ds.dtype, v.dtype, P)
        if kind:
            bad.append(f"dataset {ds.name} has dtype {ds.dtype} ({kind})")
        sizes = [len(f[d]) if d in f and d != v.path else None for d in v.dims]
        if ds.ndim != len(v.dims) or any(n is not None and n != m for n, m in zip(sizes, ds.shape)):
            bad.append(f"dataset {ds.name} has shape {ds.shape}, its scales say {tuple(sizes)}")
        if not v.scale:  # every axis whose scale is in the file is attached to it
            for i, d in enumerate(v.dims[: ds.ndim]):
                names = [sc.name for sc in ds.dims[i].values()] if "DIMENSION_LIST" in ds.attrs else []
                if names != ["/" + d] and (names or d in f):
                    bad.append(f"dataset {ds.name}: axis {i} is attached to {names or 'no scale'} (expected /{d})")
    return bad


def _dtype_problem(have: np.dtype, want: str, P) -> str | None:
    """Why a stored dtype does not match a table dtype (None: it does)."""
    import h5py

    if want == P.STATUS:
        ok = have == np.uint8 and h5py.check_enum_dtype(have) is not None
    elif want == P.STRING:
        ok = h5py.check_string_dtype(have) is not None and have.kind == "O"
    elif want == P.MESSAGE:
        ok = have == np.dtype(f"S{P.MESSAGE_BYTES}")
    else:
        ok = have == np.dtype(want)
    return None if ok else f"expected {want}"


def _counts(f) -> dict:
    """Points by status name (CF ``flag_meanings`` of every product's status dataset)."""
    P = _products()
    out: dict[str, int] = {}
    for product in P.PRODUCTS:
        if product.status not in f:
            continue
        ds = f[product.status]
        names = _text(ds.attrs.get("flag_meanings", b"")).split()
        codes = np.atleast_1d(ds.attrs.get("flag_values", np.arange(len(names))))
        n = np.bincount(np.asarray(ds[()], dtype=np.int64).ravel(), minlength=256)
        for code, name in zip(codes, names):
            out[name] = out.get(name, 0) + int(n[int(code)])
    return out


def check(path: Path, locking: bool = True) -> dict:
    """The checks themselves (run in the child): ``complete``, ``n_datasets``, ``counts``, ``problems``.
    ``locking=False`` reads a file another process holds open for writing."""
    import h5py

    out = {"complete": False, "n_datasets": 0, "counts": {}, "problems": [], "notes": []}
    problems = out["problems"]
    try:
        f = h5py.File(path, "r", locking=locking)
    except OSError as exc:
        problems.append(f"HDF5 cannot open it ({exc})")
        return out
    with f, open(path, "rb") as fh:
        kind = _text(f.attrs.get("format", ""))
        if (labelled := kind.startswith("fkev-") and kind != _products().FORMAT) and ROOT_DIGEST_ATTR not in f.attrs:
            return {**out, "other_format": kind}  # a labelled file without checksums (fkev loads, response)
        try:
            out["complete"] = bool(int(f.attrs.get("complete", 0)))
            stamped = ROOT_DIGEST_ATTR in f.attrs
            if out["complete"] and not stamped:
                problems.append("complete but without checksums (written before fkev verify existed, "
                                "or the checksums were removed)")
            if stamped and f.attrs[ROOT_DIGEST_ATTR] != root_digest(f):
                problems.append("root attributes changed since the run finished (checksum mismatch)")
            for ds in _datasets(f):
                out["n_datasets"] += 1
                want = ds.attrs.get(DIGEST_ATTR) if stamped else None
                try:
                    have = dataset_digest(ds, fh)
                    if not stamped:
                        ds[()]  # an unfinished run: at least every value must read back
                except (OSError, ValueError, TypeError) as exc:
                    problems.append(f"dataset {ds.name} cannot be read ({exc})")
                    continue
                if stamped and want is None:
                    problems.append(f"dataset {ds.name} has no checksum")
                elif stamped and have != _text(want):
                    problems.append(f"dataset {ds.name} changed since the run finished (checksum mismatch)")
                elif stamped and STRINGS_ATTR in ds.attrs and strings_digest(ds) != _text(ds.attrs[STRINGS_ATTR]):
                    problems.append(f"dataset {ds.name}: its strings changed since the run finished (checksum mismatch)")
                elif stamped and strings_digest(ds) is not None and STRINGS_ATTR not in ds.attrs:
                    out["notes"].append(f"dataset {ds.name}: string contents not checksummed (stamped before {STRINGS_ATTR})")
            for g in _groups(f):  # groups stamped by this version: attributes and member names
                want = g.attrs.get(DIGEST_ATTR) if stamped else None
                if want is not None and group_digest(g) != _text(want):
                    problems.append(f"group {g.name} changed since the run finished (checksum mismatch)")
            for obj in [f] + _groups(f) + _datasets(f):  # every attribute decodes, HDF5's own included
                try:
                    for key in obj.attrs:
                        obj.attrs[key]
                except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
                    problems.append(f"the attributes of {obj.name} cannot be decoded ({exc})")
            problems.extend([] if labelled else structure_problems(f))  # the tables describe sweep archives
            out["counts"] = {} if labelled else _counts(f)
        except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:  # damaged object headers
            problems.append(f"HDF5 cannot read its structure ({exc})")
    return out


if __name__ == "__main__":  # the child of verify(): one JSON line on stdout
    print(json.dumps(check(Path(sys.argv[1]), locking=sys.argv[2] != "1")))
