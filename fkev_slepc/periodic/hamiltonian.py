"""Hamiltonian generators in canonical (q, p): packed samples, structured commutators and Magnus
steps (docs/theory.md §18.7, "Hamiltonian steps").

An undamped Lagrangian case in canonical coordinates has the generator (scaled DOF by DOF, which
keeps the structure: q̂ = d q, p̂ = p/d)

    A = [[E, F], [G, -Eᵀ]],   F = Fᵀ,  G = Gᵀ   (JA symmetric, J = [[0, I], [-I, 0]]),

an element of the Lie algebra sp(2n): every linear combination and every commutator of such
matrices is one again, so every Magnus Ω is, and it is held by its blocks E, F, G. The commutator

    [A₁, A₂] = [[E, X + Xᵀ], [Y + Yᵀ, -Eᵀ]],   E = E₁E₂ - E₂E₁ + F₁G₂ - F₂G₁,
    X = E₁F₂ - E₂F₁,   Y = G₁E₂ - G₂E₁

takes 8 products of n × n (the generic 2n × 2n one 16), and the trigonometric interpolant holds
E and the upper triangles of F and G: n² + n(n + 1) of the 4n² entries. The 2n × 2n Ω is
assembled only for the step's exponential.

``hamiltonian_residual(A) -> float``: max |JA - (JA)ᵀ| / max|A| over a stack (k, 2n, 2n).
``is_hamiltonian(A, tol=HAMILTONIAN_TOL) -> bool``: that residual <= ``tol``.
``pack(A) -> P (k, n² + n(n+1))`` and ``unpack(P, n) -> B (3, k, n, n)`` (the blocks E, F, G,
block-major; F and G from the symmetric parts), ``assemble(B) -> A (k, 2n, 2n)``,
``commutator(B₁, B₂) -> B``.
``HamiltonianInterpolant(start, samples, drop)``: the trigonometric interpolant of Hamiltonian
samples over their packed entries (callable θ -> A like :class:`TrigInterpolant`, ``S`` the full
samples), whose ``magnus_step(theta, h, order)`` gives the steps' Ω by the structured commutators
(the hook of :func:`fkev_slepc.periodic.magnus.step_exponentials`).
``interpolant(start, samples, drop) ->`` a :class:`HamiltonianInterpolant` where the samples are
Hamiltonian to ``HAMILTONIAN_TOL``, else the generic :class:`TrigInterpolant`.

**With a forcing** (the response's shooting, fkev_slepc/periodic/shooting.py) the steps run on the
augmented generator [[A, b], [0, 0]], whose commutators are [[A₁, b₁], [0, 0]], [[A₂, b₂], [0, 0]] ->
[[[A₁, A₂], A₁b₂ - A₂b₁], [0, 0]]: the structured commutator of the A parts and four n × n by
n × m products for the columns (the generic augmented commutator takes 2 products of (2n + m)²).
``forced(generator, forcing)``: the augmented generator (callable τ -> (k, 2n + m, 2n + m)) with
those ``magnus_step``s where ``generator`` is a :class:`HamiltonianInterpolant`, else None.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from fkev_slepc.periodic.interpolant import TrigInterpolant
from fkev_slepc.periodic.magnus import magnus_generators

# JA's asymmetry relative to max|A| that counts as Hamiltonian: the round-off of the samples'
# M⁻¹ (measured <= 1e-13 on Bahgat–Willmert, the slider-crank, Turcic–Midha and their link bases,
# <= 1.5e-12 on their frozen-mode bases; the damped Bahgat–Willmert scene's C_d M⁻¹ gives 0.1)
HAMILTONIAN_TOL = 1e-10


def _blocks(A):
    n = A.shape[-1] // 2
    return A[..., :n, :n], A[..., :n, n:], A[..., n:, :n], A[..., n:, n:]


def hamiltonian_residual(A) -> float:
    """max |JA - (JA)ᵀ| / max|A| over the stack ``A`` (k, 2n, 2n): 0 for a Hamiltonian generator."""
    A = np.asarray(A, dtype=float)
    if A.ndim != 3 or A.shape[1] != A.shape[2] or A.shape[1] % 2:
        return np.inf
    E, F, G, H = _blocks(A)
    r = max(np.max(np.abs(H + np.swapaxes(E, 1, 2))), np.max(np.abs(F - np.swapaxes(F, 1, 2))),
            np.max(np.abs(G - np.swapaxes(G, 1, 2))))
    return float(r / max(np.max(np.abs(A)), 1e-300))


def is_hamiltonian(A, tol: float = HAMILTONIAN_TOL) -> bool:
    """Whether the stack ``A`` (k, 2n, 2n) is Hamiltonian to ``tol`` (:func:`hamiltonian_residual`)."""
    return hamiltonian_residual(A) <= tol


@lru_cache(maxsize=8)
def _layout(n: int) -> np.ndarray:
    """(3n²,) positions in the packed entries of the full blocks E, F, G (row-major each)."""
    iu = np.triu_indices(n)
    tri = np.zeros((n, n), dtype=int)
    tri[iu] = np.arange(iu[0].size)
    tri = np.maximum(tri, tri.T)  # the lower triangle reads its upper mirror
    return np.concatenate([np.arange(n * n), n * n + tri.ravel(), n * n + iu[0].size + tri.ravel()])


def pack(A) -> np.ndarray:
    """P (k, n² + n(n+1)): E row-major, then the upper triangles of (F + Fᵀ)/2 and (G + Gᵀ)/2."""
    E, F, G, _ = _blocks(np.asarray(A, dtype=float))
    k, n = E.shape[0], E.shape[1]
    iu = np.triu_indices(n)
    sym = lambda X: 0.5 * (X + np.swapaxes(X, 1, 2))[:, iu[0], iu[1]]  # noqa: E731
    return np.concatenate([E.reshape(k, n * n), sym(F), sym(G)], axis=1)


def unpack(P, n: int) -> np.ndarray:
    """B (3, k, n, n): the blocks E, F, G of packed entries ``P`` (k, n² + n(n+1)), block-major
    (each block a contiguous stack: batched products of strided stacks are 3× slower)."""
    P = np.asarray(P, dtype=float)
    return np.ascontiguousarray(np.moveaxis(np.take(P, _layout(n), axis=-1).reshape(-1, 3, n, n), 1, 0))


def assemble(B) -> np.ndarray:
    """A (k, 2n, 2n) = [[E, F], [G, -Eᵀ]] from blocks ``B`` (3, k, n, n)."""
    _, k, n, _ = B.shape
    A = np.empty((k, 2 * n, 2 * n))
    A[:, :n, :n], A[:, :n, n:], A[:, n:, :n] = B
    A[:, n:, n:] = -np.swapaxes(B[0], 1, 2)
    return A


def commutator(B1, B2) -> np.ndarray:
    """[A₁, A₂] of Hamiltonian matrices by blocks (3, s, n, n): 8 products of n × n (module docstring)."""
    (E1, F1, G1), (E2, F2, G2) = B1, B2
    out = np.empty(B1.shape)
    out[0] = E1 @ E2 - E2 @ E1 + F1 @ G2 - F2 @ G1
    X = E1 @ F2 - E2 @ F1
    Y = G1 @ E2 - G2 @ E1
    np.add(X, np.swapaxes(X, 1, 2), out=out[1])
    np.add(Y, np.swapaxes(Y, 1, 2), out=out[2])
    return out


class HamiltonianInterpolant:
    """The trigonometric interpolant of Hamiltonian samples (k, 2n, 2n) over their packed entries
    (``drop`` as :class:`TrigInterpolant`'s, on the same entries' values)."""

    def __init__(self, start, samples: np.ndarray, drop: float = 0.0):
        self.start, self.S, self.n = start, samples, samples.shape[1] // 2
        self.packed = TrigInterpolant(start, pack(samples), drop)
        self.harmonics, self.k = self.packed.harmonics, self.packed.k

    def blocks(self, theta) -> np.ndarray:
        """B (3, len(θ), n, n): the interpolant's blocks E, F, G at ``theta``."""
        return unpack(self.packed(theta), self.n)

    def __call__(self, theta) -> np.ndarray:
        return assemble(self.blocks(theta))

    def magnus_step(self, theta, h: float, order: int) -> np.ndarray:
        """Ω (s, 2n, 2n) of the Magnus steps whose Gauss nodes are ``theta`` (s, nodes): the node
        blocks (3, nodes, s, n, n), whose axis 1 :func:`magnus_generators` reads as the nodes."""
        s, c = theta.shape
        B = self.blocks(theta.T.ravel()).reshape(3, c, s, self.n, self.n)
        return assemble(magnus_generators(B, h, order, commutator=commutator))


def interpolant(start, samples: np.ndarray, drop: float = 0.0):
    """:class:`HamiltonianInterpolant` of Hamiltonian ``samples`` (:func:`is_hamiltonian`), else
    the generic :class:`TrigInterpolant`."""
    if is_hamiltonian(samples):
        return HamiltonianInterpolant(start, samples, drop)
    return TrigInterpolant(start, samples, drop)


class _Affine:
    """[[A, b], [0, 0]] by A's blocks ``B`` (3, [nodes,] s, n, n) and ``b`` ([nodes,] s, 2n, m): the
    linear combinations, node picks (``x[:, i]``) and :func:`_affine_commutator` that
    :func:`fkev_slepc.periodic.magnus.magnus_generators` applies."""

    __slots__ = ("B", "b")

    def __init__(self, B, b):
        self.B, self.b = B, b

    def __getitem__(self, key):
        return _Affine(self.B[key], self.b[key[1]])

    def __add__(self, o):
        return _Affine(self.B + o.B, self.b + o.b)

    def __sub__(self, o):
        return _Affine(self.B - o.B, self.b - o.b)

    def __mul__(self, c):
        return _Affine(c * self.B, c * self.b)

    __rmul__ = __mul__

    def __truediv__(self, c):
        return _Affine(self.B / c, self.b / c)

    def __neg__(self):
        return _Affine(-self.B, -self.b)


def _apply(B, v) -> np.ndarray:
    """[[E, F], [G, -Eᵀ]] v for blocks ``B`` (3, s, n, n) and columns ``v`` (s, 2n, m)."""
    E, F, G = B
    n = E.shape[-1]
    v1, v2 = v[:, :n], v[:, n:]
    return np.concatenate([E @ v1 + F @ v2, G @ v1 - np.swapaxes(E, 1, 2) @ v2], axis=1)


def _affine_commutator(x: _Affine, y: _Affine) -> _Affine:
    return _Affine(commutator(x.B, y.B), _apply(x.B, y.b) - _apply(y.B, x.b))


class _Forced:
    """The augmented generator of a :class:`HamiltonianInterpolant` and a forcing (:func:`forced`)."""

    def __init__(self, generator: HamiltonianInterpolant, forcing):
        self.generator, self.forcing = generator, forcing

    def _columns(self, theta) -> np.ndarray:
        b = np.asarray(self.forcing(theta), dtype=float)
        return b[:, :, None] if b.ndim == 2 else b

    def __call__(self, theta) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        return self._assemble(self.generator.blocks(theta), self._columns(theta))

    @staticmethod
    def _assemble(B, b) -> np.ndarray:
        k, n2, m = b.shape
        out = np.zeros((k, n2 + m, n2 + m))
        out[:, :n2, :n2] = assemble(B)
        out[:, :n2, n2:] = b
        return out

    def magnus_step(self, theta, h: float, order: int) -> np.ndarray:
        """Ω (s, 2n + m, 2n + m) of the augmented steps whose Gauss nodes are ``theta`` (s, nodes)."""
        s, c = theta.shape
        t = theta.T.ravel()
        B = self.generator.blocks(t).reshape(3, c, s, self.generator.n, self.generator.n)
        b = self._columns(t)
        x = magnus_generators(_Affine(B, b.reshape((c, s) + b.shape[1:])), h, order, commutator=_affine_commutator)
        return self._assemble(x.B, x.b)


def forced(generator, forcing):
    """The augmented generator [[A, b], [0, 0]] with structured Magnus steps (module docstring) where
    ``generator`` is a :class:`HamiltonianInterpolant`; None otherwise (the generic steps apply)."""
    return _Forced(generator, forcing) if isinstance(generator, HamiltonianInterpolant) else None
