"""The trigonometric interpolant of a smooth 2π-periodic matrix function sampled at k equispaced
angles, and CSR data to dense stacks (docs/theory.md §18.7: the generator A(θ) is built exactly at
equispaced crank angles and evaluated in between by this interpolant).

``TrigInterpolant(start, samples)``: callable θ -> (len(θ), n, n); ``to_dense(pattern, data)``:
(k, nnz) CSR data on a pattern -> (k, n, n).
"""

from __future__ import annotations

import numpy as np


def to_dense(pattern, data: np.ndarray) -> np.ndarray:
    """(k, nnz) CSR data on ``pattern`` (a :class:`fkev_slepc.model.assembly.Pattern`) -> (k, n, n)."""
    rows = np.repeat(np.arange(pattern.n), np.diff(pattern.indptr))
    out = np.zeros((data.shape[0], pattern.n, pattern.n))
    out[:, rows, pattern.indices] = data
    return out


def _dirichlet(theta: np.ndarray, k: int) -> np.ndarray:
    """Weights (len(θ), k) of the trigonometric interpolant on the k (even) nodes 2πj/k:
    D(x) = sin(kx/2) cot(x/2)/k at x = θ - 2πj/k, by angle addition (sin(kθ_j/2) = 0,
    cos(kθ_j/2) = (-1)^j), so only O(len(θ) + k) transcendental evaluations."""
    half, node = 0.5 * theta[:, None], np.pi * np.arange(k)[None, :] / k
    sx = np.sin(half) * np.cos(node) - np.cos(half) * np.sin(node)  # sin(x/2)
    cx = np.cos(half) * np.cos(node) + np.sin(half) * np.sin(node)  # cos(x/2)
    sk = np.sin(k * half) * np.where(np.arange(k) % 2, -1.0, 1.0)[None, :]  # sin(kx/2)
    small = np.abs(sx) < 1e-12
    with np.errstate(invalid="ignore", divide="ignore"):
        w = sk * cx / (k * np.where(small, 1.0, sx))
    return np.where(small, np.sign(cx) ** k, w)


class TrigInterpolant:
    """θ -> (len(θ), n, n): the trigonometric interpolant of ``samples`` (k even, (k, n, n), or any
    (k, ...) stack: (len(θ), ...)) taken at start + 2πj/k, j = 0..k-1 (period 2π).

    ``drop`` > 0: evaluated as its Fourier series (the same function) with the highest harmonics
    left out where their summed amplitudes are at most ``drop``·max|samples|, a bound on the
    difference from the interpolant at every θ. Each evaluation then costs 2K + 1 weights per
    angle instead of k (Bahgat–Willmert, 4 elements per link: K = 74 of 128 harmonics at 1e-13)."""

    def __init__(self, start, samples: np.ndarray, drop: float = 0.0):
        self.start, self.S = start, samples
        self.k = samples.shape[0]
        self.harmonics = None
        if drop > 0.0:
            c = np.fft.rfft(samples.reshape(self.k, -1), axis=0) / self.k  # (k/2 + 1, n²)
            amp = 2.0 * np.max(np.abs(c), axis=1)
            amp[0] *= 0.5
            amp[-1] *= 0.5  # the Nyquist term, cos(kθ/2), counted once
            tail = np.concatenate([np.cumsum(amp[::-1])[::-1][1:], [0.0]])  # tail[K]: harmonics above K
            K = int(np.argmax(tail <= drop * np.max(np.abs(samples))))
            m = np.arange(K + 1)
            scale = np.where((m == 0) | (m == self.k // 2), 1.0, 2.0)[:, None]
            self.harmonics = m
            self.coefficients = np.concatenate([scale * c[: K + 1].real, -scale[1:] * c[1 : K + 1].imag])

    def __call__(self, theta):
        theta = np.asarray(theta, dtype=float)
        shape = (theta.size,) + self.S.shape[1:]
        if self.harmonics is not None:
            # e^{imθ} by repeated products of e^{iθ}: one transcendental per angle (round-off
            # grows like m·ε, 1e-14 at the 128th harmonic, below the dropped harmonics' 0.1·tol)
            z = np.exp(1j * (theta - self.start))
            e = np.cumprod(np.broadcast_to(z[:, None], (theta.size, self.harmonics.size)), axis=1) / z[:, None]
            W = np.concatenate([e.real, e.imag[:, 1:]], axis=1)
            return (W @ self.coefficients).reshape(shape)
        W = _dirichlet(theta - self.start, self.k)
        return (W @ self.S.reshape(self.k, -1)).reshape(shape)
