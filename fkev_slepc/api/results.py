"""What :meth:`Study.point <fkev_slepc.api.study.Study.point>` returns: :class:`PointResult`, and
:class:`ModeShape` (one mode at every node)."""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np


from fkev_slepc.archive import reader
from fkev_slepc.solve import modes as _modes
from fkev_slepc.solve.stability import FROZEN_TIME
from fkev_slepc.status import CONVERGED, json_number
from fkev_slepc.model.operators import Model
from fkev_slepc.model.plane import Plane
from fkev_slepc.solve.sensitivity import point_sensitivity, point_solver

__all__ = ["PointResult", "ModeShape"]


@dataclass(frozen=True)
class ModeShape:
    """One mode at one operating point, node by node.

    ``displacement[i]`` is the (x, y, rotation) displacement of node ``i`` in the global frame
    (m, m, rad), complex, scaled to unit largest modulus and phase-aligned so that its real
    part is the shape to draw (gyroscopic modes are complex). Constrained DOFs are 0. Pin
    joints are two nodes (one per link) sharing x, y.
    """

    mode: int  # 1-based
    frequency_hz: float
    eigenvalue: complex
    node_xy: np.ndarray  # (n_node, 2) undeformed positions, m
    displacement: np.ndarray  # (n_node, 3) complex
    node_link: np.ndarray  # (n_node,) link index
    link_names: tuple[str, ...]
    plane: str = "in"  # "out": ``displacement`` is (w, θ_X, θ_Y) per node (docs/theory.md §19)


@dataclass(frozen=True, repr=False)
class PointResult:
    """The outcome of :meth:`~fkev_slepc.api.study.Study.point` at one (crank angle, speed, case).

    Plain data (it pickles): arrays, numbers, strings and the frozen scene tree solved, no live
    model or solver; ``pool_ref`` is a weak reference to the model pool of the study that solved it
    (:mod:`fkev_slepc.api.pool`; not pickled), where :meth:`sensitivity` takes its model while the
    study lives. Arrays have one entry per mode (NaN where fewer modes were found):
    ``eigenvalues`` λ (1/s, the Im λ > 0 member of each pair), ``frequency_hz`` = Im λ / 2π,
    ``pair_error`` the relative residual of each eigenpair (docs/theory.md §10). ``max_real``
    is the largest Re λ over every computed eigenvalue (stability indicator), ``divergent`` the
    positive real eigenvalues (divergence, never frequencies).
    """

    angle_deg: float
    speed_rad_s: float
    case: str
    raw: _modes.PointModes  # the reported modes as the solve stage returns them (arrays)
    title: str
    n_free: int
    kind: str  # the QEP's structure (see model/operators.classify)
    transmission_angle_deg: float  # smallest transmission angle of the dyads (90 ideal, 0 toggle; NaN: none)
    mesh: reader.NodeDofMap  # nodes and DOFs of the model solved, with each node's exact U direction (node_axis)
    node_xy: np.ndarray  # (n_node, 2) undeformed node positions at this crank angle, m
    scene: object  # the Scene solved (frozen data; re-meshed when rel_error planned the mesh)
    cross_check: float | None = None  # largest relative frequency difference vs the other engine
    accuracy: dict | None = None  # with rel_error: the planned element and mesh, and its estimate
    max_pair_error: float = float("nan")  # the engine's acceptance threshold on each reported pair's error
    damping_tol: float = float("nan")  # a mode with damping ratio < -damping_tol is unstable (analysis.damping_tol)
    plane: str = "in"  # "in": the in-plane problem; "out": bending out of the plane and torsion (theory §19)
    pool_ref: weakref.ref | None = field(default=None, compare=False, repr=False)  # the study's ModelPool

    def __getstate__(self) -> dict:
        """The fields but ``pool_ref`` (a weak reference does not pickle; a copy builds its own model)."""
        return {k: v for k, v in vars(self).items() if k != "pool_ref"}

    @property
    def theta_rad(self) -> float:
        return float(np.radians(self.angle_deg))

    eigenvalues = property(lambda self: self.raw.eigenvalue)
    frequency_hz = property(lambda self: self.raw.frequency_hz)
    pair_error = property(lambda self: self.raw.residual)
    max_real = property(lambda self: self.raw.max_real)
    divergent = property(lambda self: self.raw.divergent)
    status = property(lambda self: self.raw.status)
    message = property(lambda self: self.raw.message)
    solver = property(lambda self: self.raw.solver)

    @property
    def damping_ratio(self) -> np.ndarray:
        """-Re λ / |λ| per mode (negative: the mode grows): the engine's value (solve/stability.py)."""
        return self.raw.damping_ratio

    @property
    def converged(self) -> bool:
        """Every requested mode found and every reported pair accepted (pair error at most
        ``max_pair_error`` and within what the matrices' conditioning explains): the
        frequencies are trustworthy. Independent of the stability verdict: ``unstable`` and
        ``divergent`` points are converged."""
        return self.status in CONVERGED

    @property
    def unstable_modes(self) -> list[int]:
        """Modes (1-based) whose damping ratio is below ``-damping_tol``: the flutter verdict."""
        return [int(k) + 1 for k in np.flatnonzero(self.damping_ratio < -self.damping_tol)]

    def __repr__(self) -> str:
        f = ", ".join("—" if not np.isfinite(v) else f"{v:.6g}" for v in self.frequency_hz)
        msg = f" ({self.message})" if self.message else ""
        return (f"PointResult(θ={self.angle_deg:g}°, Ω={self.speed_rad_s:g} rad/s, case {self.case}: "
                f"{self.status.value}{msg}; f = [{f}] Hz; max Re λ = {self.max_real + 0.0:.3g} 1/s)")

    def sensitivity(self, key: str):
        """d f_k/d p and d ζ_k/d p of every reported mode for the numeric scene key ``key``
        (``"links[1].length_m"``, per unit of the key in the scene's units) at this point, from
        the left and right eigenvectors (:mod:`fkev_slepc.solve.sensitivity`).

        Returns
        -------
        fkev_slepc.solve.sensitivity.Sensitivity
            ``frequency_hz``, ``damping_ratio``, ``eigenvalue`` (dλ/dp), ``relative_frequency``
            ((p/f) df/dp); ``as_dict()`` is the JSON of ``fkev point --sensitivity KEY``.

        Examples
        --------
        At rest, with one material and no lumped masses, every frequency scales like sqrt(E):
        1 % stiffer links, 0.5 % higher frequencies.

        >>> from fkev_slepc import load
        >>> r = load(RUNS / "bahgat-willmert-1976.toml").point(10, 0, "structure")
        >>> s = r.sensitivity("link_defaults.youngs_modulus_pa")
        >>> s.relative_frequency.round(6), s.method
        (array([0.5, 0.5, 0.5, 0.5]), 'adjoint')
        """
        if not Plane.parse(self.plane).sensitivities:
            raise ValueError(f"sensitivities are in plane only (this point is plane {self.plane!r})")
        engine = next((m for m in ("dense", "slepc") if self.solver.startswith(m)), "auto")
        solve = point_solver(self.theta_rad, self.speed_rad_s, self.case, len(self.eigenvalues), engine)
        pool = None if self.pool_ref is None else self.pool_ref()
        model = Model(self.scene, cases=(self.case,)) if pool is None else pool.model_for(self.scene, self.case)
        return point_sensitivity(model, self.theta_rad, self.speed_rad_s, self.case, self.eigenvalues, key, solve)

    def mode_shape(self, k: int) -> ModeShape:
        """Mode ``k`` (1-based) at every node; needs ``shapes=True`` in :meth:`~fkev_slepc.api.study.Study.point`.

        Examples
        --------
        >>> from fkev_slepc import load
        >>> r = load(RUNS / "rotating-cantilever.toml").point(0, 0, "structure", modes=1, shapes=True)
        >>> m = r.mode_shape(1)
        >>> m.node_xy.shape, m.displacement.shape      # 16 elements: 17 nodes, (x, y, rotation)
        ((17, 2), (17, 3))
        >>> tip = m.node_xy[:, 0].argmax()             # the strip lies along x: bending moves y,
        >>> abs(m.displacement[:, 1]).argmax() == tip  # most at the free tip
        True
        """
        if self.raw.shapes is None:
            raise ValueError("no mode shapes: solve the point with shapes=True")
        n = self.raw.shapes.shape[1]
        if not 1 <= k <= n:
            raise ValueError(f"mode: must be 1..{n} (got {k})")
        from fkev_slepc.plots.shapes import align_phase, node_displacement

        q = align_phase(self.raw.shapes[:, k - 1], None)
        if Plane.parse(self.plane).transverse:  # the out-of-plane DOFs (θ_X, θ_Y, w) -> (w, θ_X, θ_Y)
            disp = node_displacement(self.mesh, q)[:, [2, 0, 1]]
        else:  # a slider node's translational DOF runs along its guide (mesh.node_axis) -> x, y
            disp = node_displacement(self.mesh, q, self.mesh.node_axis)
        return ModeShape(k, float(self.frequency_hz[k - 1]), complex(self.eigenvalues[k - 1]), self.node_xy, disp,
                         self.mesh.node_link, self.mesh.link_names, self.plane)

    def plot(self, modes=None):
        """Mode shapes on the undeformed linkage (a matplotlib Figure; needs ``shapes=True``)."""
        if self.raw.shapes is None:
            raise ValueError("no mode shapes to plot: solve the point with shapes=True")
        from fkev_slepc.plots.shapes import archived_guides, shapes_figure

        mesh, xy = self.mesh, self.node_xy  # the exact node axes, as mode_shape() uses them
        picked = list(range(len(self.frequency_hz))) if modes is None else [int(m) - 1 for m in modes]
        heading = (f"{self.title}\nmode shapes at θ = {self.angle_deg:g}°, Ω = {self.speed_rad_s:g} rad/s, "
                   f"case {self.case}")
        if Plane.parse(self.plane).transverse:  # w along the links, the twist marked (plots/out_of_plane.py)
            from fkev_slepc.plots.out_of_plane import out_of_plane_figure

            return out_of_plane_figure(mesh, xy, self.raw.shapes, self.frequency_hz, picked, heading)
        return shapes_figure(mesh, xy, [(self.case, self.raw.shapes, self.frequency_hz)], picked, heading,
                             guide_lines=archived_guides(mesh, xy, mesh.node_axis), axes_dof=mesh.node_axis)

    def as_dict(self) -> dict:
        """JSON-ready summary (None for missing values), as ``fkev point --json`` prints it."""
        def num(v):
            x = json_number(v)
            return None if x is None else x + 0.0  # + 0.0: no -0.0 (an exact zero Re λ)

        out = {"scene": self.title, "angle_deg": self.angle_deg, "speed_rad_s": self.speed_rad_s,
               "case": self.case, "plane": self.plane, "n_free": self.n_free, "kind": self.kind, "solver": self.solver,
               "frequency_hz": [num(v) for v in self.frequency_hz],
               "eigenvalue": [[num(z.real), num(z.imag)] for z in self.eigenvalues],
               "residual": [num(v) for v in self.pair_error],
               "damping_ratio": [num(v) for v in self.damping_ratio],
               "max_real": num(self.max_real), "divergent": [float(v) for v in self.divergent],
               "stability_scope": {"divergence": self.raw.divergence_check,
                                   "flutter": f"modes 1-{len(self.frequency_hz)} (damping ratio of the reported modes)",
                                   "time": FROZEN_TIME},
               "status": self.status.value, "message": self.message,
               # what the status combines, apart: the pairs' acceptance (accuracy) and stability
               "pairs_accepted": self.converged, "max_pair_error": num(self.max_pair_error),
               "unstable_modes": self.unstable_modes,
               "transmission_angle_deg": num(self.transmission_angle_deg),
               "element": self.scene.analysis.element,
               "elements": [lk.elements for lk in self.scene.links]}
        if self.accuracy is not None:
            out["rel_error_estimate"] = self.accuracy["predicted_rel_error"]
            out["accuracy"] = self.accuracy
        if self.cross_check is not None:
            out["cross_check_max_rel_diff"] = self.cross_check
        return out
