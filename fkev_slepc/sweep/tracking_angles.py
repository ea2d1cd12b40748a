"""Tracking along crank angle with refinement: extra angles solved where the MAC is ambiguous.

After the sweep, :func:`track_archive` (collective) walks every (speed, case) line along crank
angle (:func:`tracking.walk`); wherever a link is ambiguous (:func:`tracking.scored_match`) the
line is solved again at the link's midpoint, on every rank (:func:`refine_angles`), and walked
again, until no link is ambiguous or links are ``2**max_halvings`` times shorter than the grid
step, within a budget of extra points (:meth:`tracking.Criteria.budget`: as many as the grid has,
at least 100; requests beyond it are not solved). Lines still ambiguous, or whose modes come
back permuted after a revolution, fall back to sorted order. The extra angles go to
``/tracking/refined`` (docs/tracking.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import SimpleNamespace

import numpy as np

from fkev_slepc.status import converged_codes
from fkev_slepc.sweep.tracking import Criteria, chain_order, lines, track_speeds, walk


@dataclass
class Samples:
    """Points on a set of crank angles: what tracking needs of them (lines = speed × case)."""

    angles_deg: np.ndarray  # (n,)
    freq: np.ndarray  # (n, speed, case, mode) sorted at each point
    status: np.ndarray  # (n, speed, case) uint8
    sig: np.ndarray  # (n, speed, case, n_sig, mode)
    eigenvalue: np.ndarray | None = None  # (n, speed, case, mode)

    @property
    def ok(self) -> np.ndarray:
        return np.isin(self.status, converged_codes())

    @staticmethod
    def concat(*parts: "Samples") -> "Samples":
        def cat(name):
            return np.concatenate([getattr(p, name) for p in parts])

        ev = None if any(p.eigenvalue is None for p in parts) else cat("eigenvalue")
        return Samples(cat("angles_deg"), cat("freq"), cat("status"), cat("sig"), ev)


@dataclass
class AngleTracking:
    """Result of tracking along crank angle (main grid plus refined angles)."""

    tracked: np.ndarray  # (angle, speed, case, mode) on the main grid; sorted order on fallback lines
    fallback: np.ndarray  # (speed, case) bool: the line is in sorted order (ambiguity not resolved)
    open_loop: np.ndarray  # (speed, case) bool: modes came back permuted after a revolution
    ambiguous_main: int  # (link, line) pairs of the main grid ambiguous or crossing before refining
    unresolved: int  # ambiguous (link, line) pairs left after refining (closing links included)
    crossings: int  # (link, line) pairs left that cross (confirmed down to the shortest link)
    refined: Samples | None  # the extra angles solved (None: none)
    refined_tracked: np.ndarray | None  # their frequencies in tracked order
    crit: Criteria = field(default_factory=Criteria)
    budget_points: int = 0  # the most extra points refinement could solve (0: not refined)
    budget_exhausted: bool = False  # requests were left unsolved for lack of budget

    @property
    def open_loops(self) -> int:
        return int(np.count_nonzero(self.open_loop))

    @property
    def refined_points(self) -> int:
        return 0 if self.refined is None else int(np.count_nonzero(self.refined.status))

    def attrs(self) -> dict:
        """Attributes of ``/tracking`` describing what was done."""
        n_ref = 0 if self.refined is None else len(self.refined.angles_deg)
        return dict(self.crit.attrs(), ambiguous_links=self.ambiguous_main, unresolved_links=self.unresolved,
                    crossings=self.crossings,
                    refined_angles=n_ref, refined_points=self.refined_points,
                    refine_budget_points=self.budget_points, refine_budget_exhausted=int(self.budget_exhausted),
                    fallback_lines=int(np.count_nonzero(self.fallback)), open_loops=self.open_loops)


def track_angles(main: Samples, extra: Samples | None = None, crit: Criteria = Criteria(),
                 ambiguous_main: int | None = None):
    """Track along crank angle over ``main`` plus ``extra`` angles; returns the
    :class:`AngleTracking` and the refinement requests ``{angle: (speed, case) mask}``
    (midpoints of ambiguous links still longer than the main step / 2**max_halvings).

    ``ambiguous_main``: the count of ambiguous or crossing links of ``main`` alone, from an
    earlier walk; None counts them on this walk (right only when ``extra`` is None)."""
    allp = main if extra is None else Samples.concat(main, extra)
    na = len(main.angles_deg)
    ns, nc, nm = main.freq.shape[1:]
    order, closed = chain_order(allp.angles_deg)
    w = walk(lines(allp.ok), lines(allp.sig), order, closed, crit)
    tracked_all = w.apply(lines(allp.freq)).reshape(allp.freq.shape)
    tracked_all = np.where(allp.ok[..., None], tracked_all, np.nan)
    fallback = w.unresolved.reshape(ns, nc)
    sorted_all = np.where(allp.ok[..., None], allp.freq, np.nan)
    tracked_all = np.where(fallback[None, :, :, None], sorted_all, tracked_all)

    a = allp.angles_deg
    gaps = np.abs(np.diff(np.sort(main.angles_deg % 360.0)))
    base = gaps[gaps > 1e-9].min() if np.any(gaps > 1e-9) else 360.0
    min_step = base / 2 ** crit.max_halvings * (1 + 1e-9)
    requests: dict[float, np.ndarray] = {}

    def ask(a0, a1, line):
        d = a1 - a0
        if d < 0:
            d += 360.0  # the walk crosses 360° -> 0°
        if d > min_step:
            mid = float(np.round(a0 + d / 2.0, 9))
            requests.setdefault(mid, np.zeros(ns * nc, bool))[line] = True

    for i, line in zip(*np.nonzero(w.ambiguous | w.crossed)):
        ask(a[w.previous[i, line]], a[i], line)
    for line in np.flatnonzero(w.closing_ambiguous | w.closing_crossed):
        ask(a[w.last[line]], a[w.first[line]], line)
    unresolved = int(np.count_nonzero(w.ambiguous) + np.count_nonzero(w.closing_ambiguous))
    if ambiguous_main is None:
        ambiguous_main = int(np.count_nonzero(w.ambiguous | w.crossed)
                             + np.count_nonzero(w.closing_ambiguous | w.closing_crossed))
    result = AngleTracking(
        tracked=tracked_all[:na], fallback=fallback, open_loop=w.open_loop.reshape(ns, nc),
        ambiguous_main=ambiguous_main, unresolved=unresolved,
        crossings=int(np.count_nonzero(w.crossed) + np.count_nonzero(w.closing_crossed)),
        refined=extra, refined_tracked=None if extra is None else tracked_all[na:], crit=crit)
    return result, {k: v.reshape(ns, nc) for k, v in sorted(requests.items())}


def refine_angles(main: Samples | None, solve, comm, crit: Criteria = Criteria(),
                  extra: Samples | None = None) -> AngleTracking | None:
    """Track along crank angle, solving extra angles where links are ambiguous (collective).

    ``main`` is given on rank 0 (None elsewhere). ``solve(angle_deg, mask)`` solves the
    (speed, case) points of ``mask`` at one angle on the calling rank and returns a
    :class:`Samples` of that one angle (status 0 = pending where not solved). Requested angles
    are dealt to the ranks cyclically; rank 0 gathers them. ``extra``: angles already solved
    (a resumed archive's). At most ``crit.budget(points of main)`` extra points are solved, the
    earliest requests first. Returns the result on rank 0."""
    result, amb, exhausted = None, None, False
    budget = spent = 0
    if comm.rank == 0:
        budget = crit.budget(int(np.count_nonzero(main.status)))
        spent = 0 if extra is None else int(np.count_nonzero(extra.status))
    for _ in range(crit.max_halvings + 2):
        if comm.rank == 0:
            if amb is None and extra is not None:  # a resumed archive's angles: count main's links alone
                amb = track_angles(main, None, crit)[0].ambiguous_main
            result, requests = track_angles(main, extra, crit, amb)
            amb = result.ambiguous_main
            work, cut = _within(list(requests.items()), budget - spent)
            exhausted |= cut
            spent += sum(int(np.count_nonzero(m)) for _, m in work)
        else:
            work = None
        work = comm.bcast(work, root=0)
        if not work:
            break
        mine = [solve(angle, mask) for angle, mask in work[comm.rank::comm.size]]
        got = comm.gather(mine, root=0)
        if comm.rank == 0:
            extra = _merge(extra, [s for part in got for s in part])
    if result is not None:
        result = replace(result, budget_points=budget, budget_exhausted=exhausted)
    return result


def _within(work: list, left: int) -> tuple[list, bool]:
    """The requests (angle, mask) that fit in ``left`` points, in order; and whether any was cut."""
    out, n = [], 0
    for angle, mask in work:
        k = int(np.count_nonzero(mask))
        if n + k > left:
            return out, True
        out.append((angle, mask))
        n += k
    return out, False


def _merge(have: Samples | None, new: list[Samples]) -> Samples | None:
    """Add one round's angles (one point each) with a single concatenation; an angle already
    present gets its newly solved lines filled in."""
    parts = [] if have is None else [have]
    for s in new:
        if not any(_fill(old, s) for old in parts):
            parts.append(s)
    return None if not parts else parts[0] if len(parts) == 1 else Samples.concat(*parts)


def _fill(have: Samples, new: Samples) -> bool:
    """Fill the lines ``new`` solved into ``have``'s point at the same angle; False: no such angle."""
    hit = np.flatnonzero(np.isclose(have.angles_deg, new.angles_deg[0], rtol=0, atol=1e-9))
    if hit.size == 0:
        return False
    i, solved = hit[0], new.status[0] != 0
    for name in ("freq", "status", "sig", "eigenvalue"):
        dst, src = getattr(have, name), getattr(new, name)
        if dst is not None and src is not None:
            dst[i][solved] = src[0][solved]
    return True


def track_archive(part, sweep, comm, crit: Criteria = Criteria(), plane: str = "in") -> int | None:
    """Collective, after the sweep (its writer closed, the engine still open): track modes along
    crank angle (solving extra angles with ``sweep.solve_samples`` where links are ambiguous)
    and along speed, and write the results into the archive ``part`` on rank 0 (``plane`` "out":
    the ``/planes/out`` sweep of a two-plane archive, fkev_slepc/sweep/plane_run.py).

    Returns the number of open loops on rank 0 (None on the other ranks)."""
    from fkev_slepc.archive import store, tracks

    main = extra = None
    if comm.rank == 0:
        freq, status, sig = store.read_tracking_inputs(part, plane)
        if sig is not None:
            main = Samples(np.asarray(sweep.grid.angles_deg, float), freq, status, sig)
            old = tracks.read_refined(part, plane)
            if old is not None:
                extra = Samples(old.angles_deg, old.freq, old.status, old.sig, old.eigenvalue)
    if not comm.bcast(main is not None, root=0):
        if comm.rank == 0:  # nothing to track (one angle and one speed): the sorted order
            sorted_f = track_speeds(freq, status, None)[0]
            tracks.write_tracking(part, sorted_f, np.zeros(status.shape[1:], bool), crit.attrs(), sorted_f, plane=plane)
            return 0
        return None
    res = refine_angles(main, sweep.solve_samples, comm, crit, extra)
    if comm.rank != 0:
        return None
    speed_tracked, speed_fallback = track_speeds(main.freq, main.status, main.sig, crit)
    refined = None
    if res.refined is not None:
        r = res.refined
        order = np.argsort(r.angles_deg)
        refined = SimpleNamespace(angles_deg=r.angles_deg[order], freq=r.freq[order],
                                  tracked=res.refined_tracked[order], status=r.status[order], sig=r.sig[order],
                                  eigenvalue=r.eigenvalue[order])
    attrs = dict(res.attrs(), speed_fallback_lines=int(np.count_nonzero(speed_fallback)))
    tracks.write_tracking(part, res.tracked, res.fallback, attrs, speed_tracked, refined, speed_fallback, plane)
    return res.open_loops
