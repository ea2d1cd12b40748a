"""``fkev info ARCHIVE``: what a sweep archive holds, in a few lines.

Grid, cases, counts by status (every point accounted for), per-mode frequency range of each
case, unstable and divergent regions as crank-angle intervals, failure messages, solver
settings and run time. The archive is verified first (``fkev verify``): exit code 0 for an
intact archive, 2 for a missing, unreadable or damaged one.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np


def add_parser(sub) -> None:
    p = sub.add_parser("info", help="summarise a sweep archive",
                       description="Grid, status counts, frequency ranges, unstable/divergent regions, "
                       "solver settings and run time of an fkev archive.")
    p.add_argument("archive", type=Path, help="archive (.h5, or .h5.part of an unfinished run)")
    p.add_argument("--errors", type=int, default=5, metavar="N", help="failure messages to show (default 5)")
    p.set_defaults(func=run)


def run(args) -> int:
    from fkev_slepc.sweep.parallel import world
    from fkev_slepc.archive.reader import ArchiveError, load
    from fkev_slepc.archive.verify import verify

    if world().rank != 0:  # under mpiexec: one report
        return 0
    check = verify(args.archive)  # never show the numbers of a damaged archive
    if not check.ok:
        print(f"fkev info: {check.summary()}", file=sys.stderr)
        return 2
    try:
        res = load(args.archive)
    except ArchiveError as err:
        print(f"fkev info: {err}", file=sys.stderr)
        return 2
    print("\n".join(report(res, args.errors)))
    return 0


def describe(values, unit: str) -> str:
    """``73 values, 0 to 360 step 5 deg`` or ``0, 500, 1000 rad/s``."""
    v = np.asarray(values, dtype=float)
    if v.size > 4:
        d = np.diff(v)
        if np.allclose(d, d[0]):
            return f"{v.size} values, {v[0]:g} to {v[-1]:g} step {d[0]:g} {unit}"
        return f"{v.size} values from {v.min():g} to {v.max():g} {unit}"
    return ", ".join(f"{x:g}" for x in v) + f" {unit}"


def intervals(angles, mask) -> str:
    """Runs of consecutive grid angles where ``mask`` holds: ``0-45, 300-360 deg``."""
    m = np.concatenate([[0], np.asarray(mask, dtype=np.int8), [0]])
    starts = np.flatnonzero(np.diff(m) == 1)
    stops = np.flatnonzero(np.diff(m) == -1) - 1
    a = np.asarray(angles, dtype=float)
    parts = [f"{a[s]:g}" if s == e else f"{a[s]:g}-{a[e]:g}" for s, e in zip(starts, stops)]
    return ", ".join(parts) + " deg"


def report(res, n_errors: int = 5) -> list[str]:
    """The lines printed by ``fkev info``."""
    from fkev_slepc.archive.store import status_counts
    from fkev_slepc.status import Status
    from fkev_slepc.archive.reader import solver_settings

    at = res.attrs
    na, ns, nc = res.status.shape
    counts = status_counts(res.status)
    total = sum(counts.values())
    complete = "complete" if int(at.get("complete", 0)) else "INCOMPLETE (resume with fkev run --resume)"
    lines = [
        f"{res.path}: {res.title}",
        f"  archive     {at.get('format')} v{at.get('format_version')}, {complete}; created {at.get('created')}",
        f"  crank angle {describe(res.crank_angle_deg, 'deg')}",
        f"  speed       {describe(res.speed_rad_s, 'rad/s')}",
        f"  cases       {', '.join(res.cases)}",
        f"  modes       {len(res.modes)} per point; {at.get('n_free', '?')} free DOFs; elements per link "
        f"{', '.join(str(n) for n in res.elements_per_link())}",
        f"  points      {total} = {na} x {ns} x {nc}"
        + (" (all accounted for)" if total == na * ns * nc and counts["pending"] == 0 else ""),
        "  status      " + ", ".join(f"{k} {v}" for k, v in counts.items()),
    ]
    lines.append("  frequency range per mode (Hz, converged points):")
    conv = res.converged
    for jc, case in enumerate(res.cases):
        f = np.where(conv[:, :, jc, None], res.frequency_hz[:, :, jc, :], np.nan).reshape(-1, len(res.modes))
        have = np.any(np.isfinite(f), axis=0)
        lo = np.full(f.shape[1], np.nan)
        hi = np.full(f.shape[1], np.nan)
        lo[have], hi[have] = np.nanmin(f[:, have], axis=0), np.nanmax(f[:, have], axis=0)
        cells = [f"{m}: {a:.6g}-{b:.6g}" if np.isfinite(a) else f"{m}: -" for m, a, b in zip(res.modes, lo, hi)]
        lines.append(f"    {case:<17} " + "; ".join(cells))
    regions = []
    for status in (Status.UNSTABLE, Status.DIVERGENT):
        for js, speed in enumerate(res.speed_rad_s):
            for jc, case in enumerate(res.cases):
                mask = res.status[:, js, jc] == status.code
                if mask.any():
                    mr = np.nanmax(res.max_real[:, js, jc][mask])
                    regions.append(f"    {status.value:<9} {case} at {speed:g} rad/s: "
                                   f"{intervals(res.crank_angle_deg, mask)} ({int(mask.sum())} points, "
                                   f"max Re lambda {mr:.4g} 1/s)")
    lines.append("  unstable/divergent regions:" + ("" if regions else " none"))
    lines.extend(regions)
    lines.extend(_errors(res, n_errors))
    settings = solver_settings(res)
    lines.append("  solver      " + (json.dumps(settings, sort_keys=True) if settings else "-"))
    lines.append(f"  thresholds  imag_tol {at.get('imag_tol')}, stability_tol {at.get('stability_tol')}")
    if "tracking_open_loops" in at:
        lines.append(f"  tracking    MAC along crank angle; {int(at['tracking_open_loops'])} (speed, case) "
                     "line(s) whose modes come back permuted after a revolution")
    lines.append(f"  run         {float(at.get('wall_time_s', 0.0)):.1f} s wall on {at.get('n_ranks', '?')} rank(s); "
                 f"fkev {at.get('fkev_version')}, PETSc {at.get('petsc_version')}, SLEPc {at.get('slepc_version')}, "
                 f"h5py {at.get('h5py_version')}, {at.get('mpi_version')}")
    lines.append(f"  command     {at.get('command_line', '?')}")
    return lines


def _errors(res, n: int) -> list[str]:
    import h5py

    with h5py.File(res.path, "r") as f:
        if "errors" not in f or f["errors/index"].shape[0] == 0:
            return ["  errors      none"]
        index = f["errors/index"][()]
        msgs = [m.decode("utf-8", "replace") if isinstance(m, bytes) else str(m) for m in f["errors/message"][()]]
    out = [f"  errors      {len(msgs)} point(s) failed or did not converge; first {min(n, len(msgs))}:"]
    for (a, s, c), m in list(zip(index, msgs))[:n]:
        out.append(f"    {res.crank_angle_deg[a]:g} deg, {res.speed_rad_s[s]:g} rad/s, {res.cases[c]}: {m}")
    return out
