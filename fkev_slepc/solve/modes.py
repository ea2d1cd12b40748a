"""From raw eigenpairs to what users read: frequencies, stability, status; MAC tracking.

docs/theory.md §10.3-10.4: modes are the eigenvalues with Im λ > 0 sorted by Im λ;
real eigenvalues are divergence and never frequencies. Stability (docs/stability.md): each
reported mode has a damping ratio ζ = -Re λ/|λ| (flutter verdicts cover the reported modes
only); divergence is the engine's whole-spectrum verdict (solve/stability.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.solve.protocol import EigenSolution
from fkev_slepc.solve.thresholds import IMAG_TOL
from fkev_slepc.scene import DAMPING_TOL
from fkev_slepc.status import Status
from fkev_slepc.solve.stability import damping_ratio, real_positive


@dataclass(frozen=True)
class PointModes:
    eigenvalue: np.ndarray  # complex (n_modes,), NaN where fewer modes were found
    frequency_hz: np.ndarray  # (n_modes,)
    residual: np.ndarray  # (n_modes,) acceptance.pair_error of each mode
    max_real: float  # max Re λ over the reported modes and the located real eigenvalues (NaN if none)
    divergent: np.ndarray  # the positive real eigenvalues located (1/s)
    status: Status
    message: str = ""
    shapes: np.ndarray | None = None  # complex (n_free, n_modes)
    solver: str = ""
    damping_ratio: np.ndarray | None = None  # (n_modes,) ζ = -Re λ/|λ| of each reported mode
    divergence_check: str = ""  # how divergence was decided, and over which part of the spectrum

    @property
    def min_damping_ratio(self) -> float:
        """Smallest ζ of the reported modes (NaN if none): the flutter indicator."""
        z = self.damping_ratio
        return float(np.nanmin(z)) if z is not None and np.any(np.isfinite(z)) else float("nan")


# hoisted: np.finfo costs microseconds per call, and reported() runs several times per point
_TINY = np.finfo(float).tiny
CNAN = complex(np.nan, np.nan)  # a missing eigenvalue: NaN in both parts (NaN + 0j has Im = 0)


def failed(n_modes: int, message: str, solver: str = "") -> PointModes:
    nan = np.full(n_modes, np.nan)
    return PointModes(np.full(n_modes, CNAN), nan, nan, np.nan, np.zeros(0), Status.FAILED, message, None, solver,
                       nan.copy())


def postprocess(
    sol: EigenSolution,
    n_modes: int,
    imag_tol: float | None = None,
    damping_tol: float = DAMPING_TOL,
    want_shapes: bool = False,
) -> PointModes:
    """Select, sort and classify the eigenpairs of one point (docs/theory.md §10.4).

    Status: convergence first; then ``divergent`` from the whole-spectrum verdict
    (``sol.divergence``; without one, from the real eigenvalues among those computed);
    then ``unstable`` if a reported mode has ζ < -damping_tol; else ``ok``. ``imag_tol`` is
    the one the engine decided with (``sol.imag_tol``; another one given is an error), so that
    the modes selected here and the engine's divergence verdict and acceptance agree on what is real.
    """
    lam = np.asarray(sol.eigenvalues, dtype=complex)
    err = np.asarray(sol.errors, dtype=float)
    if imag_tol is not None and imag_tol != sol.imag_tol:  # the verdict and acceptance used the engine's
        raise ValueError(f"imag_tol {imag_tol:g} differs from the {sol.imag_tol:g} the engine decided with "
                         "(build the engine with the same SolveSettings)")
    imag_tol = sol.imag_tol
    osc, _ = reported(lam, n_modes, imag_tol)
    k = osc.size

    eig = np.full(n_modes, CNAN)
    res = np.full(n_modes, np.nan)
    eig[:k] = lam[osc]
    res[:k] = err[osc]
    freq = eig.imag / (2 * np.pi)
    zeta = damping_ratio(eig)
    shapes = None
    if want_shapes and sol.vectors is not None:
        shapes = np.full((sol.vectors.shape[0], n_modes), CNAN)
        shapes[:, :k] = normalize_shapes(sol.vectors[:, osc])

    v = sol.divergence
    if v is not None:
        real_pos, divergent, check = v.real_eigenvalues, v.divergent, f"{v.method} [{v.scope}]"
    else:
        real_pos = real_positive(lam, imag_tol)
        divergent, check = bool(real_pos.size), f"located among the {lam.size} eigenvalues computed"
    parts = np.concatenate([eig.real[:k], real_pos])
    max_real = float(parts.max()) if parts.size else np.nan
    unstable = bool(np.any(zeta[:k] < -damping_tol))

    if not sol.converged or k < n_modes:
        status = Status.NOT_CONVERGED
        msg = sol.message or f"{k} of {n_modes} modes found"
    elif divergent:
        status, msg = Status.DIVERGENT, sol.message
    elif unstable:
        status, msg = Status.UNSTABLE, sol.message
    else:
        status, msg = Status.OK, sol.message
    return PointModes(eig, freq, res, max_real, real_pos, status, msg, shapes, sol.solver, zeta, check)


def reported(lam: np.ndarray, n_modes: int, imag_tol: float = IMAG_TOL) -> tuple[np.ndarray, np.ndarray]:
    """What a point reports: indices of the ``n_modes`` lowest oscillatory eigenvalues
    (Im λ > 0, sorted by Im λ) and the mask of real (divergence) eigenvalues."""
    lam = np.asarray(lam, dtype=complex)
    is_real = np.abs(lam.imag) <= imag_tol * np.maximum(np.abs(lam), _TINY)
    osc = np.flatnonzero(~is_real & (lam.imag > 0))
    return osc[np.argsort(lam.imag[osc], kind="stable")][:n_modes], is_real


def normalize_shapes(X: np.ndarray) -> np.ndarray:
    """Scale each column to unit max modulus with that entry real and positive."""
    X = np.array(X, dtype=complex)
    idx = np.argmax(np.abs(X), axis=0)
    piv = X[idx, np.arange(X.shape[1])]
    piv[piv == 0] = 1.0
    return X / piv


def mac(U: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Modal assurance criterion |uᴴv|² / (uᴴu · vᴴv) between the columns of U and V,
    batched over leading axes: (..., n, a) and (..., n, b) give (..., a, b)."""
    U = np.asarray(U, dtype=complex)
    V = np.asarray(V, dtype=complex)
    num = np.abs(np.einsum("...ki,...kj->...ij", U.conj(), V)) ** 2
    den = np.einsum("...ki,...ki->...i", U.conj(), U).real[..., :, None] * np.einsum(
        "...kj,...kj->...j", V.conj(), V
    ).real[..., None, :]
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def match_modes(prev: np.ndarray, cur: np.ndarray) -> np.ndarray:
    """Mode continuation by greedy MAC (largest first), batched over lines.

    ``prev`` and ``cur`` are (n_lines, n, n_modes); returns ``perm`` (n_lines, n_modes) with
    ``cur[l][:, perm[l, i]]`` the continuation of ``prev[l][:, i]``.
    """
    return greedy_match(mac(prev, cur))


def greedy_match(m: np.ndarray) -> np.ndarray:
    """:func:`match_modes` on a MAC matrix ``m`` (n_lines, n_modes, n_modes), which it overwrites."""
    n_lines, nm = m.shape[0], m.shape[-1]
    perm = np.zeros((n_lines, nm), dtype=int)
    rows = np.arange(n_lines)
    for _ in range(nm):  # n_modes rounds, each vectorised over all lines
        r, c = np.divmod(np.argmax(m.reshape(n_lines, -1), axis=1), nm)
        perm[rows, r] = c
        m[rows, r, :] = -1.0
        m[rows, :, c] = -1.0
    return perm


def percent_error(freq_case: np.ndarray, freq_full: np.ndarray) -> np.ndarray:
    """Signed % error of a simplified case against the full solution (docs/theory.md §12)."""
    return (np.asarray(freq_case) - np.asarray(freq_full)) / np.asarray(freq_full) * 100.0
