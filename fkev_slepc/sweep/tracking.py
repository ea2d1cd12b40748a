"""Mode tracking: modes followed along crank angle and along speed by MAC, refined where ambiguous.

A *line* is a fixed (speed, case) for tracking along crank angle, or a fixed (angle, case) for
tracking along speed. Walking a line, the modes of each converged point are matched to the
already-tracked modes of the previous converged point by greedy MAC (:func:`modes.match_modes`)
on the eigenvector entries archived in ``/tracking/signature``. A *link* (one step of a walk)
is **ambiguous** when, for some mode, the MAC of its match is below :data:`MAC_MIN`, or beats
the best competitor in its row or column of the MAC matrix by less than :data:`MAC_MARGIN`.
A link that **crosses** (the tracked modes change their frequency order) is not ambiguous by
itself, but from two samples a true crossing cannot be told from a veering the grid stepped
over (the shapes exchange within the link and look crossed): it has to be confirmed.

Along crank angle the sweep then solves extra angles (only the lines concerned, at the
midpoint of each ambiguous or crossing link; :mod:`fkev_slepc.sweep.tracking_angles`) and walks again,
halving a link of the main grid at most :data:`MAX_HALVINGS` times. A crossing still there
with clear MACs on links that short is a crossing. A line that still has an ambiguous link, or whose modes come
back permuted after a whole revolution, *falls back* to sorted order (its tracked frequencies
are then the sorted ones, flagged in ``/tracking/fallback``): the archive never shows a guessed
identity. Along speed nothing extra is solved, so a line with an ambiguous or crossing link falls back.
The extra angles are archived in ``/tracking/refined`` (docs/tracking.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.plane import Plane
from fkev_slepc.solve.modes import greedy_match, mac
from fkev_slepc.status import converged_codes

TRACK_DOFS = 64  # eigenvector entries kept per mode for tracking (all DOFs of smaller models)
# Thresholds (archived as attributes of /tracking). Measured on Bahgat-Willmert at 1000 rad/s
# (docs/tracking.md): between 1° neighbours every match has MAC >= 0.88 and beats its
# competitors by >= 0.5, while the 10° links that swap modes have matches of 0.46-0.75 or
# competitors within 0.1-0.3 of them. The MAC is on raw DOF entries (not mass-weighted), so two
# different modes can have a MAC of 0.3-0.45; the margin is measured against that.
MAC_MIN = 0.8
MAC_MARGIN = 0.3
MAX_HALVINGS = 6  # a 10° link is refined down to 10°/64 = 0.16° at most
REFINE_BUDGET = 1.0  # extra points solved for tracking: at most as many as the grid has ...
REFINE_BUDGET_MIN = 100  # ... or this many, whichever is larger


@dataclass(frozen=True)
class Criteria:
    """When a link is unambiguous, and how far a link of the main grid may be halved."""

    mac_min: float = MAC_MIN
    mac_margin: float = MAC_MARGIN
    max_halvings: int = MAX_HALVINGS
    refine_budget: float = REFINE_BUDGET
    refine_budget_min: int = REFINE_BUDGET_MIN

    def budget(self, n_points: int) -> int:
        """The most extra points tracking may solve for a grid of ``n_points`` points."""
        return max(int(self.refine_budget_min), int(np.ceil(self.refine_budget * n_points)))

    def attrs(self) -> dict:
        return {"mac_min": self.mac_min, "mac_margin": self.mac_margin, "max_halvings": self.max_halvings,
                "refine_budget": self.refine_budget, "refine_budget_min": self.refine_budget_min}


def tracking_dofs(n_free: int, n_angles: int, n_speeds: int = 1, limit: int = TRACK_DOFS) -> np.ndarray | None:
    """Free DOFs whose eigenvector entries are stored for tracking; None for a single point
    per line (one angle and one speed).

    Every DOF of models with at most ``limit`` of them, else ``limit`` DOFs spread evenly
    over the numbering (a non-integer stride, so U, V and Φ entries all appear)."""
    if n_angles < 2 and n_speeds < 2:
        return None
    if n_free <= limit:
        return np.arange(n_free)
    return np.unique(np.linspace(0, n_free - 1, limit).round().astype(int))


def signature_weight(plane: str, mass_diagonal: np.ndarray, dofs: np.ndarray | None) -> np.ndarray | None:
    """Weights of the eigenvector entries stored for tracking at one crank angle: None (raw
    entries) in plane; √M_ii at the tracked DOFs out of plane.

    Out of plane a node's DOFs are two rotations (rad) and a displacement w (m) (docs/theory.md
    §19.7); on raw entries the rotations dominate and different modes of the flat-rod
    slider-crank have MACs of 0.8 (docs/tracking.md, "Out of plane"). Weighted by the square
    root of the mass diagonal, each entry counts with its own kinetic energy, and the MAC of
    different modes falls below 0.15. The in-plane criteria were measured on raw entries and
    stay so."""
    if not Plane.parse(plane).weighted_signatures or dofs is None:
        return None
    return np.sqrt(np.asarray(mass_diagonal, dtype=float)[dofs])


def chain_order(angles_deg) -> tuple[np.ndarray, bool]:
    """Order in which to walk the crank angles for tracking, and whether it closes a loop.

    Angles are walked in ascending order. A grid spanning less than a revolution whose
    largest hole (on the circle) is not across 360° → 0° is walked across 360° → 0° instead,
    starting after that hole (300, 330, 0, 30 → 300, 330, 0, 30 rather than 0, 30, 300, 330).
    The walk closes a loop when it covers a whole revolution, its last step back to the start
    included (0..360 or 0..355 by 5°)."""
    a = np.asarray(angles_deg, dtype=float)
    order = np.argsort(a, kind="stable")
    if a.size < 2:
        return order, False
    if a[order[-1]] - a[order[0]] < 360.0 - 1e-9:
        on_circle = np.argsort(a % 360.0, kind="stable")
        m = a[on_circle] % 360.0
        gaps = np.diff(m)
        if gaps.max() > m[0] + 360.0 - m[-1] + 1e-9:
            order = np.roll(on_circle, -(int(np.argmax(gaps)) + 1))
    steps = np.abs((np.diff(a[order]) + 180.0) % 360.0 - 180.0)
    closed = bool(steps.sum() + steps.max() >= 360.0 - 1e-6)
    return order, closed


def scored_match(prev: np.ndarray, cur: np.ndarray, crit: Criteria = Criteria()) -> tuple[np.ndarray, np.ndarray]:
    """Match ``cur``'s modes to ``prev``'s by greedy MAC, batched over lines, and score each match.

    ``prev`` and ``cur`` are (n_lines, n_sig, n_modes). Returns ``perm`` (n_lines, n_modes), with
    ``cur[l][:, perm[l, i]]`` the match of ``prev[l][:, i]``, and ``clear`` (n_lines, n_modes):
    the match has MAC >= ``mac_min`` and beats by at least ``mac_margin`` every competitor in
    its row and column of the MAC matrix (another mode of ``cur`` for ``prev``'s mode i, another
    mode of ``prev`` for its partner)."""
    m = mac(prev, cur)
    perm = greedy_match(m.copy())
    got = np.take_along_axis(m, perm[:, :, None], axis=2)[..., 0]
    own = np.zeros(m.shape, dtype=bool)
    np.put_along_axis(own, perm[:, :, None], True, axis=2)
    others = np.where(own, -np.inf, m)
    rival = np.maximum(others.max(axis=2), np.take_along_axis(others.max(axis=1), perm, axis=1))
    return perm, (got >= crit.mac_min) & (got - rival >= crit.mac_margin)


def link_check(prev: np.ndarray, cur: np.ndarray, crit: Criteria = Criteria()) -> tuple[np.ndarray, np.ndarray]:
    """:func:`scored_match`, and ``ambiguous`` (n_lines,): some match of the line is not clear."""
    perm, clear = scored_match(prev, cur, crit)
    return perm, ~clear.all(axis=1)


@dataclass
class Walk:
    """Modes followed along one coordinate for a set of lines (see :func:`walk`)."""

    perm: np.ndarray  # (n_pos, n_lines, n_modes): tracked mode i at a point is sorted mode perm[..., i]
    previous: np.ndarray  # (n_pos, n_lines) position of the previous converged point of the walk, -1 none
    ambiguous: np.ndarray  # (n_pos, n_lines) the link previous -> this point is ambiguous
    crossed: np.ndarray  # (n_pos, n_lines) the link changes the frequency order of the tracked modes
    closing_ambiguous: np.ndarray  # (n_lines,) the link back from the end to the start is ambiguous
    closing_crossed: np.ndarray  # (n_lines,) ... changes the frequency order
    open_loop: np.ndarray  # (n_lines,) the modes come back permuted after a whole revolution
    last: np.ndarray  # (n_lines,) last converged position of the walk, -1 none
    first: np.ndarray  # (n_lines,) first converged position of the walk, -1 none

    def apply(self, values: np.ndarray) -> np.ndarray:
        """``values`` (n_pos, n_lines, n_modes) in tracked order."""
        return np.take_along_axis(values, self.perm, axis=2)

    @property
    def unresolved(self) -> np.ndarray:
        """(n_lines,) lines with an ambiguous link or an open loop."""
        return self.ambiguous.any(axis=0) | self.closing_ambiguous | self.open_loop


def walk(ok: np.ndarray, sig: np.ndarray, order: np.ndarray, closed: bool, crit: Criteria = Criteria()) -> Walk:
    """Follow modes along positions ``order`` for every line at once.

    ``ok`` (n_pos, n_lines) marks converged points (others are skipped: the walk continues from
    the last converged point of the line); ``sig`` (n_pos, n_lines, n_sig, n_modes) their
    eigenvector entries. ``closed``: the walk is a whole revolution, and its end is compared
    with its start."""
    n, n_lines, _, nm = sig.shape
    v = np.nan_to_num(sig)
    ident = np.arange(nm)
    perm_all = np.broadcast_to(ident, (n, n_lines, nm)).copy()
    previous = np.full((n, n_lines), -1)
    amb = np.zeros((n, n_lines), bool)
    crossed = np.zeros((n, n_lines), bool)
    last_perm = np.broadcast_to(ident, (n_lines, nm)).copy()
    prev = np.zeros_like(v[0])
    start = np.zeros_like(v[0])
    last = np.full(n_lines, -1)
    first = np.full(n_lines, -1)
    for i in order:
        now = ok[i]
        seen = last >= 0
        perm, a = link_check(prev, v[i], crit)
        perm = np.where(seen[:, None], perm, ident)
        perm_all[i, now] = perm[now]
        amb[i] = now & seen & a
        crossed[i] = now & seen & np.any(perm != last_perm, axis=1)
        last_perm[now] = perm[now]
        previous[i, now] = last[now]
        cur = np.take_along_axis(v[i], perm[:, None, :], axis=2)
        fresh = now & ~seen
        start[fresh] = cur[fresh]
        first[fresh] = i
        prev[now] = cur[now]
        last[now] = i
    closing = np.zeros(n_lines, bool)
    closing_crossed = np.zeros(n_lines, bool)
    open_loop = np.zeros(n_lines, bool)
    if closed:
        back, a = link_check(prev, start, crit)
        both = (last >= 0) & (last != first)
        open_loop = both & np.any(back != ident, axis=1)
        closing = both & a
        closing_crossed = both & ~open_loop & np.any(last_perm != ident, axis=1)
    return Walk(perm_all, previous, amb, crossed, closing, closing_crossed, open_loop, last, first)


def lines(x: np.ndarray, n_before: int = 1) -> np.ndarray:
    """Merge the (speed, case) axes after the first ``n_before`` axes into one line axis."""
    s = x.shape
    return x.reshape(s[:n_before] + (s[n_before] * s[n_before + 1],) + s[n_before + 2:])


# --------------------------------------------------------------------------- along speed
def track_speeds(freq: np.ndarray, status: np.ndarray, sig: np.ndarray | None,
                 crit: Criteria = Criteria()) -> tuple[np.ndarray, np.ndarray]:
    """Modes followed along crank speed at every (angle, case), for Campbell diagrams.

    Returns ``tracked`` (angle, speed, case, mode), at the lowest speed the sorted order, and
    ``fallback`` (angle, case): lines with an ambiguous or crossing link (nothing is solved in
    between to confirm a crossing), left in sorted order."""
    ok = np.isin(status, converged_codes())
    sorted_f = np.where(ok[..., None], freq, np.nan)
    na, ns, nc, nm = freq.shape
    if sig is None or ns < 2:
        return sorted_f, np.zeros((na, nc), bool)
    f = np.moveaxis(sorted_f, 1, 0)  # (speed, angle, case, mode)
    w = walk(lines(np.moveaxis(ok, 1, 0)), lines(np.moveaxis(sig, 1, 0)), np.arange(ns), False, crit)
    tracked = w.apply(lines(f)).reshape(f.shape)
    fallback = (w.unresolved | w.crossed.any(axis=0)).reshape(na, nc)  # a crossing is not confirmed
    tracked = np.where(fallback[None, :, :, None], f, tracked)
    return np.moveaxis(tracked, 0, 1), fallback


# --------------------------------------------------------------------------- between cases
def match_cases(ref: np.ndarray, other: np.ndarray, crit: Criteria = Criteria()) -> tuple[np.ndarray, np.ndarray]:
    """Modes of ``other`` matched to the modes of ``ref`` at the same points, by MAC.

    ``ref`` and ``other`` are (..., n_sig, n_modes) eigenvector entries. Returns ``perm``
    (..., n_modes), ``other``'s mode perm[..., i] being ``ref``'s mode i, and ``matched``
    (..., n_modes): that match is unambiguous (MAC >= mac_min and a margin of mac_margin over
    the competitors, as for a link along crank angle)."""
    lead, nm = ref.shape[:-2], ref.shape[-1]
    r = ref.reshape((-1,) + ref.shape[-2:])
    o = other.reshape((-1,) + other.shape[-2:])
    perm, clear = scored_match(np.nan_to_num(r), np.nan_to_num(o), crit)
    clear &= np.all(np.isfinite(r), axis=1) & np.all(np.isfinite(o), axis=1)  # a missing mode matches nothing
    return perm.reshape(lead + (nm,)), clear.reshape(lead + (nm,))
