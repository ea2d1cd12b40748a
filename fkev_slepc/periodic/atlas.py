"""Where parametric bands can sit, to first order: Hsu's conditions on modal coordinates
(docs/theory.md §18.9).

``band_atlas(freqs, coefficients, max_order)`` lists, for frequencies ω₁ … ω_r (rad/s) and the
complex Fourier coefficients Bⁿ (n = 1 … N) of a mass-normalised periodic stiffness coupling, every
principal (2ωₖ/n), sum ((ωⱼ + ωₖ)/n) and difference ((ωⱼ − ωₖ)/n) band that first-order theory
opens, with its speed range and its growth rate at the centre. ``fourier_coefficients(samples)``
gives Bⁿ from equispaced samples of B over one period. A guide, not a verdict: the monodromy
decides (periodic/floquet.py); what the first order leaves out is in §18.9.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class AtlasBand:
    """One first-order band: Ω in [lower, upper] (rad/s), centre (ωⱼ ± ωₖ)/n, growth rate there (1/s)."""

    kind: str  # "principal", "sum" or "difference"
    modes: tuple[int, int]  # (j, k), 1-based: ωⱼ >= ωₖ
    order: int  # n
    centre: float
    lower: float
    upper: float
    growth_rate: float

    @property
    def label(self) -> str:
        """As the Floquet bands are labelled (periodic/bands.py): 2ω̄ₖ/n, (ω̄ₖ+ω̄ⱼ)/n, (ω̄ⱼ-ω̄ₖ)/n."""
        j, k = self.modes
        if self.kind == "principal":
            return f"2ω̄{k}/{self.order}"
        return f"(ω̄{k}+ω̄{j})/{self.order}" if self.kind == "sum" else f"(ω̄{j}-ω̄{k})/{self.order}"

    @property
    def width(self) -> float:
        return self.upper - self.lower


def fourier_coefficients(samples, orders: int) -> np.ndarray:
    """Bⁿ (orders, r, r) complex, n = 1 … ``orders``, of B(t) sampled at ``len(samples)`` equispaced
    points of one period (samples (m, r, r)): B(t) = B⁰ + Σₙ (Bⁿ e^{inΩt} + conj(Bⁿ) e^{−inΩt})."""
    b = np.asarray(samples, dtype=float)
    m = b.shape[0]
    if not 2 * orders < m:
        raise ValueError(f"orders: {orders} harmonics need more than {2 * orders} samples (got {m})")
    return (np.fft.fft(b, axis=0) / m)[1:orders + 1]  # Bⁿ = mean of B(t) e^{−inΩt}: np.fft's sign


def band_atlas(freqs, coefficients, max_order: int | None = None) -> list[AtlasBand]:
    """Every first-order band of ``freqs`` (r,) rad/s and ``coefficients`` Bⁿ (N, r, r), n = 1 … N
    (docs/theory.md §18.9), of order n <= ``max_order`` (default N), sorted by centre."""
    w = np.asarray(freqs, dtype=float)
    B = np.asarray(coefficients, dtype=complex)
    n_max = B.shape[0] if max_order is None else min(int(max_order), B.shape[0])
    r = w.size
    lo, hi = np.triu_indices(r)  # index pairs lo <= hi
    swap = w[lo] > w[hi]
    k, j = np.where(swap, hi, lo), np.where(swap, lo, hi)  # ωⱼ >= ωₖ
    root = np.sqrt(w[j] * w[k])
    out = []
    for n in range(1, n_max + 1):
        Bn = B[n - 1]
        for kind, centre, lam in (("sum", w[j] + w[k], (Bn[k, j] * np.conj(Bn[j, k])).real),
                                  ("difference", w[j] - w[k], (-np.conj(Bn[k, j]) * Bn[j, k]).real)):
            half = np.sqrt(np.where(lam > 0, lam, 0.0)) / root  # the half-width in nΩ
            for i in np.flatnonzero((lam > 0) & (centre > 0) & ((kind == "sum") | (j != k))):
                out.append(AtlasBand("principal" if j[i] == k[i] else kind, (int(j[i]) + 1, int(k[i]) + 1), n,
                                     float(centre[i] / n), float((centre[i] - half[i]) / n),
                                     float((centre[i] + half[i]) / n), float(half[i] / 2.0)))
    return sorted(out, key=lambda b: b.centre)
