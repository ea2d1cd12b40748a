"""One writer per archive: an advisory lock next to the output, held for the whole run.

Two ``fkev run`` on the same ``-o`` used to write the same ``<name>.h5.part`` (the second
truncating the first's file under it) and left an archive HDF5 could not open. Now the first
takes ``<name>.h5.lock`` with ``flock`` before anything is created or moved, and a second
writer is refused with :class:`ArchiveLocked` (exit 2) without touching any file.

``flock`` belongs to the open file description, so the kernel drops it when the holder dies
(``kill -9``): a killed run never leaves a stale lock and ``--resume`` just works. The lock
file itself is removed on release; a writer that opened it just before the removal notices
(the path no longer names the inode it locked) and tries again on the new file.
"""

from __future__ import annotations

import datetime
import fcntl
import os
import socket
from pathlib import Path


class ArchiveLocked(RuntimeError):
    """Another process is writing this archive (message names it and the lock file)."""


def lock_path(path: str | Path) -> Path:
    """``<name>.h5.lock`` beside the archive ``<name>.h5``."""
    path = Path(path)
    return path.with_name(path.name + ".lock")


class ArchiveLock:
    """Exclusive, non-blocking lock of an archive path (a context manager).

    Examples
    --------
    >>> with ArchiveLock("out.h5"):      # doctest: +SKIP
    ...     ...                          # create / resume / finalize out.h5
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.file = lock_path(path)
        self._fd: int | None = None

    def acquire(self) -> "ArchiveLock":
        self.file.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(100):  # only a release racing with us makes this loop more than once
            fd = os.open(self.file, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 200, 0).decode("utf-8", "replace").strip() or "another process"
                os.close(fd)
                raise ArchiveLocked(f"{self.path} is being written by {holder} (lock {self.file}); "
                                    "wait for it to finish, or write elsewhere with -o") from None
            try:
                same = os.stat(self.file).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"fkev pid {os.getpid()} on {socket.gethostname()} since {now}".encode(), 0)
                self._fd = fd
                return self
            os.close(fd)  # the holder released and removed the file between our open and flock
        raise ArchiveLocked(f"{self.path}: could not take the lock {self.file}")

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            os.unlink(self.file)  # while still holding it: see the inode check in acquire
        except FileNotFoundError:
            pass
        os.close(self._fd)
        self._fd = None

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()


_HELD: dict[Path, ArchiveLock] = {}


def hold(path: str | Path) -> None:
    """Take the lock of ``path`` for the rest of the run (released by :func:`release` or exit).

    Raises
    ------
    ArchiveLocked
        Another process holds it.
    """
    key = Path(path).resolve()
    if key not in _HELD:
        _HELD[key] = ArchiveLock(path).acquire()


def release(path: str | Path) -> None:
    """Release the lock :func:`hold` took (no-op if not held)."""
    lock = _HELD.pop(Path(path).resolve(), None)
    if lock is not None:
        lock.release()


def writer_of(path: str | Path) -> str | None:
    """The live run writing the archive ``path`` (``<name>.h5`` or its ``<name>.h5.part``): the
    text of its lock (``fkev pid N on HOST since T``), or None when no process holds the lock.

    Read without taking the lock (a reader must never make a starting writer fail): Linux lists
    every held ``flock`` in ``/proc/locks`` by inode; elsewhere a held lock is detected by a
    non-blocking shared lock attempt, released at once."""
    path = Path(path)
    final = path.with_name(path.name[: -len(".part")]) if path.name.endswith(".part") else path
    file = lock_path(final)
    try:
        fd = os.open(file, os.O_RDONLY)
    except OSError:
        return None
    try:
        text = os.pread(fd, 200, 0).decode("utf-8", "replace").strip() or "another process"
        held = _held_in_proc_locks(os.fstat(fd))
        if held is None:  # no /proc/locks: probe
            try:
                fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
                fcntl.flock(fd, fcntl.LOCK_UN)
                held = False
            except BlockingIOError:
                held = True
        return f"{text} (lock {file})" if held else None
    finally:
        os.close(fd)


def _held_in_proc_locks(st) -> bool | None:
    """Whether ``/proc/locks`` lists a FLOCK on the file of ``st`` (None: no /proc/locks)."""
    try:
        lines = Path("/proc/locks").read_text().splitlines()
    except OSError:
        return None
    dev = f"{os.major(st.st_dev):02x}:{os.minor(st.st_dev):02x}:{st.st_ino}"
    return any(" FLOCK " in f" {ln} " and ln.split()[5 if "->" not in ln else 6] == dev for ln in lines)
