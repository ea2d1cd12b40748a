"""Building blocks of the stress campaigns (scripts/stress.py): scenes, the conditioning floor,
and the dense-vs-SLEPc judgement of one point. Not part of the package."""

from __future__ import annotations

import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import scipy.sparse as sp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fkev_slepc.scene import Analysis, Driver, Joint, Link, LinkEnd, LumpedMass, Scene  # noqa: E402

EPS = np.finfo(float).eps
FLOOR_FACTOR = 10.0  # dense and SLEPc must agree within this multiple of the conditioning floor
STEEL = dict(youngs_modulus=2.07e11, density=7760.0)


def four_bar(lengths, ground, sections, elements, masses=(), speed=0.0, accel=0.0, angle=10.0,
             case="full", modes=4, props=STEEL) -> Scene:
    """A crank-rocker O1-A-B-O2 (crank, coupler, follower; ground pivots on the x axis)."""
    names = ("crank", "coupler", "follower")
    links = tuple(Link(n, L, props["youngs_modulus"], props["density"], A, I, e)
                  for n, L, (A, I), e in zip(names, lengths, sections, elements))
    joints = (Joint("O1", "revolute", (LinkEnd("crank", "root"),), (0.0, 0.0)),
              Joint("A", "revolute", (LinkEnd("crank", "tip"), LinkEnd("coupler", "root"))),
              Joint("B", "revolute", (LinkEnd("coupler", "tip"), LinkEnd("follower", "tip"))),
              Joint("O2", "revolute", (LinkEnd("follower", "root"),), (ground, 0.0)))
    ms = tuple(LumpedMass(j, lk, m) for j, lk, m in masses)
    return Scene("stress four-bar", links, joints, Driver("crank", (speed,), accel), ms,
                 Analysis((angle,), (case,), modes))


def scale_units(scene: Scene, length: float, mass: float) -> Scene:
    """The same scene in another consistent unit system (seconds kept): ``length`` and ``mass``
    are the new units in metres and kilograms (mm-t-s: 1e-3, 1e3)."""
    E_unit, rho_unit = mass / length, mass / length**3  # N/m² = kg/(m s²); kg/m³
    links = tuple(replace(lk, length=lk.length / length, area=lk.area / length**2,
                          second_moment=lk.second_moment / length**4, youngs_modulus=lk.youngs_modulus / E_unit,
                          density=lk.density / rho_unit) for lk in scene.links)
    joints = tuple(replace(j, ground=None if j.ground is None else (j.ground[0] / length, j.ground[1] / length))
                   for j in scene.joints)
    masses = tuple(replace(m, mass=m.mass / mass) for m in scene.masses)
    return replace(scene, links=links, joints=joints, masses=masses)


def _perturbed(A, u):
    """A with every stored entry changed by one unit in the last place (relative), by a sign
    symmetric in (i, j), so a symmetric K stays symmetric and a skew C skew."""
    if A is None:
        return None
    c = A.tocoo()
    sign = np.where(np.sin(1e4 * u[c.row] * u[c.col] + u[c.row] + u[c.col]) >= 0, 1.0, -1.0)
    return sp.csr_matrix((c.data * (1.0 + EPS * sign), (c.row, c.col)), shape=A.shape)


def perturb(qep, rng):
    """The QEP with every matrix entry perturbed by one ulp (relative), symmetry kept."""
    from fkev_slepc.model.qep import QEP

    u = rng.random(qep.n)
    return QEP(_perturbed(qep.mass, u), _perturbed(qep.damping, u), _perturbed(qep.stiffness, u), qep.kind)


def rel_diff(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    good = np.isfinite(a) & np.isfinite(b)
    if not good.any():
        return np.nan
    return float(np.max(np.abs(a[good] - b[good]) / np.maximum(np.abs(b[good]), np.finfo(float).tiny)))


@dataclass
class Tally:
    """Counts of a campaign, printed as one line per counter."""

    name: str
    counts: dict = field(default_factory=dict)
    worst: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    def add(self, key: str, n: int = 1) -> None:
        self.counts[key] = self.counts.get(key, 0) + n

    def high(self, key: str, value: float) -> None:
        if np.isfinite(value):
            self.worst[key] = max(self.worst.get(key, -np.inf), float(value))

    def report(self) -> str:
        lines = [f"[{self.name}]"]
        lines += [f"  {k}: {v}" for k, v in self.counts.items()]
        lines += [f"  max {k}: {v:.2e}" for k, v in self.worst.items()]
        lines += [f"  note: {n}" for n in self.notes[:10]]
        return "\n".join(lines)


class Judge:
    """Solves one QEP with both engines and measures its conditioning floor."""

    def __init__(self, n_modes: int, seed: int = 0, n_perturb: int = 2):
        from fkev_slepc.solve.dense import DenseEngine
        from fkev_slepc.solve.slepc import SlepcEngine

        self.n_modes, self.n_perturb = n_modes, n_perturb
        self.dense, self.slepc = DenseEngine(), SlepcEngine()
        self.rng = np.random.default_rng(seed)

    def close(self):
        self.slepc.close()

    def __call__(self, qep, tally: Tally, label: str = "", hint=None) -> dict:
        from fkev_slepc.solve.modes import postprocess

        n = self.n_modes
        rd = postprocess(self.dense.solve(qep, n), n)
        rs = postprocess(self.slepc.solve(qep, n, hint=hint), n)
        out = {"dense": rd, "slepc": rs}
        tally.add("points")
        ok_d, ok_s = _conv(rd), _conv(rs)
        tally.add("converged (both engines)" if ok_d and ok_s else "flagged by an engine (not converged)")
        if rd.status == rs.status:
            tally.add("status agrees")
        else:
            tally.add("status differs")
            tally.notes.append(f"{label}: status dense {rd.status.value} vs slepc {rs.status.value} "
                               f"(max Re λ {rd.max_real:.3g} / {rs.max_real:.3g}; {rs.message or rd.message})")
        if not (ok_d and ok_s):
            return out
        floor = 0.0
        for _ in range(self.n_perturb):
            rp = postprocess(self.dense.solve(perturb(qep, self.rng), n), n)
            floor = max(floor, rel_diff(rp.frequency_hz, rd.frequency_hz))
        floor = max(floor, EPS)
        diff = rel_diff(rd.frequency_hz, rs.frequency_hz)
        out.update(floor=floor, diff=diff)
        for name, engine in (("dense", self.dense), ("SLEPc", self.slepc)):
            tally.high(f"{name} pair error / its one-ulp floor", pair_ratio(qep, engine.solve(qep, n, True), n))
        if qep.n <= 300:  # each engine against Newton-refined eigenvalues of the unscaled QEP
            ref = newton_refined(qep, self.dense.solve(qep, n, want_vectors=True), n)
            for name, r in (("dense", rd), ("SLEPc", rs)):
                tally.high(f"{name} error vs Newton-refined / floor", rel_diff(r.frequency_hz, ref) / floor)
        tally.high("conditioning floor", floor)
        tally.high("dense-vs-SLEPc / floor", diff / floor)
        tally.high("pair error of an accepted pair", np.nanmax(np.r_[rd.residual, rs.residual]))
        if diff <= FLOOR_FACTOR * floor:
            tally.add(f"dense = SLEPc within {FLOOR_FACTOR:g}x floor")
        else:
            tally.add(f"dense != SLEPc beyond {FLOOR_FACTOR:g}x floor")
            tally.notes.append(f"{label} ({qep.kind}, n={qep.n}): dense vs SLEPc {diff:.2e}, floor {floor:.2e}")
        return out


def newton_refined(qep, sol, n_modes: int, steps: int = 3) -> np.ndarray:
    """Frequencies (Hz) of the ``n_modes`` reported pairs after Newton steps on the QEP itself.

    The bordered system [P(λ) P'(λ)x; cᴴ 0][dx; dλ] = -[P(λ)x; cᴴx - 1] in complex double, on
    the assembled (unscaled, unbalanced) matrices: independent of either engine's linearization,
    scaling and stopping test, it converges quadratically to the eigenpair nearest the start."""
    from fkev_slepc.solve.modes import reported

    M, K = qep.mass.toarray(), qep.stiffness.toarray()
    C = qep.damping.toarray() if qep.damping is not None else np.zeros_like(M)
    idx, _ = reported(sol.eigenvalues, n_modes)
    out = np.full(n_modes, np.nan)
    for k, i in enumerate(idx):
        lam, x = complex(sol.eigenvalues[i]), np.array(sol.vectors[:, i], dtype=complex)
        c = x.conj() / np.vdot(x, x)
        for _ in range(steps):
            P, dP = lam * lam * M + lam * C + K, 2 * lam * M + C
            J = np.block([[P, (dP @ x)[:, None]], [c[None, :], np.zeros((1, 1))]])
            d = np.linalg.solve(J, -np.concatenate([P @ x, [c @ x - 1.0]]))
            x, lam = x + d[:-1], lam + d[-1]
        out[k] = lam.imag / (2 * np.pi)
    return out


def pair_ratio(qep, sol, n_modes: int) -> float:
    """Largest pair_error / pair_error_floor over the pairs a point reports."""
    from fkev_slepc.solve.acceptance import pair_error, pair_error_floor
    from fkev_slepc.solve.modes import reported

    osc, is_real = reported(sol.eigenvalues, n_modes)
    idx = np.concatenate([osc, np.flatnonzero(is_real)])
    lam, X = sol.eigenvalues[idx], sol.vectors[:, idx]
    return float(np.max(pair_error(qep, lam, X) / pair_error_floor(qep, lam, X))) if idx.size else np.nan


def _conv(res) -> bool:
    from fkev_slepc.status import CONVERGED

    return res.status in CONVERGED


def mp_real_eigenvalues(qep, dps: int = 40) -> np.ndarray:
    """The positive real eigenvalues of ``qep`` in ``dps``-digit arithmetic (mpmath), ascending.

    The companion matrix [0 I; -M⁻¹K -M⁻¹C] of the assembled matrices, inverted and solved in
    extended precision: no solver error left, only the matrices' own (so an engine's value is
    judged against the exact eigenvalue of the matrices it was given). ~40 s at n = 27.
    """
    import mpmath as mp

    from fkev_slepc.solve.stability import real_positive

    with mp.workdps(dps):
        M, K = (mp.matrix(A.toarray().tolist()) for A in (qep.mass, qep.stiffness))
        Mi, n = mp.inverse(M), qep.n
        A = -Mi * K
        B = -Mi * mp.matrix(qep.damping.toarray().tolist()) if qep.damping is not None else mp.zeros(n, n)
        L = mp.zeros(2 * n, 2 * n)
        for i in range(n):
            L[i, n + i] = 1
            for j in range(n):
                L[n + i, j], L[n + i, n + j] = A[i, j], B[i, j]
        ev = np.array([complex(e) for e in mp.eig(L, left=False, right=False)])
    return real_positive(ev)  # the default imag_tol (solve/thresholds.py IMAG_TOL)
