"""The archive as one long (tidy) table: one row per (crank angle, speed, case, mode), C order
as in the archive (``fkev export``, :meth:`SweepResults.to_csv <fkev_slepc.api.study.SweepResults.to_csv>`).

Columns ``crank_angle_deg, speed_rad_s, case, mode, frequency_hz, damping_ratio, status``. The
damping ratio is the archive's ``damping_ratio`` when it has one, else ζ = −Re λ / |λ| from the
eigenvalues (the modal damping of λ = −ζω_n ± iω_n√(1−ζ²); negative for a growing mode). Modes a
point did not find, and every mode of a point that did not converge, have empty frequency and
damping fields; ``status`` says why.
"""

from __future__ import annotations

import csv

import numpy as np

from fkev_slepc.archive import products as P

# the archive's names (fkev_slepc/archive/products.py): crank_angle_deg, speed_rad_s, case, mode,
# frequency_hz, damping_ratio, status
COLUMNS = (P.ANGLE, P.SPEED, P.CASE, P.MODE, P.FREQUENCY.path, P.DAMPING.path, P.STATUS_VAR.path)


def table(res) -> dict[str, np.ndarray]:
    """The columns of the long table, each a flat array over (angle, speed, case, mode)."""
    na, ns, nc = res.status.shape
    nm = len(res.modes)
    ia, js, kc, lm = np.meshgrid(np.arange(na), np.arange(ns), np.arange(nc), np.arange(nm), indexing="ij")
    freq = res.frequency()
    zeta = np.where(np.isfinite(freq), res.damping_ratio, np.nan)
    names = np.broadcast_to(res.status_names[..., None], (na, ns, nc, nm))
    cols = (res.crank_angle_deg[ia], res.speed_rad_s[js], np.asarray(res.cases)[kc], res.modes[lm], freq, zeta, names)
    return {name: c.ravel() for name, c in zip(COLUMNS, cols)}


def write_csv(columns: dict[str, np.ndarray], fh) -> None:
    """Write the columns as CSV (full precision, ``repr`` of floats; NaN as an empty field)."""
    def cell(v):
        if isinstance(v, (float, np.floating)):
            return "" if not np.isfinite(v) else repr(float(v))
        return str(v)

    w = csv.writer(fh, lineterminator="\n")
    w.writerow(COLUMNS)
    cols = [columns[c].tolist() for c in COLUMNS]
    w.writerows([[cell(v) for v in row] for row in zip(*cols)])
