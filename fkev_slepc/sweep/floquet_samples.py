"""The monodromies ``fkev floquet`` solves beside its speed grid, archived as they are solved.

Band-edge refinement (:func:`fkev_slepc.periodic.edges.refine_edges`) and
resonance probes (:func:`fkev_slepc.periodic.bands.unsampled`) ask for speeds that are not
on the grid. :class:`Sampler` solves each round of them over the MPI ranks (dealt cyclically),
appends them on rank 0 to ``/floquet/samples`` (docs/archive.md; the status column last, so a
row cut short by a kill stays pending and is solved again), and then stops cleanly if a rank
was sent Ctrl-C/SIGTERM (:mod:`fkev_slepc.sweep.interrupt`: every rank leaves after the same
sync, the ``.part`` resumable). A resumed run reads the archived samples back: the edge search,
a function of the points known, asks from them for the speeds the uninterrupted run asked next, so
an interrupted refinement continues where it stopped and ends with the uninterrupted edges. ``FKEV_PAUSE_AFTER=K`` pauses at the first
round after which K samples are archived (counted beside the grid, the resumed ones included; a
grid phase that paused and went on, SIGUSR2, pauses here again).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from fkev_slepc.archive import products as P, lock
from fkev_slepc.archive.products_floquet import F_SAMPLE, SAMPLE_ROWS, SAMPLE_STATUS
from fkev_slepc.archive.store import text
from fkev_slepc.periodic.bands import SpeedPoint
from fkev_slepc.status import Status
from fkev_slepc.sweep.interrupt import StopRequest, SweepInterrupted

PURPOSES = ("edge", "probe")
_COLUMNS = {v.source: v for v in SAMPLE_ROWS if v.source and v is not SAMPLE_STATUS}


def add_sample_rows(part) -> None:
    """Rank 0: the empty ``/floquet/samples`` rows in an archive written before they existed."""
    from fkev_slepc.archive.groups import build, describe_groups

    with h5py.File(part, "r+") as f:
        if F_SAMPLE not in f:
            build(f, SAMPLE_ROWS, {})
            describe_groups(f, P.FLOQUET)


def read_samples(part) -> dict[float, tuple[SpeedPoint, str]]:
    """speed -> (point, purpose) of every finished row of ``/floquet/samples``."""
    with h5py.File(part, "r") as f:
        if F_SAMPLE not in f:
            return {}
        col = {k: f[v.path][()] for k, v in _COLUMNS.items()}
        codes = np.asarray(f[SAMPLE_STATUS.path][()], dtype=np.uint8)
    out = {}
    for i, code in enumerate(codes):
        if code == Status.PENDING.code:
            continue
        mu = col["multipliers"][i]
        ok = code in (Status.OK.code, Status.UNSTABLE.code)
        point = SpeedPoint(float(col["speed"][i]), mu[np.isfinite(mu)], float(col["error"][i]), ok)
        out[point.speed] = (point, text(col["purpose"][i]))
    return out


def append_samples(part, rows: list[tuple[SpeedPoint, str, int, str]], n_index: int) -> None:
    """Rank 0: append (point, purpose, status code, message) rows, the status column last."""
    if not rows:
        return
    with h5py.File(part, "r+") as f:
        n0 = f[F_SAMPLE].shape[0]
        n = n0 + len(rows)
        for v in SAMPLE_ROWS:
            f[v.path].resize(n, axis=0)
        f[F_SAMPLE][n0:] = np.arange(n0 + 1, n + 1)
        mu = np.full((len(rows), n_index), P.CNAN)
        for i, (p, *_r) in enumerate(rows):
            mu[i, : p.multipliers.size] = p.multipliers
        values = {"speed": [p.speed for p, *_r in rows], "purpose": [r[1] for r in rows], "multipliers": mu,
                  "max_abs": [p.max_abs for p, *_r in rows], "error": [p.error for p, *_r in rows],
                  "message": [r[3] for r in rows]}
        for key, vals in values.items():
            ds = f[_COLUMNS[key].path]
            ds[n0:] = vals if _COLUMNS[key].dtype == P.STRING else np.asarray(vals, dtype=ds.dtype)
        f.flush()
        f[SAMPLE_STATUS.path][n0:] = np.asarray([r[2] for r in rows], dtype=np.uint8)


class Sampler:
    """Collective ``sampler(speeds, purpose) -> points``: the speeds not archived yet solved over
    the ranks and archived; raises SweepInterrupted on every rank after a signal (lock released).

    ``evaluate(speed) -> (SpeedPoint, message)``; ``status(point, message) -> code``;
    ``resume_command``: what the interruption notice says to run. Use inside ``with sampler.stop:``
    (the signal handlers)."""

    def __init__(self, part: Path, out: Path, evaluate, status, comm, n_index: int, notify=None,
                 resume_command: str = ""):
        self.part, self.out, self.evaluate, self.status, self.comm, self.n_index = (
            part, out, evaluate, status, comm, n_index)
        archived = read_samples(part) if comm.rank == 0 else None
        archived = comm.bcast(archived, root=0)
        self.known = {w: p for w, (p, _purpose) in archived.items()}  # speed -> SpeedPoint
        self.resumed = len(self.known)
        self.solved = {purpose: 0 for purpose in PURPOSES}  # by this run

        def say(what):
            if notify is not None and comm.rank == 0:
                how = resume_command or "the same run with resume=True"
                notify(f"interrupted by {what}: stopping at the next sync; the speeds solved so far stay in {part}; "
                       f"continue with: {how}")

        self.stop = StopRequest(notify=say)

    def __call__(self, speeds, purpose: str) -> list[SpeedPoint]:
        new = list(dict.fromkeys(float(w) for w in speeds if float(w) not in self.known))
        mine = {w: self.evaluate(w) for w in new[self.comm.rank::self.comm.size]}
        got: dict = {}
        for part in self.comm.allgather(mine):
            got.update(part)
        if self.comm.rank == 0:
            append_samples(self.part, [(got[w][0], purpose, self.status(*got[w]), got[w][1]) for w in new],
                           self.n_index)
        self.known.update((w, got[w][0]) for w in new)
        self.solved[purpose] += len(new)
        done = len(self.known)
        if self.stop.agreed(self.comm, done, done + 1):
            if self.comm.rank == 0:
                lock.release(self.out)
            raise SweepInterrupted(self.part, sum(self.solved.values()))
        return [self.known[float(w)] for w in speeds]

