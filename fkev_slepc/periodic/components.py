"""Component modes of each link in its own frame: the Craig–Bampton basis W(θ) (docs/theory.md §18.8).

Floating-frame reduction of the periodic linkage. The free DOFs split into

* **boundary** DOFs, kept as they are (ground frame, a slider node in its guide frame): every free
  DOF used by the elements of two or more links (joint translations), every DOF of a slider node and
  every DOF that carries a lumped mass (:func:`boundary_dofs`);
* the **interior** DOFs of each link j: the other free DOFs its elements use (interior nodes, its own
  end rotations at pins, internal DOFs of higher-order elements, a ternary link's branch).

Every node of link j written in the link's frame (x̂ = R(φ_j) Cₙ q for its translations, rotations
and internal DOFs frame-free) has the link's stiffness K_j = Σ L_eᵀ k_e L_e and mass M_j = Σ L_eᵀ m_e L_e
with the constant link-to-element rotation L_e = R(elem_angle): constant, built once per model
(independent of θ, Ω and the case). The interior of link j is spanned by the static constraint modes
Ψ_j = -K_ii⁻¹ K_ib of its boundary DOFs (both link-frame components of a boundary node) and its lowest
fixed-interface modes K_ii φ = ω² M_ii φ (mass-normalised; dense ``scipy.linalg.eigh`` up to
``DENSE_MAX`` interior DOFs, SLEPc shift-invert at target 0 beyond, options prefix ``fkev_cb_``).
With z = (q_b, η_1 … η_L) the basis is q = W(θ) z,

    W rows of link j's interior = R_iᵀ(φ_j) [Ψ_j G_j(φ_j), Φ_j],   boundary rows = identity,

(R_iᵀ rotates the interior translation pairs back to the ground frame, G_j maps the boundary DOFs to
their link-frame components). W depends on θ only through the link angles, so with the m-th angle
derivative ∂ᵐW_j = Σ_a C(m, a) ∂ᵃR_iᵀ [Ψ_j ∂ᵐ⁻ᵃG_j, Φ_j δ_{a,m}] (a rotation's derivative is the
rotation by a further π/2): W' = Σ_j φ_j' ∂W_j and W'' = Σ_j (φ_j'' ∂W_j + φ_j'² ∂²W_j), exact.
Keeping every fixed-interface mode makes W square and invertible (the full model, exactly).

``link_components(model) -> Components`` (cached per model); ``Components.basis(k) -> LinkBasis`` with
the lowest k modes of each link (all its interior DOFs at most); a :class:`LinkBasis` has ``shape``
(n, R), ``covered_rad_s`` (its highest retained fixed-interface frequency) and
``at(phi, dphi, ddphi) -> (W, W', W'')`` for the link angles φ, φ', φ'' (n_link,) of one crank angle,
the basis protocol of :func:`fkev_slepc.periodic.reduce.reduced_coefficients`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from math import comb

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from fkev_slepc.model import elements as el
from fkev_slepc.periodic.settings import DEFAULTS

DENSE_MAX = 300  # interior DOFs of a link up to which its fixed-interface modes are found densely
LINK_MODES = DEFAULTS.link_modes  # fixed-interface modes per link of the first level of reduce="links" (then doubled)
HALF_PI = 0.5 * np.pi


def boundary_dofs(mech) -> np.ndarray:
    """(n_free,) bool: the boundary DOFs of ``mech`` (shared by two or more links, a slider
    node's, a lumped mass's); vectorised over elements."""
    d = mech.elem_dofs.ravel()
    lk = np.repeat(mech.elem_link, mech.elem_dofs.shape[1])
    used = np.unique(np.stack([d[d >= 0], lk[d >= 0]], axis=1), axis=0)
    bnd = np.bincount(used[:, 0], minlength=mech.n_free) >= 2
    nd = mech.node_dofs
    slider = ((nd[:, :2] < 0).sum(axis=1) == 1) | (mech.node_axis[:, 0] != 1.0)
    for dofs in (nd[slider].ravel(), mech.mass_dofs.ravel()):
        bnd[dofs[dofs >= 0]] = True
    return bnd


@dataclass(frozen=True)
class LinkComponent:
    """One link's interior in its frame (positions index ``rows`` or the boundary raw list)."""

    link: int
    rows: np.ndarray  # (n_i,) free DOFs of the interior, in the link's raw order
    pair: np.ndarray  # (n_p, 2) positions in rows of each interior translation pair (x̂, ŷ)
    bpair: np.ndarray  # (n_bp, 2) positions in the boundary raw list of each boundary pair
    bpair_cols: np.ndarray  # (n_bp, 2) boundary columns of the node's two free DOFs (-1: fixed)
    bpair_axis: np.ndarray  # (n_bp,) angle of the node's first translational DOF (a slider's guide)
    bplain: np.ndarray  # positions in the boundary raw list of boundary rotations
    bplain_cols: np.ndarray  # their boundary columns
    psi: np.ndarray  # (n_i, n_braw) static constraint modes -K_ii⁻¹ K_ib
    freq: np.ndarray  # (m,) fixed-interface frequencies found so far, rad/s, ascending
    modes: np.ndarray  # (n_i, m) mass-normalised fixed-interface modes
    stiffness: tuple  # (K_ii, K_ib), dense, link frame
    mass: np.ndarray  # M_ii, dense, link frame

    @property
    def size(self) -> int:
        return self.rows.size


def _raw(mech, n_dof: int):
    """Raw DOFs (3 per node, link-frame components, then internal ones): per raw DOF its free DOF
    (-1 fixed), kind (0/1 translation x̂/ŷ, 2 rotation or internal), link and node; and the raw
    DOFs of every element (n_el, n_dof)."""
    n_node, n_el = mech.node_dofs.shape[0], mech.elem_link.size
    n_int = n_dof - 6
    free = np.concatenate([mech.node_dofs.ravel(), mech.elem_dofs[:, 6:].ravel()])
    kind = np.concatenate([np.tile([0, 1, 2], n_node), np.full(n_el * n_int, 2)])
    node = np.concatenate([np.repeat(np.arange(n_node), 3), -np.ones(n_el * n_int, dtype=int)])
    link = np.concatenate([np.repeat(mech.node_link, 3), np.repeat(mech.elem_link, n_int)])
    en = mech.elem_nodes
    elem = np.concatenate([3 * en[:, :1] + np.arange(3), 3 * en[:, 1:] + np.arange(3),
                           3 * n_node + n_int * np.arange(n_el)[:, None] + np.arange(n_int)], axis=1)
    return free, kind, link, node, elem


def _link_matrices(model, elem, n_raw):
    """Link-frame stiffness and mass over the raw DOFs (CSR, block-diagonal by link)."""
    st = model.stacks
    L = el.rotation(model.mechanism.elem_angle, st.n_dof)
    rows = np.repeat(elem, st.n_dof, axis=1).ravel()
    cols = np.tile(elem, (1, st.n_dof)).ravel()
    out = []
    for m in (st.structural, st.mass):
        data = (np.swapaxes(L, 1, 2) @ m @ L).ravel()
        out.append(sp.csr_matrix((data, (rows, cols)), shape=(n_raw, n_raw)))
    return out


class Components:
    """The link components of one model (:func:`link_components`)."""

    def __init__(self, model, dense_max: int = DENSE_MAX):
        mech = model.mechanism
        self.n, self.n_link = int(model.n_free), mech.n_link
        self.dense_max = int(dense_max)
        bnd = boundary_dofs(mech)
        self.boundary = np.flatnonzero(bnd)
        col = -np.ones(self.n, dtype=int)
        col[self.boundary] = np.arange(self.boundary.size)
        free, kind, link, node, elem = _raw(mech, model.stacks.n_dof)
        n_raw = free.size
        used = np.zeros(n_raw, dtype=bool)
        used[elem.ravel()] = True
        nd = mech.node_dofs
        pair_free = np.where(kind < 2, node, 0)
        du, dv = nd[pair_free, 0], nd[pair_free, 1]
        pair_fixed = (du < 0) & (dv < 0)
        pair_bnd = ((du >= 0) & bnd[np.maximum(du, 0)]) | ((dv >= 0) & bnd[np.maximum(dv, 0)])
        is_pair = kind < 2
        status_b = np.where(is_pair, pair_bnd & ~pair_fixed, (free >= 0) & bnd[np.maximum(free, 0)]) & used
        status_i = np.where(is_pair, ~pair_bnd & ~pair_fixed, (free >= 0) & ~bnd[np.maximum(free, 0)]) & used
        K, M = _link_matrices(model, elem, n_raw)
        axis = np.arctan2(mech.node_axis[:, 1], mech.node_axis[:, 0])
        self.links = []
        for j in range(self.n_link):
            I = np.flatnonzero(status_i & (link == j))
            B = np.flatnonzero(status_b & (link == j))
            x_i, x_b = I[kind[I] == 0], B[kind[B] == 0]
            bp_node = node[x_b]
            Kii, Kib, Mii = (K[I][:, I].toarray(), K[I][:, B].toarray(), M[I][:, I].toarray())
            psi = -la.solve(Kii, Kib, assume_a="sym") if I.size else np.zeros((0, B.size))
            self.links.append(LinkComponent(
                j, free[I], np.stack([np.searchsorted(I, x_i), np.searchsorted(I, x_i + 1)], axis=1),
                np.stack([np.searchsorted(B, x_b), np.searchsorted(B, x_b + 1)], axis=1),
                np.stack([np.where(nd[bp_node, 0] >= 0, col[nd[bp_node, 0]], -1),
                          np.where(nd[bp_node, 1] >= 0, col[nd[bp_node, 1]], -1)], axis=1),
                axis[bp_node], np.flatnonzero(kind[B] == 2), col[free[B[kind[B] == 2]]], psi,
                np.zeros(0), np.zeros((I.size, 0)), (Kii, Kib), Mii))
        rows = np.concatenate([self.boundary] + [c.rows for c in self.links])
        if rows.size != self.n or np.unique(rows).size != self.n:
            raise ValueError("the boundary and link interiors do not partition the free DOFs")

    @property
    def interior(self) -> np.ndarray:
        """(n_link,) interior DOFs per link."""
        return np.array([c.size for c in self.links])

    def _ensure(self, k: int) -> None:
        """Find at least min(k, n_i) fixed-interface modes of every link."""
        for j, c in enumerate(self.links):
            want = min(int(k), c.size)
            if c.freq.size >= want:
                continue
            Kii, M = c.stiffness[0], c.mass
            if c.size <= self.dense_max:
                lam, X = la.eigh(Kii, M)
            else:
                lam, X = fixed_interface_slepc(sp.csr_matrix(Kii), sp.csr_matrix(M), max(want, 2 * c.freq.size))
            self.links[j] = replace(c, freq=np.sqrt(np.maximum(lam, 0.0)), modes=X)

    def basis(self, k: int) -> LinkBasis:
        """The basis with the lowest ``k`` (>= 0) fixed-interface modes of every link."""
        self._ensure(k)
        keep = [min(int(k), c.size) for c in self.links]
        return LinkBasis(self, tuple(keep))


def fixed_interface_slepc(K, M, nev: int):
    """(ω², X): the ``nev`` lowest eigenpairs of K x = ω² M x (sparse, SPD) by SLEPc (GHEP,
    shift-invert at target 0, options prefix ``fkev_cb_``), X mass-normalised, ascending."""
    from fkev_slepc.solve.petsc_init import init_petsc

    init_petsc()
    from petsc4py import PETSc
    from slepc4py import SLEPc

    mats = [PETSc.Mat().createAIJ(size=A.shape, csr=(A.indptr.astype(PETSc.IntType),
                                                     A.indices.astype(PETSc.IntType), A.data),
                                  comm=PETSc.COMM_SELF) for A in (K.tocsr(), M.tocsr())]
    eps = SLEPc.EPS().create(PETSc.COMM_SELF)
    try:
        eps.setOptionsPrefix("fkev_cb_")
        eps.setOperators(*mats)
        eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
        eps.setDimensions(nev=min(int(nev), K.shape[0]))
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        eps.setTarget(0.0)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        st.getKSP().setType("preonly")
        st.getKSP().getPC().setType("cholesky")
        eps.setFromOptions()
        eps.solve()
        n = min(eps.getConverged(), int(nev))
        if n < min(int(nev), K.shape[0]):
            raise RuntimeError(f"fixed-interface modes: SLEPc converged {n} of {nev}")
        xr = mats[0].createVecs()[0]
        lam, X = np.zeros(n), np.zeros((K.shape[0], n))
        for i in range(n):
            lam[i] = eps.getEigenpair(i, xr).real
            X[:, i] = xr.getArray()
    finally:
        eps.destroy()
        for m in mats:
            m.destroy()
    order = np.argsort(lam)
    lam, X = lam[order], X[:, order]
    return lam, X / np.sqrt(np.einsum("ik,ik->k", X, M @ X))


def link_components(model, dense_max: int = DENSE_MAX) -> Components:
    """The :class:`Components` of ``model`` (built once, kept on the model)."""
    key = ("_fkev_cb_components", int(dense_max))
    cache = model.__dict__.setdefault("_fkev_cb_cache", {})
    if key not in cache:
        cache[key] = Components(model, dense_max)
    return cache[key]


def frame_rows(X, pair, phi: float, a: int):
    """∂ᵃ/∂φᵃ of R_iᵀ(φ) X: the interior pairs (x̂, ŷ) -> (U, V) = (c x̂ - s ŷ, s x̂ + c ŷ); other
    rows identity (a = 0) or zero."""
    c, s = np.cos(phi + a * HALF_PI), np.sin(phi + a * HALF_PI)
    out = X.copy() if a == 0 else np.zeros_like(X)
    x, y = X[pair[:, 0]], X[pair[:, 1]]
    out[pair[:, 0]], out[pair[:, 1]] = c * x - s * y, s * x + c * y
    return out


def _constraint(c: LinkComponent, n_b: int, phi: float, b: int):
    """∂ᵇ/∂φᵇ of Ψ G(φ) (n_i, n_b): a boundary pair's free DOFs (u, v) in its node frame have the
    link-frame components x̂ = cβ u + sβ v, ŷ = -sβ u + cβ v, β = φ - α; rotations identity."""
    out = np.zeros((c.size, n_b))
    beta = phi - c.bpair_axis + b * HALF_PI
    cb, sb = np.cos(beta), np.sin(beta)
    px, py = c.psi[:, c.bpair[:, 0]], c.psi[:, c.bpair[:, 1]]
    for k, vals in ((0, px * cb - py * sb), (1, px * sb + py * cb)):
        cols = c.bpair_cols[:, k]
        np.add.at(out, (slice(None), cols[cols >= 0]), vals[:, cols >= 0])
    if b == 0:
        np.add.at(out, (slice(None), c.bplain_cols), c.psi[:, c.bplain])
    return out


@dataclass(frozen=True)
class LinkBasis:
    """q = W(θ) z, z = (boundary DOFs, η of each link): see the module docstring."""

    comp: Components
    keep: tuple  # modes kept per link

    @property
    def shape(self) -> tuple[int, int]:
        return self.comp.n, self.comp.boundary.size + int(sum(self.keep))

    @property
    def covered_rad_s(self) -> float:
        """The highest retained fixed-interface frequency (rad/s; 0 if none is kept)."""
        f = [c.freq[k - 1] for c, k in zip(self.comp.links, self.keep) if k]
        return float(max(f)) if f else 0.0

    def at(self, phi, dphi, ddphi):
        """(W, W', W'') (n, R) at one crank angle from the link angles φ, φ', φ'' (n_link,)."""
        n, R = self.shape
        n_b = self.comp.boundary.size
        out = [np.zeros((n, R)) for _ in range(3)]
        out[0][self.comp.boundary, np.arange(n_b)] = 1.0
        start = n_b
        for j, (c, k) in enumerate(zip(self.comp.links, self.keep)):
            if not c.size:
                continue
            cols = np.concatenate([np.arange(n_b), np.arange(start, start + k)])
            start += k
            X = [np.hstack([_constraint(c, n_b, phi[j], b), c.modes[:, :k] if b == 0 else np.zeros((c.size, k))])
                 for b in range(3)]
            d = [sum(comb(m, a) * frame_rows(X[m - a], c.pair, phi[j], a) for a in range(m + 1)) for m in range(3)]
            ix = np.ix_(c.rows, cols)
            out[0][ix] = d[0]
            out[1][ix] = dphi[j] * d[1]
            out[2][ix] = ddphi[j] * d[1] + dphi[j] ** 2 * d[2]
        return tuple(out)
