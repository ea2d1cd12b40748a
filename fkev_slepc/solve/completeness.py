"""Whether the SLEPc engine's pairs hold the lowest frequencies (docs/numerical-stability.md).

Shift-and-invert about 0 converges the eigenvalues nearest 0 first: every eigenvalue inside the
disc |λ| ≤ R (R = the largest |λ| converged) is found. The lowest frequencies are the smallest
Im λ > 0, and a mode with |Re λ| ≫ Im λ (strongly divergent or flutter-unstable points) can lie
outside that disc although its frequency is below the reported ones: Bahgat-Willmert with 10
elements at 10°, 5e4 rad/s, no_pseudo_normal gave SLEPc f₁ = 679.2 Hz, the whole spectrum 514.9 Hz.

A missed frequency f_m < f_k (k-th reported) needs |Re λ| > A = sqrt(R² - (2π f_k)²). When the
converged eigenvalues themselves have real parts of that size (:func:`far_modes_possible`), the
point is checked against the whole spectrum (the dense kernel, up to ``stability.DENSE_LIMIT``
DOFs; :func:`missed_modes`) and solved again by the dense engine if it missed one; above that size
the SLEPc engine solves it again for 3x, then 9x the frequencies (a wider disc) and flags it
(:func:`uncertified`) if the suspicion remains.
"""

from __future__ import annotations

import numpy as np

from fkev_slepc.solve.modes import reported

FAR_FRACTION = 0.5  # converged |Re λ| from this fraction of A on: modes outside the disc are possible


def far_modes_possible(lam: np.ndarray, n_modes: int, imag_tol: float) -> bool:
    """Whether eigenvalues outside the converged disc could have frequencies below the reported ones."""
    lam = np.asarray(lam, dtype=complex)
    lam = lam[np.isfinite(lam)]
    osc, _ = reported(lam, n_modes, imag_tol)
    if osc.size == 0:
        return False
    radius, top = float(np.abs(lam).max()), float(lam[osc].imag.max())
    reach = np.sqrt(max(radius * radius - top * top, 0.0))
    return bool(np.abs(lam.real).max() >= FAR_FRACTION * reach)


def missed_modes(lam: np.ndarray, spectrum: np.ndarray, n_modes: int, imag_tol: float) -> str:
    """'' or which of the ``n_modes`` lowest frequencies of the whole ``spectrum`` ``lam`` misses."""
    osc, _ = reported(lam, n_modes, imag_tol)
    whole, _ = reported(spectrum, n_modes, imag_tol)
    got, ref = np.asarray(lam)[osc].imag, np.asarray(spectrum)[whole].imag
    k = min(got.size, ref.size)
    low = np.flatnonzero(ref[:k] < got[:k] * (1 - 1e-6))
    if not low.size:
        return ""
    i = int(low[0])
    return (f"SLEPc missed the lowest modes: the whole spectrum (dense LAPACK) has f{i + 1} = "
            f"{ref[i] / (2 * np.pi):.6g} Hz, SLEPc {got[i] / (2 * np.pi):.6g} Hz (eigenvalues with |Re λ| >> Im λ "
            "are not the nearest to 0)")


def uncertified(lam: np.ndarray, n_modes: int, imag_tol: float, n: int, limit: int) -> str:
    """The message of a point whose lowest frequencies cannot be certified (too large for the dense check)."""
    lam = np.asarray(lam, dtype=complex)
    lam = lam[np.isfinite(lam)]
    osc, _ = reported(lam, n_modes, imag_tol)
    return (f"lowest frequencies not certified: converged eigenvalues reach |Re λ| = {np.abs(lam.real).max():.4g} 1/s "
            f"within |λ| <= {np.abs(lam).max():.4g} 1/s, so a mode below {lam[osc].imag.max() / (2 * np.pi):.6g} Hz "
            f"could lie outside what SLEPc searched (n = {n} > {limit}: no dense whole-spectrum check)")
