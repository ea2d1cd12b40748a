"""The periodic response on the link-frame component basis q = W(θ) z (docs/response.md §3.1,
docs/theory.md §18.8).

The Galerkin projection of M q̈ + C q̇ + K q = f on the Craig–Bampton basis W(θ) of
fkev_slepc/periodic/components.py is the one the Floquet reduction takes
(:func:`fkev_slepc.periodic.reduce.reduced_coefficients`, the W', W'' terms included, through
:class:`~fkev_slepc.periodic.system.PeriodicSystem` with ``basis``) with the load Wᵀ f:

    M_r z̈ + C_r ż + K_r z = W(θ)ᵀ f(θ),

solved by the harmonic balance of fkev_slepc/periodic/harmonic_balance.py on R = n_b + Σ k_j unknowns
per harmonic instead of n. The response is q = W(θ) z(θ) + Δq(θ) at any angle, Δq the **static
correction of the dropped interior modes** of each link j (its residual flexibility under the
load's interior part, in the link's frame x̂ = R_j f):

    Δx̂_j = (K_ii⁻¹ − Φ_k Λ_k⁻¹ Φ_kᵀ) f̂_i,       Λ_k = diag(ω_k²) of the k kept modes,

zero when every mode is kept (then W is square and the projection a change of variables: the
full model). Modes above the kept ones respond quasi-statically to a load whose harmonics lie far
below their frequencies: the correction removes the leading truncation error of stresses under
inertial loads (measured in docs/engine.md).

**Truncation** (:func:`converged_response`): the modes per link double from ``link_modes`` (the
rule of fkev_slepc/periodic/truncation.py; the harmonics of the first level, doubled to ``tol``,
are kept for the next ones) until the whole-link elastic stress (σ₊, σ₋ at every
element end; the bending moment where a section has no fibre distance) and the node deflections
at ``MEASURE_ANGLES`` angles change by at most ``RESPONSE_REDUCE_TOL`` (relative to their peak)
for two successive pairs of levels; the result carries the larger of the two pairs' changes and
the frequency range its modes cover (``covered_rad_s``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.periodic.components import LINK_MODES, frame_rows, link_components
from fkev_slepc.periodic.harmonic_balance import MAX_UNKNOWNS, HarmonicResponse, harmonic_balance
from fkev_slepc.periodic.ladder import climb
from fkev_slepc.periodic.settings import DEFAULTS, resolve_reduce

RESPONSE_REDUCE_TOL = 1e-3  # relative change of stress and deflection that ends the doubling
MEASURE_ANGLES = 72  # crank angles (every 5°) at which two levels are compared
CHUNK = 64  # crank angles whose full-mesh periodic pieces are held at once
FULL_MAX_DOFS = DEFAULTS.full_max_dofs  # reduce="default": the full model up to this many free DOFs (docs/engine.md)


class ProjectedSystem:
    """The reduced system of ``system`` (a PeriodicSystem) on ``basis`` (a LinkBasis): ``mck``
    and ``load`` for the response solvers, ``lift`` back to the global DOFs."""

    def __init__(self, system, basis, correct: bool = True):
        self.full, self.basis = system, basis
        self.reduced = system.on(basis)
        self.correction = StaticCorrection(basis) if correct else None

    def mck(self, theta):
        """Reduced (M, C, K) at the crank angles, ``CHUNK`` angles at a time (the periodic pieces of
        the full mesh are held for one chunk only)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        parts = [self.reduced.mck(theta[i:i + CHUNK]) for i in range(0, theta.size, CHUNK)]
        return tuple(np.concatenate(x) for x in zip(*parts))

    def _each(self, theta):
        """(W, W') at each crank angle, one angle at a time (a stack would hold k·n·R numbers)."""
        kin = solve_kinematics(self.full.model.mechanism, theta)
        for i in range(theta.size):
            yield self.basis.at(kin.phi[i], kin.dphi[i], kin.ddphi[i])[:2]

    def load(self, theta) -> np.ndarray:
        """Wᵀ f (k, R): the reduced system's load."""
        return self.reduced.load(theta)

    def lift(self, theta, z, dz=None):
        """q = W z + Δq (k, n) at the crank angles, and dq/dθ = W z' + W' z given z' (Δq' left out)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        pairs = list(self._each(theta))
        q = np.stack([W @ z[i] for i, (W, _) in enumerate(pairs)])
        if self.correction is not None:
            q = q + self.correction(self.full.model, theta, self.full.load(theta))
        if dz is None:
            return q
        return q, np.stack([W @ dz[i] + W1 @ z[i] for i, (W, W1) in enumerate(pairs)])


class StaticCorrection:
    """Δq(θ) of the dropped fixed-interface modes (module docstring), link by link."""

    def __init__(self, basis):
        self.links = []
        for c, k in zip(basis.comp.links, basis.keep):
            if not c.size or k >= c.size:
                continue
            Phi, lam = c.modes[:, :k], c.freq[:k] ** 2
            G = np.linalg.inv(c.stiffness[0]) - (Phi / lam) @ Phi.T
            self.links.append((c, 0.5 * (G + G.T)))

    def __call__(self, model, theta, f) -> np.ndarray:
        """Δq (k, n) under the loads ``f`` (k, n) at the crank angles ``theta`` (k,)."""
        out = np.zeros_like(f)
        if not self.links:
            return out
        phi = solve_kinematics(model.mechanism, theta).phi
        for c, G in self.links:
            for i in range(theta.size):
                f_hat = frame_rows(f[i, c.rows][:, None], c.pair, -phi[i, c.link], 0)
                out[i, c.rows] = frame_rows(G @ f_hat, c.pair, phi[i, c.link], 0)[:, 0]
        return out


@dataclass(frozen=True)
class LiftedResponse:
    """The response of a projected system in the global DOFs (the interface of
    :class:`~fkev_slepc.periodic.harmonic_balance.HarmonicResponse`: ``theta``, ``q``, ``dq``,
    ``harmonics`` (of z), ``error``, ``condition``, ``levels``, ``abandoned``, ``at``)."""

    z: HarmonicResponse
    system: ProjectedSystem

    def __getattr__(self, name):  # theta, harmonics (of z), error, condition, levels, abandoned: those of z
        if name in ("theta", "harmonics", "error", "condition", "levels", "abandoned"):
            return getattr(self.z, name)
        raise AttributeError(name)

    @property
    def q(self):
        return self.at(self.z.theta)

    @property
    def dq(self):
        return self.system.lift(self.z.theta, self.z.q, self.z.dq)[1]

    def at(self, theta) -> np.ndarray:
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        return self.system.lift(theta, self.z.at(theta))


@dataclass(frozen=True)
class ResponseTruncation:
    """The truncation of a component-basis response, measured by doubling the modes per link."""

    stress: float  # max |Δσ| / max |σ| of the elastic whole-link stress (moment without c)
    deflection: float  # max |Δq| / max |q|
    converged: bool
    tol: float
    modes_per_link: int
    covered_rad_s: float  # highest retained fixed-interface frequency
    basis: int  # R, the reduced unknowns per harmonic
    levels: tuple = ()  # (modes per link, R, stress change, deflection change) from the second level

    @property
    def value(self) -> float:
        return float(max(self.stress, self.deflection))

    def as_dict(self) -> dict:
        return {"stress": self.stress, "deflection": self.deflection, "converged": self.converged,
                "tol": self.tol, "modes_per_link": self.modes_per_link, "covered_rad_s": self.covered_rad_s,
                "basis": self.basis, "levels": [list(x) for x in self.levels]}


def response_reduction(model, value, full_max_dofs: int = FULL_MAX_DOFS) -> str | None:
    """None (the full model), "links" or "links:N" from what a user asked (None, "none",
    "default", "links", "links:N"; :func:`~fkev_slepc.periodic.settings.resolve_reduce`: None is not
    given, the default): "default" is the full model up to ``full_max_dofs`` free DOFs
    (``PeriodicSettings.full_max_dofs``; docs/engine.md measures why), else "links". ValueError naming
    the accepted values otherwise."""
    try:
        v = resolve_reduce(value)  # the one resolver: None is not given, the default
    except ValueError:
        v = "bad"
    if v == "default":
        return None if model is None else None if int(model.n_free) <= full_max_dofs else "links"
    if v is None or (isinstance(v, str) and v.startswith("links")):
        return v
    raise ValueError(f"must be default, none, links or links:N (modes per link >= 0) (got {value!r})")


def _interior_sizes(mech) -> tuple[int, list[int]]:
    """(boundary DOFs, interior DOFs per link) from the mesh alone (no eigenproblem)."""
    from fkev_slepc.periodic.components import boundary_dofs

    bnd = boundary_dofs(mech)
    d = mech.elem_dofs
    sizes = []
    for j in range(mech.n_link):
        used = np.unique(d[mech.elem_link == j])
        sizes.append(int((~bnd[used[used >= 0]]).sum()))
    return int(bnd.sum()), sizes


def first_level_size(model, mode: str, link_modes: int = LINK_MODES) -> int:
    """R of the first component level of ``mode`` ("links": ``link_modes`` per link, "links:N": N)."""
    k = link_modes if mode == "links" else int(mode[6:])
    n_b, sizes = _interior_sizes(model.mechanism)
    return n_b + sum(min(k, n) for n in sizes)


def memory_estimate(mech, mode: str, harmonics=None) -> float:
    """Bytes a component-basis response of ``mech`` needs at most (docs/engine.md, "Periodic response
    on link components"): 24·S² for the harmonic balance's real block matrix, its assembly and LU
    (S = (2H + 1)·R: for "links" the bound ``MAX_UNKNOWNS`` the levels double up to; for "links:N" R
    of the 2N level it is measured against and H = ``harmonics``, else the last H the doubling from 8
    can reach, to 256), ~3 copies of the six periodic pieces at ``CHUNK`` angles (9 nonzeros per DOF),
    and 6 dense n_j² arrays per link interior (K_ii, M_ii, K_ib, the static-correction flexibility,
    the modes, eigh's workspace)."""
    n_b, sizes = _interior_sizes(mech)
    if mode == "links":
        S = MAX_UNKNOWNS
    else:
        R = n_b + sum(min(2 * int(mode[6:]), n) for n in sizes)
        H = 16 if harmonics is None else int(harmonics)
        while harmonics is None and 2 * H <= 256 and (4 * H + 1) * R <= MAX_UNKNOWNS:
            H *= 2
        S = min((2 * H + 1) * R, MAX_UNKNOWNS)
    return float(24 * S**2 + 3 * 6 * 8 * 9 * mech.n_free * CHUNK + 6 * 8 * sum(n * n for n in sizes))


MEMORY_LIMIT = 8e9  # bytes: a component-basis response estimated above is refused (memory_problem)


def memory_problem(mech, reduce, harmonics=None) -> str | None:
    """"full" where ``reduce`` resolves to the full model (the periodic DOF limit applies), None
    where the component basis fits in ``MEMORY_LIMIT`` by :func:`memory_estimate`, else the refusal."""
    mode = response_reduction(mech, reduce)
    if mode is None:
        return "full"
    need = memory_estimate(mech, mode, harmonics)
    if need <= MEMORY_LIMIT:
        return None
    n_b, sizes = _interior_sizes(mech)
    return (f"{mech.n_free} free DOFs on link components (largest link interior {max(sizes)} DOFs, held densely) "
            f"need about {need / 1e9:.3g} GB, past the limit of {MEMORY_LIMIT / 1e9:g} GB: use fewer --elements")


def component_response(system, omega: float, modes: int, *, harmonics=None, tol: float = 1e-10,
                       correct: bool = True) -> LiftedResponse:
    """The response on ``modes`` fixed-interface modes per link (all of a link's at most)."""
    basis = link_components(system.model).basis(int(modes))
    proj = ProjectedSystem(system, basis, correct)
    return LiftedResponse(harmonic_balance(proj.mck, proj.load, omega, harmonics=harmonics, tol=tol), proj)


def changes(model, coarse: LiftedResponse, fine: LiftedResponse, speed=None) -> tuple[float, float]:
    """(stress, deflection) relative changes from ``coarse`` to ``fine`` at ``MEASURE_ANGLES`` angles;
    the stresses by the shape functions, or with the crank ``speed`` (rad/s; what a Timoshenko model
    needs, periodic/stations.py) by each element's equilibrium."""
    from fkev_slepc.periodic.stations import element_end_stations, station_response

    theta = 2.0 * np.pi * np.arange(MEASURE_ANGLES) / MEASURE_ANGLES
    qa, qb = coarse.at(theta), fine.at(theta)
    ends = element_end_stations(model.mechanism)
    sa, sb = (station_response(model, theta, q, ends, speed=speed) for q in (qa, qb))
    keys = ("stress_plus", "stress_minus") if np.isfinite(sb.stress).all() else ("moment",)
    xa = np.concatenate([getattr(sa, k) for k in keys], axis=1)
    xb = np.concatenate([getattr(sb, k) for k in keys], axis=1)
    rel = lambda a, b: float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))  # noqa: E731
    return rel(xa, xb), rel(qa, qb)


def converged_response(system, omega: float, *, modes: int | None = None, harmonics=None, tol: float = 1e-10,
                       reduce_tol: float = RESPONSE_REDUCE_TOL, correct: bool = True, link_modes: int = LINK_MODES):
    """(LiftedResponse, ResponseTruncation) on the one reduction ladder (fkev_slepc/periodic/ladder.py):
    ``modes`` per link measured against 2·modes, or (``modes`` None) doubled from ``link_modes`` until
    converged (module docstring) or every interior mode is kept (then the full model: truncation zero);
    a level whose harmonic balance would pass ``MAX_UNKNOWNS`` is not solved (stated unconverged)."""
    comp = link_components(system.model)
    top = int(comp.interior.max(initial=0))
    first = {}

    def solve(k):  # the next levels at the H the first one reached: no doubling of H again
        res = component_response(system, omega, k, harmonics=first.get("H", harmonics), tol=tol, correct=correct)
        first.setdefault("H", harmonics if harmonics is not None else res.harmonics.shape[0] - 1)
        return res

    def levels():
        k = link_modes if modes is None else int(modes)
        yield k
        while k < top:
            k = min(2 * k, top) if k else 1
            yield k

    def fits(k, prev):
        return (2 * max(prev.harmonics.shape[0] - 1, 16) + 1) * comp.basis(k).shape[1] <= MAX_UNKNOWNS

    speed = None if system.model.stacks.shear_parameter is None else omega  # Timoshenko: equilibrium stresses
    c = climb(levels(), solve, lambda a, b: changes(system.model, a, b, speed), reduce_tol, whole=lambda k: k >= top,
              fits=fits, fixed=modes is not None)
    steps = tuple((k, r.system.basis.shape[1], *m) for k, r, m in c.rungs[1:])
    ds, dd = (0.0, 0.0) if c.exact else c.changes or (np.inf, np.inf)
    return c.result, _truncation(c.result, c.level, ds, dd, c.converged, reduce_tol, steps)


def _truncation(res: LiftedResponse, k, ds, dd, ok, tol, levels) -> ResponseTruncation:
    b = res.system.basis
    return ResponseTruncation(float(ds), float(dd), bool(ok), float(tol), int(k), b.covered_rad_s, b.shape[1],
                              tuple(levels))
