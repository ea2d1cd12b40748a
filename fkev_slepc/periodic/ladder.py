"""The one reduction ladder of the periodic analyses: a reduced answer is only as good as its basis,
and its truncation error is measured by climbing basis levels, coarse to fine, and watching the
answer change (docs/engine.md; Floquet: fkev_slepc/periodic/truncation.py, the response:
fkev_slepc/periodic/component_response.py).

:func:`climb` takes the levels (an iterable, read lazily: the next level is built only when asked),
``solve(level)`` -> a result, ``change(other, reference)`` -> a tuple of relative changes of
``other`` from ``reference`` (each relative to the reference: the level returned), and ``tol``. The rule:

* **Converged** at the first level whose change from the level before is within ``tol`` in every
  ``decisive`` measure, for two successive pairs of levels (``confirm``; one small change can be a
  coincidence of a sequence that has not converged), or for one pair (``confirm`` False: a basis
  whose error falls by an order or more per level, the moving basis). The finest level is returned
  with the larger change of the two pairs, measure by measure, as its truncation estimate.
* **Exact** at a level that spans the whole space (``whole(level)``: the projection is then a change
  of variables): that level's result, truncation zero.
* **Fixed** (``fixed``): the first level is the answer, the second (its double) measured from it,
  converged when that one change is within ``tol``.
* **Stopped**: when the levels run out (a cap, the whole pool) or the next one does not fit
  (``fits(level, previous result)`` False): the last level solved, with the last measured change
  (inf when only one level was solved) and ``converged`` False: the error is reported, never hidden.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable


@dataclass(frozen=True)
class Climb:
    """What :func:`climb` found: the result returned and its level, the change measured (None: exact;
    empty: stopped after one level, not measured),
    whether it converged, and every level solved, coarse to fine, as (level, result, change from the
    level before or None)."""

    result: object
    level: object
    changes: tuple | None
    converged: bool
    rungs: tuple

    @property
    def exact(self) -> bool:
        """The returned level spans the whole space: its truncation is zero."""
        return self.changes is None


def climb(levels: Iterable, solve: Callable, change: Callable, tol: float, *, decisive=None, confirm: bool = True,
          whole: Callable = lambda level: False, fits: Callable | None = None, fixed: bool = False) -> Climb | None:
    """The ladder of the module docstring; None when no level was given. ``decisive``: the indices of
    the measures that decide convergence (default all)."""
    def within(m):
        return all(m[i] <= tol for i in (range(len(m)) if decisive is None else decisive))

    rungs, pair, report = [], None, None
    for level in levels:
        if rungs and fits is not None and not fits(level, rungs[-1][1]):
            break
        res = solve(level)
        # each change relative to the level returned: the finer one, or the fixed level against its double
        m = None if not rungs else tuple(change(res, rungs[0][1]) if fixed else change(rungs[-1][1], res))
        rungs.append((level, res, m))
        if whole(level) and not (fixed and m is not None):  # a fixed level is the first; its double only measures it
            return Climb(res, level, None, True, tuple(rungs))
        if m is None:
            continue
        if fixed:
            return Climb(rungs[0][1], rungs[0][0], m, within(m), tuple(rungs))
        report = m if pair is None or not confirm else tuple(max(a, b) for a, b in zip(m, pair))
        if within(report) and (pair is not None or not confirm):
            return Climb(res, level, report, True, tuple(rungs))
        pair = m
    if not rungs:
        return None
    return Climb(rungs[-1][1], rungs[-1][0], () if report is None else report, False, tuple(rungs))
