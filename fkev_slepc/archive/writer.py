"""Per-rank writing of a product's results (:mod:`fkev_slepc.archive.products`) into an archive
created by :mod:`fkev_slepc.archive.store`, one unit of work at a time (the sweep's: one crank angle).

With the ``mpio`` driver (h5py with MPI, more than one rank) every rank writes the points of
the units it solved with independent hyperslab writes, and the flushes are collective;
otherwise rank 0 alone holds the file and the other ranks send it their results at each sync.
Statuses are written only after the data they vouch for has been flushed (see
:class:`Writer`), so after a crash a point marked done always has its data.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import h5py
import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.products import MESSAGE_BYTES  # noqa: F401 (part of the archive contract)


def use_mpio(comm) -> bool:
    """Parallel HDF5 when h5py has MPI, there is more than one rank and the environment
    does not say ``FKEV_HDF5_MPIO=0`` (for file systems without working MPI-IO locking)."""
    return bool(h5py.get_config().mpi and comm.size > 1 and os.environ.get("FKEV_HDF5_MPIO", "1") != "0")


@dataclass
class Block:
    """Results of one unit of work of a product: the points of unit ``ia`` marked in ``mask``.

    ``ia``: the unit's index (an int for a product with one unit axis, such as the sweep's
    crank angle, else a tuple); ``mask``: the points of the unit (shaped like the product's
    ``point_dims``, e.g. (speed, case)) that were solved. ``data`` maps dataset paths (table
    rows of :mod:`fkev_slepc.archive.products`) to arrays: per-point datasets shaped
    ``mask.shape + ...``, per-unit datasets (``modes/node_xy``) shaped like one unit's slice.
    ``status``: the points' status codes (``mask.shape``). ``errors``: ((point index), status,
    message) of failed/not-converged points. ``node_xy``: per-unit node positions of the sweep
    (kept for callers that pass them apart; the same as ``data[NODE_XY.path]``).
    """

    ia: int | tuple
    mask: np.ndarray
    data: dict
    status: np.ndarray
    errors: list
    node_xy: np.ndarray | None = None

    @property
    def unit(self) -> tuple:
        return self.ia if isinstance(self.ia, tuple) else (int(self.ia),)


class Writer:
    """Per-rank writer of :class:`Block` s; see the module docstring for the two modes.

    :meth:`sync` is collective: all ranks call it at the same rounds (it tells them when the
    next one is due: about every ``interval`` seconds of rank 0's work), and :meth:`close`
    once at the end.
    """

    def __init__(self, path, comm, parallel: bool | None = None, interval: float = 2.0,
                 product: P.Product = P.SWEEP):
        self.comm, self.product = comm, product
        self.parallel = use_mpio(comm) if parallel is None else parallel
        self.root = comm.rank == 0
        self.interval = interval
        self._clock = time.monotonic
        self._t_sync, self._rounds = self._clock(), 0
        self.next_gap = 1  # rounds until the next sync (the first one measures the round time)
        if self.parallel:
            self.f = h5py.File(path, "r+", driver="mpio", comm=comm)
        else:
            self.f = h5py.File(path, "r+") if self.root else None
        written = [v.path for v in product.written()]
        self._ds = {} if self.f is None else {k: self.f[k] for k in written if k in self.f}
        self._per_unit = {v.path for v in product.per_unit()}
        self._blocks: list[Block] = []  # serial mode: not yet sent to rank 0
        self._count = 0  # points this rank completed since the last sync
        self._new_errors: list = []  # this rank's error rows since the last sync
        self._done: list = []  # (ia, mask, status) to write at the next flush
        self._errors: list = []  # every rank's error rows, appended at the next flush

    def write_block(self, block: Block) -> None:
        """Store one angle's results (their status becomes visible at the next sync)."""
        self._count += int(block.mask.sum())
        if not self.parallel:
            self._blocks.append(block)
            return
        self._write(block)
        self._new_errors.extend(block.errors)

    def end_round(self) -> bool:
        """Count a round; True when every rank must now call :meth:`sync`."""
        self._rounds += 1
        return self._rounds >= self.next_gap

    def _write(self, b: Block) -> None:
        whole = bool(np.all(b.mask))
        data = dict(b.data)
        if b.node_xy is not None:
            data.setdefault(P.NODE_XY.path, b.node_xy)
        u = b.unit
        for name, arr in data.items():
            ds = self._ds.get(name)
            if ds is None:
                continue
            arr = np.asarray(arr, dtype=ds.dtype)
            if whole or name in self._per_unit:  # one hyperslab for the whole unit
                ds[u] = arr
            else:
                for j in np.argwhere(b.mask):
                    ds[u + tuple(j)] = arr[tuple(j)]
        self._done.append((u, b.mask, b.status))

    def sync(self) -> int:
        """Collective: send results to rank 0 (serial mode), exchange error rows, flush, and
        agree on the next sync. Returns the number of points completed since the last sync."""
        n = self._count
        if not self.parallel:
            blocks = self.comm.gather(self._blocks, root=0)
            self._blocks = []
            for b in (x for rank_blocks in blocks or () for x in rank_blocks):
                self._write(b)
                self._errors.extend(b.errors)
        now = self._clock()
        gap = self.next_gap
        if self.root and self._rounds:
            per_round = (now - self._t_sync) / self._rounds
            gap = int(np.clip(np.ceil(self.interval / max(per_round, 1e-6)), 1, 10_000))
        ctrl = self.comm.allgather((n, gap, self._new_errors))
        self._count, self._new_errors, self._rounds = 0, [], 0
        self.next_gap = ctrl[0][1]
        for _, _, errors in ctrl:  # parallel mode: every rank now holds the same rows
            self._errors.extend(errors)
        self._flush()
        self._t_sync = self._clock()
        return int(sum(c[0] for c in ctrl))

    def _flush(self) -> None:
        """Collective: append error rows, put the data on disk, then mark the points done."""
        f, e = self.f, self.product.errors
        if f is None:
            return
        if self._errors and e is not None:
            n0, k = f[e.index.path].shape[0], len(self._errors)
            rows = [v for v in (e.row, e.index, e.status, e.message) if v.path in f]  # format 1 may lack the row scale
            for v in rows:
                f[v.path].resize(n0 + k, axis=0)  # collective in mpio mode
            if self.root:
                if e.row.path in f:
                    f[e.row.path][n0:] = np.arange(n0, n0 + k, dtype="i4")
                f[e.index.path][n0:] = np.array([x[0] for x in self._errors], dtype="i4")
                f[e.status.path][n0:] = np.array([x[1] for x in self._errors], dtype="u1")
                f[e.message.path][n0:] = [_clip(x[2]) for x in self._errors]
            self._errors = []
        f.flush()  # data first ...
        status = self._ds[self.product.status]
        for u, mask, st in self._done:
            if np.all(mask):
                status[u] = st
            else:
                for j in np.argwhere(mask):
                    status[u + tuple(j)] = st[tuple(j)]
        self._done = []
        f.flush()  # ... then the statuses that say the points are done

    def close(self) -> None:
        """Final collective sync, then close."""
        self.sync()
        if self.f is not None:
            self.f.close()
            self.f = None


def _clip(msg: str) -> bytes:
    """UTF-8 bytes of ``msg`` cut to MESSAGE_BYTES at a character boundary."""
    raw = str(msg).encode("utf-8")
    if len(raw) <= MESSAGE_BYTES:
        return raw
    return raw[: MESSAGE_BYTES - 3].decode("utf-8", "ignore").encode("utf-8") + b"..."
