"""The sweep over crank angle × speed × case: distribution over ranks, continuation, tracking.

**Unit of work: one crank angle** (the unit axes of :data:`fkev_slepc.archive.products.SWEEP`).
Points are numbered in C order over (angle, speed, case) (:meth:`archive.products.Grid.index`,
``np.unravel_index``), and the angles that still hold points to solve are dealt cyclically to
the ranks by :func:`fkev_slepc.sweep.units.run_units`, one angle per rank per round, in equal
rounds so that the collective flushes of :class:`archive_writer.Writer` line up.
Every angle carries the same mix of cases, so rounds cost the same on every rank although
cases differ in cost (a cyclic split of single points would give one rank every expensive
case). Inside an angle the operator pieces are assembled once, the ``structure`` case (which
does not depend on speed) is solved once and copied to every speed, and so is the motionless
problem (Ω = 0 without crank acceleration: every case is the structure, docs/theory.md §11);
the other points are solved speed by speed.

**Continuation.** The engine ``hint`` (|λ| of the lowest mode) of point (θ, Ω_j, case) is
|λ1| of (θ, Ω_{j-1}, case), or of the structure at θ for the first speed. It comes only from
points of the same angle, which one rank solves in a fixed order, so a point gets the same
hint on any number of ranks and after a resume (the hint then comes from the archive, where
|λ1| was stored exactly): results do not depend on the rank count.

**Tracking** (:mod:`fkev_slepc.sweep.tracking`). Modes are followed by MAC after the sweep, from
eigenvector entries at up to ``tracking.TRACK_DOFS`` free DOFs stored per point in the archive
(``/tracking/signature``), so tracking does not need neighbouring angles on the same rank and
survives a resume. Eigenvectors are therefore computed for every point when the sweep has more
than one angle or speed. :meth:`Sweep.solve_samples` solves the extra angles tracking asks for.

**Failures.** ``PETSc.Error``, ``LinAlgError`` and ``FloatingPointError`` raised while solving
a point mark it ``failed`` with the message; any other exception is a bug and propagates
(``parallel.install_abort_hook`` then aborts every rank).
"""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass

import numpy as np

from fkev_slepc.archive import products as P
from fkev_slepc.archive.products import Grid
from fkev_slepc.archive.store import modulus
from fkev_slepc.archive.writer import Block, Writer
from fkev_slepc.model.operators import AssemblyError
from fkev_slepc.solve.modes import CNAN, PointModes, failed, postprocess
from fkev_slepc.scene import DAMPING_TOL, IMAG_TOL
from fkev_slepc.status import CONVERGED, RETRYABLE
from fkev_slepc.sweep.tracking import signature_weight
from fkev_slepc.sweep.tracking_angles import Samples
from fkev_slepc.sweep.units import assign, run_units  # noqa: F401 (assign: part of the sweep API)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SweepOptions:
    """What to compute at each point (thresholds as in the scene's ``[analysis]``)."""

    n_modes: int
    imag_tol: float = IMAG_TOL
    damping_tol: float = DAMPING_TOL
    mode_shapes: bool = False
    tracking_dofs: np.ndarray | None = None  # None: no tracking (a single angle)

    @property
    def want_vectors(self) -> bool:
        return self.mode_shapes or self.tracking_dofs is not None


def recoverable_errors() -> tuple[type[BaseException], ...]:
    """Exceptions that mark a point failed instead of stopping the sweep."""
    errs: list[type[BaseException]] = [np.linalg.LinAlgError, FloatingPointError]
    petsc = sys.modules.get("petsc4py.PETSc")  # only if an engine already uses PETSc
    if petsc is not None:
        errs.append(petsc.Error)
    return tuple(errs)


class Sweep:
    """Solve the points of ``todo`` on this rank and hand them to ``writer``.

    Parameters
    ----------
    model : operators.Model of the scene (built with the grid's cases).
    grid : archive.Grid.
    engine : an :class:`~fkev_slepc.solve.protocol.Engine`.
    writer : archive_writer.Writer of this rank.
    opts : SweepOptions.
    lam1 : (angle, speed, case) |λ1| of the points already in the archive (NaN elsewhere).
    """

    def __init__(self, model, grid: Grid, engine, writer: Writer, opts: SweepOptions, lam1: np.ndarray):
        self.model, self.grid, self.engine, self.writer, self.opts = model, grid, engine, writer, opts
        self.lam1 = np.array(lam1, dtype=float, copy=True)
        self._errors = recoverable_errors()

    def run(self, todo: np.ndarray, comm, progress=None, stop=None) -> int:
        """Collective over ``comm``. Returns the number of points solved by all ranks.

        ``stop`` (:class:`~fkev_slepc.sweep.interrupt.StopRequest`): polled at every sync; when
        any rank was signalled, every rank leaves after that sync (the points synced so far
        are in the archive) and ``stop.stopped`` is set."""
        return run_units(todo, lambda unit, mask: self.solve_angle(unit[0], mask), self.writer, comm,
                         progress=progress, stop=stop)

    def solve_angle(self, ia: int, todo: np.ndarray) -> Block:
        """Solve the points of crank angle ``ia`` marked in ``todo`` (speed, case)."""
        theta = float(np.radians(self.grid.angles_deg[ia]))
        results, weight = self._solve_at(theta, todo, self.lam1[ia])
        return self._block(ia, todo, results, self.model.node_positions(theta) if self.opts.mode_shapes else None,
                           weight)

    def solve_samples(self, angle_deg: float, todo: np.ndarray) -> Samples:
        """Solve the (speed, case) points of ``todo`` at an angle off the grid, for tracking
        (:func:`tracking.refine_angles`); nothing is written. Hints come from this angle only."""
        lam1, weight = np.full(todo.shape, np.nan), None
        try:
            results, weight = self._solve_at(float(np.radians(angle_deg)), todo, lam1)
        except AssemblyError as exc:  # cannot happen between two assembled grid angles, but never guess
            results = {tuple(i): failed(self.opts.n_modes, str(exc)) for i in np.argwhere(todo)}
        b = self._block(-1, todo, results, None, weight)
        sig = b.data.get(P.SIGNATURE.path)
        return Samples(np.array([float(angle_deg)]), b.data[P.FREQUENCY.path][None], b.status[None],
                       None if sig is None else sig[None], b.data[P.EIGENVALUE.path][None])

    def _solve_at(self, theta: float, todo: np.ndarray, lam1: np.ndarray) -> tuple[dict, np.ndarray | None]:
        """Results {(speed, case): PointModes} of the points of ``todo`` at crank angle
        ``theta`` (rad), and the weights of their tracked eigenvector entries
        (:func:`tracking.signature_weight`); ``lam1`` (speed, case) holds and receives the |λ1| hints."""
        grid, model = self.grid, self.model
        pieces = model.pieces(theta)
        weight = signature_weight(model.plane, pieces.mass_matrix.diagonal(), self.opts.tracking_dofs)
        results: dict[tuple[int, int], PointModes] = {}
        cases = list(grid.cases)
        struct_lam1 = np.nan
        still = None  # the motionless problem (Ω = 0, no crank acceleration): every case is the structure
        if "structure" in cases:
            jc = cases.index("structure")
            need = np.flatnonzero(todo[:, jc])
            if need.size:  # independent of speed: solve once, store at every speed
                still = self._solve(model.qep(pieces, float(grid.speeds[0]), "structure"), None, (theta, 0, jc))
                for js in need:
                    self._keep(results, lam1, (js, jc), still)
            known = lam1[:, jc][np.isfinite(lam1[:, jc])]
            struct_lam1 = known[0] if known.size else np.nan
        static = model.scene.driver.acceleration == 0.0
        for js, speed in enumerate(grid.speeds):
            motionless = static and speed == 0.0  # docs/theory.md §11: no motion term left
            batch, copies = [], []  # (case index, QEP, hint) to solve; cases that copy `still`
            for jc, case in enumerate(cases):
                if case == "structure" or not todo[js, jc]:
                    continue
                if motionless and (still is not None or batch):
                    copies.append(jc)
                    continue
                prev = lam1[js - 1, jc] if js > 0 else np.nan
                hint = prev if np.isfinite(prev) else struct_lam1
                batch.append((jc, model.qep(pieces, float(speed), case), float(hint) if np.isfinite(hint) else None))
            solved = self._solve_many(batch, theta, js)
            for (jc, _, _), res in zip(batch, solved):
                self._keep(results, lam1, (js, jc), res)
            if motionless and still is None and solved:
                still = solved[0]
            for jc in copies:
                self._keep(results, lam1, (js, jc), still)
        return results, weight

    def _solve_many(self, batch: list, theta: float, js: int) -> list[PointModes]:
        """Results of the (case index, QEP, hint) of one speed: in one call of an engine that
        batches problems (the dense engine's ``solve_many``), else point by point; a batch
        that raises is solved again point by point, so that a failure marks only its own point."""
        if len(batch) > 1:
            o = self.opts
            try:
                sols = self.engine.solve_many([q for _, q, _ in batch], o.n_modes, o.want_vectors,
                                              [h for _, _, h in batch])
                return [self._postprocess(sol) for sol in sols]
            except self._errors:
                pass
        return [self._solve(q, hint, (theta, js, jc)) for jc, q, hint in batch]

    def _postprocess(self, sol) -> PointModes:
        o = self.opts
        return postprocess(sol, o.n_modes, o.imag_tol, o.damping_tol, want_shapes=o.want_vectors)

    def _solve(self, qep, hint, where) -> PointModes:
        o = self.opts
        try:
            return self._postprocess(self.engine.solve(qep, o.n_modes, want_vectors=o.want_vectors, hint=hint))
        except self._errors as exc:
            theta, s, c = where
            log.warning("point (%g deg, %g rad/s, %s) failed: %s: %s", np.degrees(theta),
                        self.grid.speeds[s], self.grid.cases[c], type(exc).__name__, exc)
            return failed(o.n_modes, f"{type(exc).__name__}: {exc}", self.engine.name)

    @staticmethod
    def _keep(results, lam1, index, res: PointModes) -> None:
        results[index] = res
        lam = float(modulus(res.eigenvalue[:1])[0]) if res.eigenvalue.size else np.nan
        lam1[index] = lam if res.status in CONVERGED else np.nan

    def _block(self, ia, todo, results, node_xy, weight=None) -> Block:
        """Stack one angle's results into (speed, case, ...) arrays (fill values where not solved),
        one per per-point dataset of the sweep product that this run has (the table's ``source``
        names the :class:`PointModes` field, ``rows`` the tracked DOFs of an eigenvector, scaled
        by ``weight`` when given)."""
        o, (ns, nc) = self.opts, todo.shape
        sizes = {P.MODE: o.n_modes, P.FREE_DOF: self.model.n_free,
                 P.DOFS: 0 if o.tracking_dofs is None else len(o.tracking_dofs)}
        needs = {"", *(("signatures",) if o.tracking_dofs is not None else ()),
                 *(("shapes",) if o.mode_shapes else ())}
        rows = [v for v in P.SWEEP.per_point() if v.needs in needs and v.path != P.SWEEP.status]
        data = {v.path: np.full((ns, nc) + tuple(sizes[d] for d in v.dims[3:]), v.fill, dtype=v.dtype) for v in rows}
        status = np.zeros((ns, nc), dtype=np.uint8)
        errors = []
        for (js, jc), r in results.items():
            for v in rows:
                value = getattr(r, v.source)
                if v.rows is not None:  # the tracked DOFs of each eigenvector (only with vectors)
                    if value is None:
                        continue
                    value = value[o.tracking_dofs]
                    if weight is not None:
                        value = value * weight[:, None]
                elif value is None:
                    continue
                data[v.path][js, jc] = value
            status[js, jc] = r.status.code
            if r.status in RETRYABLE:
                errors.append(((ia, js, jc), r.status.code, r.message))
        return Block(ia, np.asarray(todo, bool), data, status, errors, node_xy)
