"""Output paths checked before any work: one clear line naming the path, never a traceback
after the sweep (``fkev run``, ``plot -o``, ``export -o``).

:func:`check_output` refuses a wrong extension, a path that is a directory, a missing parent
directory (never created silently), and a directory that cannot be written (probed by
creating and removing a file there: permission bits say nothing for root or on read-only
mounts such as ``/proc``).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


class PathProblem(ValueError):
    """An output path that cannot be used; the message is one line naming the flag and path."""


def check_output(path: str | Path, suffixes: tuple[str, ...], flag: str = "-o", *, make_parent: bool = False) -> Path:
    """Check that ``path`` can be written as an output file; returns it as a Path.

    Parameters
    ----------
    path : the output file
    suffixes : accepted extensions (lower case, with the dot), e.g. ``(".h5",)``
    flag : how the user gave it (named in the message)
    make_parent : create a missing parent directory (only for defaults the documentation
        promises, e.g. ``<scene dir>/out/``); an explicit path's parent must exist

    Raises
    ------
    PathProblem
    """
    text = str(path)
    p = Path(path)
    if text.endswith(os.sep) or p.is_dir():
        raise PathProblem(f"{flag} {text}: is a directory (give a file name ending in {_alts(suffixes)})")
    if p.suffix.lower() not in suffixes:
        raise PathProblem(f"{flag} {text}: unsupported format {p.suffix or '(no extension)'!r} (use {_alts(suffixes)})")
    parent = p.parent
    if not parent.exists():
        if not make_parent:
            raise PathProblem(f"{flag} {text}: directory {parent} does not exist (create it first)")
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise PathProblem(f"{flag} {text}: cannot create directory {parent} ({_why(exc)})") from None
    if not parent.is_dir():
        raise PathProblem(f"{flag} {text}: {parent} is not a directory")
    try:
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".fkev-probe-"):
            pass
    except OSError as exc:
        raise PathProblem(f"{flag} {text}: directory {parent} is not writable ({_why(exc)})") from None
    if p.exists() and not os.access(p, os.W_OK):
        raise PathProblem(f"{flag} {text}: file exists and is not writable")
    return p


def _alts(suffixes) -> str:
    return " or ".join(suffixes)


def _why(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


def check_archive_output(out: str | Path, *, resume: bool, force: bool, flag: str = "-o",
                         make_parent: bool = False) -> Path:
    """:func:`check_output` for an archive, and no silent replacement of earlier work.

    Without ``resume`` or ``force``, an existing archive ``out`` (finished) or ``out.part``
    (an interrupted run) is refused, naming the way to continue it (``--resume``) or to
    replace it (``--force``). With ``force`` an existing output is replaced only when the new
    run finishes (it writes ``out.part`` meanwhile; an unfinished run is started over).

    Raises
    ------
    PathProblem
    """
    from fkev_slepc.archive.store import partial_path

    p = check_output(out, (".h5",), flag, make_parent=make_parent)
    part = partial_path(p)
    if resume or force:
        if part.is_dir():
            raise PathProblem(f"{flag} {p}: {part} is a directory")
        return p
    # the command line's flags, or the API's arguments when the caller is Study.sweep (flag "output")
    resume_, retry_, force_ = (("--resume", "--retry-failed", "--force") if flag.startswith("-")
                               else ("resume=True", "retry_failed=True", "force=True"))
    if p.exists():
        raise PathProblem(f"{flag} {p}: an archive already exists ({_points(p)}); continue it with {resume_} "
                          f"(with {retry_} to solve its failed points again) or replace it with {force_}")
    if part.exists():
        raise PathProblem(f"{flag} {p}: an unfinished run exists ({part.name}, {_points(part)}); continue it with "
                          f"{resume_} or start over with {force_}")
    return p


def _points(path: Path) -> str:
    """``1314 points, 1314 done`` for an fkev archive, ``not an fkev archive`` otherwise."""
    try:
        import h5py
        import numpy as np

        from fkev_slepc.archive.products import SWEEP

        with h5py.File(path, "r") as f:
            status = f[SWEEP.status][()]
            return f"{status.size} points, {int(np.count_nonzero(status))} done"
    except (OSError, KeyError):
        return "not an fkev archive"
