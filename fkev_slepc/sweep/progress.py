"""Progress of a sweep on rank 0: points done / total, rate and ETA."""

from __future__ import annotations

import os
import sys
import time

import numpy as np


class Progress:
    """Points done / total, rate and ETA: a tqdm bar on a terminal, else a line every
    ``every`` seconds (and at the end) on ``stream`` (stderr by default).

    Called as ``progress(done, total)`` by :meth:`fkev_slepc.sweep.runner.Sweep.run`.
    """

    def __init__(self, total: int, every: float = 10.0, stream=None, label: str = "fkev run", unit: str = "points"):
        self.total, self.every, self.label, self.unit = total, every, label, unit
        self.stream = stream or sys.stderr
        self.t0 = self._last = time.monotonic()
        self.bar = None
        if self.stream.isatty() and os.environ.get("TERM") != "dumb":
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=total, unit="pt" if unit == "points" else unit, file=self.stream,
                                dynamic_ncols=True, desc=None if label == "fkev run" else label)
            except ImportError:  # pragma: no cover - tqdm is part of the stack
                self.bar = None
        self.done = 0

    def __call__(self, done: int, total: int) -> None:
        if self.bar is not None:
            self.bar.update(done - self.done)
        now = time.monotonic()
        self.done = done
        if self.bar is None and (now - self._last >= self.every or done >= total):
            self._last = now
            print(self.line(done, total, now - self.t0, self.label, self.unit), file=self.stream, flush=True)

    @staticmethod
    def line(done: int, total: int, elapsed: float, label: str = "fkev run", unit: str = "points") -> str:
        """One progress line.

        Examples
        --------
        >>> Progress.line(50, 200, 10.0)
        'fkev run: 50/200 points (25%), 5.0 points/s, ETA 00:00:30'
        """
        rate = done / elapsed if elapsed > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else float("nan")
        eta_s = time.strftime("%H:%M:%S", time.gmtime(eta)) if np.isfinite(eta) else "?"
        pct = 100.0 * done / total if total else 100.0
        return f"{label}: {done}/{total} {unit} ({pct:.0f}%), {rate:.1f} {unit}/s, ETA {eta_s}"

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
