"""Archives verified before a reader decodes them: every reader of the package (``fk.open`` /
``reader.load``, ``read_floquet``, ``read_response``, ``open_design``) calls :func:`checked`, which
runs :func:`fkev_slepc.archive.verify.verify` (in a child process) once per unchanged file.
"""

from __future__ import annotations

from pathlib import Path


class ArchiveError(ValueError):
    """An archive that cannot be read, or a selection it cannot satisfy (message says which)."""


class DamagedArchiveWarning(UserWarning):
    """The archive read does not match its checksums or its layout (``fkev verify`` would flag it):
    its values may be wrong. Raised as an error instead with ``warnings.simplefilter("error", ...)``."""


def checked(path, stacklevel: int = 2) -> Path:
    """``path`` verified before a reader decodes it (``fk.open``, ``read_floquet``, ``read_response``,
    ``open_design``): an archive whose values or attributes changed since its run finished gives a
    :class:`DamagedArchiveWarning`; one whose metadata HDF5 cannot decode, or that a live run is
    still writing, raises :class:`ArchiveError`. Checked once per unchanged file (:func:`verified`)."""
    path = Path(path)
    if not path.is_file():
        raise ArchiveError(f"{path}: no such archive")
    check = verified(path)
    if check.writer is not None:
        raise ArchiveError(check.summary() + "; read it when the run finishes")
    if check.crashed or any("cannot open" in p or "cannot read its structure" in p for p in check.problems):
        raise ArchiveError(check.summary())
    if not check.ok and check.other_format is None:  # a single-point file has no checksums: nothing damaged
        import warnings

        warnings.warn(check.summary(), DamagedArchiveWarning, stacklevel=stacklevel + 1)
    return path


_VERIFIED: dict = {}


def verified(path: Path):
    """:func:`~fkev_slepc.archive.verify.verify` of ``path``, remembered for this process while
    the file is unchanged (same inode, size and modification time): reading one archive many
    times checks it once."""
    from fkev_slepc.archive.verify import verify

    st = path.stat()
    key = (str(path.resolve()), st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in _VERIFIED:
        check = verify(path)
        if check.writer is not None:  # a live run: it changes, remember nothing
            return check
        _VERIFIED[key] = check
    return _VERIFIED[key]
