"""Reduced periodic coefficients on co-rotating frozen modes (docs/theory.md §18.7).

A constant basis in the global DOFs cannot follow links that turn a full revolution (a crank's
mode shape at θ is its shape at 0 rotated by θ). The basis here co-rotates: every free node
translation pair (U, V) is written in the frame of the link that owns it,

    q = Q(θ) q̂,   Q = blockdiag(Rᵀ(ψ_node(θ)), 1, …),   Q' = ψ' Rᵀ S,   Q'' = ψ'' Rᵀ S - ψ'² Rᵀ,

(ψ_node the owning link's angle; slider DOFs along a fixed guide and rotations stay as they
are) and q̂ = V̂ η with a constant V̂: the lowest ``r`` undamped frozen modes at a few angles,
each unit-normalised and mapped to q̂ = Qᵀ q (:func:`frozen_pool`), then the pool's left
singular directions above a threshold of the largest singular value (:func:`compress`; which
threshold and pool, and the truncation error they leave, are decided by measurement in
fkev_slepc/periodic/truncation.py). With W = Q V̂ the Galerkin projection of the Lagrangian
of model/periodic.py is again Lagrangian (so symplectic steps still apply):

    M_r = WᵀMW,  N_r = Ω WᵀMW' + WᵀNW,  V_r = WᵀVW - Ω² W'ᵀMW' - 2Ω sym(W'ᵀNW),
    C_d,r = WᵀC_dW,  K_d,r = Ω WᵀC_dW' + WᵀK_dW,
    C_r = 2Ω WᵀMW' + WᵀCW,  K_r = Ω² WᵀMW'' + Ω WᵀCW' + WᵀKW   (second-order form),

and along a run-up with crank acceleration α, K_r gains α WᵀMW' (docs/theory.md §21).

For the lone crank the co-rotated system has constant coefficients, so its lowest frozen modes
span an invariant subspace and the reduction is exact for them.

The projection (:func:`reduced_coefficients`) takes any basis that gives (W, W', W'') at one crank
angle from the link angles φ, φ', φ'' (``at``): the co-rotated frozen modes here
(:class:`CorotatedBasis`) or the link-frame component modes of fkev_slepc/periodic/components.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from fkev_slepc.model.kinematics import solve_kinematics
from fkev_slepc.model.periodic import periodic_pieces

TWO_PI = 2.0 * np.pi


def corotated_pairs(mech):
    """(u, v, link) of every free translation pair, owned by the first link listing the node."""
    seen, rows = set(), []
    for node in range(mech.node_dofs.shape[0]):
        u, v = (int(x) for x in mech.node_dofs[node, :2])
        if u < 0 or v < 0 or (u, v) in seen or mech.node_axis[node, 0] != 1.0:
            continue
        seen.add((u, v))
        rows.append((u, v, int(mech.node_link[node])))
    arr = np.array(rows, dtype=int).reshape(-1, 3)
    return arr[:, 0], arr[:, 1], arr[:, 2]


def rotate_rows(X, pairs, psi, sign=1.0):
    """Rows (u, v) of X rotated by Rᵀ(sign·ψ) (a copy): Q X for sign = 1, Qᵀ X for sign = -1."""
    u, v, _ = pairs
    c, s = np.cos(psi)[:, None], sign * np.sin(psi)[:, None]
    out = X.copy()
    out[u], out[v] = c * X[u] - s * X[v], s * X[u] + c * X[v]
    return out


def _rot90(X, pairs):
    u, v, _ = pairs
    out = np.zeros_like(X)
    out[u], out[v] = -X[v], X[u]
    return out


def basis_derivatives(Vhat, pairs, phi, dphi, ddphi):
    """W, W', W'' (n, r) at one angle from the link angles φ, φ', φ'' (n_link,)."""
    link = pairs[2]
    psi, d1, d2 = phi[link], dphi[link][:, None], ddphi[link][:, None]
    W = rotate_rows(Vhat, pairs, psi)
    SV = rotate_rows(_rot90(Vhat, pairs), pairs, psi)  # Rᵀ S V̂ on the pairs, 0 elsewhere
    u, v, _ = pairs
    W1 = np.zeros_like(Vhat)
    W2 = np.zeros_like(Vhat)
    for rows in (u, v):
        W1[rows] = d1 * SV[rows]
        W2[rows] = d2 * SV[rows] - d1**2 * W[rows]
    return W, W1, W2


def frozen_pool(model, omega, case, r, angles, start=0.0):
    """(n, r·angles): the lowest r undamped frozen modes at ``angles`` equispaced angles from
    ``start``, each unit-normalised and co-rotated (q̂ = Qᵀq), in angle-major order."""
    th = start + TWO_PI * np.arange(angles) / angles
    c = periodic_pieces(model, th, case).at_speed(omega, damping=False)
    kin = solve_kinematics(model.mechanism, th)
    pairs = corotated_pairs(model.mechanism)
    pat, cols = model.pattern, []
    stiff = c.K if c.V is None else c.V  # the undamped static stiffness (the Lagrangian form's potential)
    for i in range(angles):
        K = pat.matrix(stiff[i])
        _, x = spla.eigsh(0.5 * (K + K.T), k=min(r, model.n_free - 1), M=pat.matrix(c.M[i]),
                          sigma=0.0, which="LM")
        x = x / np.linalg.norm(x, axis=0)
        cols.append(rotate_rows(x, pairs, kin.phi[i, pairs[2]], sign=-1.0))
    return np.hstack(cols)


def compress(pool, threshold=1e-10):
    """V̂ (n, R): the left singular vectors of ``pool`` with s > threshold·s₀ (orthonormal)."""
    U, s, _ = np.linalg.svd(pool, full_matrices=False)
    return U[:, s > threshold * s[0]]


@dataclass(frozen=True)
class CorotatedBasis:
    """The co-rotated frozen-mode basis W = Q(θ) V̂ in the basis protocol of
    :func:`reduced_coefficients` (``shape``, ``at(φ, φ', φ'') -> (W, W', W'')``)."""

    Vhat: np.ndarray
    pairs: tuple

    @property
    def shape(self) -> tuple[int, int]:
        return self.Vhat.shape

    def at(self, phi, dphi, ddphi):
        return basis_derivatives(self.Vhat, self.pairs, phi, dphi, ddphi)


def reduced_coefficients(model, c, thetas, omega, basis, accel: float = 0.0):
    """Dense reduced (M, C, K, N, V, C_d, K_d) stacks (see the module docstring) of the full model's
    coefficients ``c`` at crank speed ``omega`` (:meth:`PeriodicPieces.at_speed
    <fkev_slepc.model.periodic.PeriodicPieces.at_speed>`) on ``basis``: a co-rotated V̂ (n, R), or any
    object whose ``at(φ, φ', φ'')`` gives (W, W', W'') at one crank angle from the link angles and rates
    (:class:`CorotatedBasis`, or the link-frame component modes of fkev_slepc/periodic/components.py),
    or whose ``at_angle(θ)`` gives them from the crank angle (the moving frozen-mode basis of
    fkev_slepc/periodic/moving.py). ``accel``: the crank acceleration α (rad/s²) of a run-up at which
    ``c`` was taken; K_r gains α WᵀMW' (docs/theory.md §21)."""
    mat = model.pattern.matrix
    w = float(omega)
    out = {k: [] for k in "M C K N V Cd Kd".split()}
    for i, (W, W1, W2) in enumerate(basis_frames(model, thetas, basis)):
        Mm = mat(c.M[i])
        MW, MW1 = Mm @ W, Mm @ W1
        Cm, Km = mat(c.C[i]), mat(c.K[i])
        out["M"].append(W.T @ MW)
        out["C"].append(2 * w * W.T @ MW1 + W.T @ (Cm @ W))
        out["K"].append(w * w * W.T @ (Mm @ W2) + w * W.T @ (Cm @ W1) + W.T @ (Km @ W) + accel * (W.T @ MW1))
        if c.N is not None:
            NW = mat(c.N[i]) @ W
            X = W1.T @ NW
            out["N"].append(w * W.T @ MW1 + W.T @ NW)
            out["V"].append(W.T @ (mat(c.V[i]) @ W) - w * w * W1.T @ MW1 - w * (X + X.T))
        if c.Cd is not None:
            Cd = mat(c.Cd[i])
            out["Cd"].append(W.T @ (Cd @ W))
            out["Kd"].append(w * W.T @ (Cd @ W1) + W.T @ (mat(c.Kd[i]) @ W))
    return tuple(np.stack(v) if v else None for v in out.values())


def basis_frames(model, thetas, basis):
    """(W, W', W'') of ``basis`` (as :func:`reduced_coefficients` takes it) at each crank angle of
    ``thetas``, one angle at a time."""
    kin = solve_kinematics(model.mechanism, thetas)
    if isinstance(basis, np.ndarray):
        basis = CorotatedBasis(basis, corotated_pairs(model.mechanism))
    moving = hasattr(basis, "at_angle")  # a basis given in the crank angle (periodic/moving.py)
    for i in range(len(thetas)):
        yield basis.at_angle(thetas[i]) if moving else basis.at(kin.phi[i], kin.dphi[i], kin.ddphi[i])


def reduced_load(model, f, thetas, basis) -> np.ndarray:
    """Wᵀ f (len(θ), R): the Galerkin load of ``f`` (len(θ), n) on ``basis`` at the crank angles."""
    return np.stack([W.T @ f[i] for i, (W, _, _) in enumerate(basis_frames(model, thetas, basis))])
