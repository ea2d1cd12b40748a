"""``fkev info ARCHIVE``: what a sweep archive holds, in a few lines.

Grid, cases, counts by status (every point accounted for), per-mode frequency range of each
case, unstable and divergent regions as crank-angle intervals (frozen-time verdicts; the line
``cycle`` points to ``fkev floquet`` for the verdict over a revolution), failure messages, solver
settings (a short table) and run time; with ``--crossings`` the crank speeds at which each
mode's frequency meets a crank-order line k·Ω/2π (the circles of the Campbell diagram). The
archive is verified first (``fkev verify``): exit code 0 for an intact archive, 2 for a
missing, unreadable or damaged one.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from fkev_slepc.model.plane import Plane
from fkev_slepc.scene.units import RAD_S_PER_RPM, with_rpm

from .common import ARCHIVE_FLAGS, add_plane_selection, flag_words


def add_parser(sub) -> None:
    p = sub.add_parser("info", help="summarise a sweep archive",
                       description="Grid, status counts, frequency ranges, unstable/divergent regions, "
                       "solver settings and run time of an fkev archive.")
    p.add_argument("archive", type=Path, help="archive (.h5, or .h5.part of an unfinished run)")
    p.add_argument("--errors", type=int, default=5, metavar="N", help="failure messages to show (default 5)")
    p.add_argument("--crossings", action="store_true",
                   help="list the Campbell crossings: speeds where a mode's frequency meets a crank order k·Ω/2π")
    p.add_argument("--angle", type=float, metavar="DEG",
                   help="--crossings: crank angle (default 10 if on the grid, else the first)")
    p.add_argument("--orders", type=int, metavar="K", help="--crossings: crank orders 1..K (default: enough to "
                   "reach the highest frequency, at most 8)")
    add_plane_selection(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from fkev_slepc.sweep.parallel import world
    from fkev_slepc.archive.reader import ArchiveError, load
    from fkev_slepc.archive.verify import verify

    if world().rank != 0:  # under mpiexec: one report
        return 0
    check = verify(args.archive)  # never show the numbers of a damaged archive
    if check.writer is not None:  # a live run's .part: what is there so far
        print(f"fkev info: {check.summary()}")
        return 0
    if not check.ok:
        print(f"fkev info: {check.summary()}", file=sys.stderr)
        return 2
    try:
        res = load(args.archive, verify=False, plane=args.plane)  # verified above
    except ArchiveError as err:
        print(f"fkev info: {flag_words(err, ARCHIVE_FLAGS)}", file=sys.stderr)
        return 2
    lines = report(res, args.errors)
    if args.crossings:
        try:
            lines += crossing_lines(res, args.angle, args.orders)
        except ArchiveError as err:
            print(f"fkev info: {flag_words(err, ARCHIVE_FLAGS)}", file=sys.stderr)
            return 2
    print("\n".join(lines))
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
    rpm = res.speeds_in_rpm
    na, ns, nc = res.status.shape
    counts = status_counts(res.status)
    total = sum(counts.values())
    waiting = pending_products(res.path)
    complete = "complete" if int(at.get("complete", 0)) else "INCOMPLETE" + (
        ": " + "; ".join(f"{name} {k} of {n} units pending" for name, k, n in waiting) if waiting else "")
    lines = [
        f"{res.path}: {res.title}",
        f"  archive     {at.get('format')} v{at.get('format_version')}, {complete}; created {at.get('created')}",
        f"  crank angle {describe(res.crank_angle_deg, 'deg')}",
        f"  speed       {describe(res.speed_rad_s, 'rad/s')}"
        + (f" ({describe(res.speed_rad_s / RAD_S_PER_RPM, 'rpm')})" if rpm else ""),
        f"  cases       {', '.join(res.cases)}",
        f"  modes       {len(res.modes)} per point; {at.get('n_free', '?')} free DOFs; elements per link "
        f"{', '.join(str(n) for n in res.elements_per_link())}"
        + ("; out of plane (bending out of the plane and torsion, docs/theory.md §19)"
           if Plane.parse(res.plane).transverse else ""),
        f"  points      {total} = {na} x {ns} x {nc}"
        + (" (all accounted for)" if total == na * ns * nc and counts["pending"] == 0 else ""),
        "  status      " + ", ".join(f"{k} {v}" for k, v in counts.items()),
    ] + _planes(res)
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
    lines.append("  damping ratio, smallest over the reported modes of converged points (frozen-time; < 0: growing "
                 "while frozen):")
    zeta = np.where(conv[..., None], res.damping_ratio, np.nan)
    for jc, case in enumerate(res.cases):
        z = zeta[:, :, jc]
        lines.append(f"    {case:<17} " + (f"{np.nanmin(z):.4g}" if np.any(np.isfinite(z)) else "-"))
    regions, cycle_growth = [], _floquet_growth(res.path)
    for status in (Status.UNSTABLE, Status.DIVERGENT):
        for js, speed in enumerate(res.speed_rad_s):
            for jc, case in enumerate(res.cases):
                mask = res.status[:, js, jc] == status.code
                if mask.any():
                    regions.append(f"    {status.value:<9} {case} at {speed:g} rad/s: "
                                   f"{intervals(res.crank_angle_deg, mask)} ({int(mask.sum())} points, "
                                   f"{_severity(res, status, mask, js, jc, cycle_growth.get(jc, {}).get(js))})")
    lines.append("  unstable/divergent regions (frozen-time):" + ("" if regions else " none"))
    lines.extend(regions)
    cycle = _floquet_lines(res.path)
    if cycle:
        lines.extend(cycle)
    elif np.any(res.speed_rad_s != 0):
        moving = ",".join(f"{w:g}" for w in res.speed_rad_s if w != 0)
        lines.append("  cycle       frozen-time verdicts hold the matrices at each crank angle; whether vibration grows "
                     f"over a revolution: fkev floquet {at.get('scene_source') or 'SCENE'} --speeds {moving}")
    lines.extend(_errors(res, n_errors))
    if not int(at.get("complete", 0)):
        name = waiting[-1][0] if waiting else "sweep"
        lines.append(f"  resume      {resume_command(at, name)}")
    settings = solver_settings(res)
    lines.extend(settings_table(settings))
    lines.append(f"  thresholds  imag_tol {at.get('imag_tol')}, damping_tol {at.get('damping_tol')}")
    lines.extend(_tracking(res))
    lines.append(f"  run         {float(at.get('wall_time_s', 0.0)):.1f} s wall on {at.get('n_ranks', '?')} rank(s); "
                 f"fkev {at.get('fkev_version')}, PETSc {at.get('petsc_version')}, SLEPc {at.get('slepc_version')}, "
                 f"h5py {at.get('h5py_version')}, {at.get('mpi_version')}")
    lines.append(f"  command     {at.get('command_line', '?')}")
    return lines


def settings_table(settings: dict) -> list[str]:
    """The solver settings as a short table: the engine, then one row per option with its
    value and where it came from (command line, scene, default)."""
    if not settings:
        return ["  solver      -"]
    versions = ", ".join(f"{k.split('_')[0].upper().replace('PETSC', 'PETSc').replace('SLEPC', 'SLEPc')} {settings[k]}"
                         for k in ("petsc_version", "slepc_version") if k in settings)
    head = f"  solver      engine {settings.get('engine', '?')}" + (f" ({versions})" if versions else "")
    options, sources = settings.get("options") or {}, settings.get("option_sources") or {}
    rows = [(k, str(v), sources.get(k, "default").replace("_", " ")) for k, v in sorted(options.items())]
    if not rows:  # the dense engine: its few scalar settings
        rows = [(k, str(v), "") for k, v in sorted(settings.items())
                if k not in ("engine", "petsc_version", "slepc_version") and not k.startswith("last_")
                and not isinstance(v, (dict, list))]
    width = max(len(k) for k, _, _ in rows) if rows else 0
    lines = [head] + [f"    {k:<{width}}  {v:<14} {src}".rstrip() for k, v, src in rows]
    cc = settings.get("cross_check")
    if isinstance(cc, dict):
        lines.append(f"    cross-check vs {cc.get('other_engine')}: max relative frequency difference "
                     f"{float(cc.get('max_rel_diff', float('nan'))):.2e} over {cc.get('points')} points")
    return lines


def crossing_lines(res, angle: float | None = None, orders: int | None = None) -> list[str]:
    """Campbell crossings at one crank angle: for each case and mode, the crank speeds Ω where
    the frequency meets k·Ω/2π (linear interpolation between neighbouring archived speeds,
    :func:`fkev_slepc.plots.maps.crossings`; the points circled in ``fkev plot --kind campbell``)."""
    from fkev_slepc.archive.reader import ArchiveError
    from fkev_slepc.plots.common import pick_angle
    from fkev_slepc.plots.maps import MAX_DEFAULT_ORDERS, crossings


    if res.speed_rad_s.size < 2:
        raise ArchiveError(f"--crossings: {res.path} has one crank speed; crossings need a speed sweep")
    if orders is not None and orders < 1:
        raise ArchiveError(f"--orders: must be >= 1 (got {orders})")
    a = pick_angle(res, angle)
    f = res.frequency(order="sorted")[a]  # (speed, case, mode), NaN where not converged
    om = res.speed_rad_s
    if orders is None:
        top = om.max() / (2 * np.pi)
        fmax = float(np.nanmax(f)) if np.any(np.isfinite(f)) else 0.0
        orders = int(min(MAX_DEFAULT_ORDERS, max(1, np.ceil(fmax / top)))) if top > 0 else 1
    rpm = res.speeds_in_rpm
    lines = [f"  crossings   at θ = {res.crank_angle_deg[a]:g} deg, crank orders k = 1..{orders} "
             f"(speeds {om.min():g}-{om.max():g} rad/s, linear between grid speeds):"]
    for c, case in enumerate(res.cases):
        for m, mode in enumerate(res.modes):
            for k in range(1, orders + 1):
                for w, hz in zip(*crossings(om, f[:, c, m], k)):
                    lines.append(f"    {case:<17} mode {mode} x order {k}: Ω = {with_rpm(float(w), rpm)}, f = {hz:.6g} Hz")
    if len(lines) == 1:
        lines.append("    none in the archived speed range")
    return lines


def _severity(res, status, mask, js, jc, floquet=None) -> str:
    """Unstable: smallest ζ and the worst frozen Re λ; divergent: the largest real eigenvalue.
    No growth per crank revolution stretched from a frozen eigenvalue (it holds for a fraction of
    a turn): the Floquet max|μ| of that speed when the archive has it (``floquet``), else a pointer."""
    from fkev_slepc.status import Status

    if status == Status.DIVERGENT:
        return f"largest real eigenvalue {np.nanmax(res.max_real[:, js, jc][mask]):.4g} 1/s"
    zmin = np.nanmin(res.damping_ratio[:, js, jc][mask])
    worst = np.nanmax(res.eigenvalue[:, js, jc][mask].real)
    cycle = (f"over a revolution (Floquet) max|μ| - 1 = {floquet - 1:.3g}" if floquet is not None
             else "not a growth per revolution: fkev floquet")
    return f"min damping ratio {zmin:.3g}, max Re λ {worst:.4g} 1/s; frozen-time, {cycle}"


def _floquet_growth(path) -> dict:
    """{case index: {speed index: Floquet max|μ|}} of an archive with the ``/floquet`` product, else {}."""
    import h5py

    from fkev_slepc.archive import products as P

    with h5py.File(path, "r") as f:
        if P.FLOQUET.status not in f:
            return {}
        mx = f[P.MAX_ABS_MULTIPLIER.path][()]
    return {jc: {js: float(mx[js, jc]) for js in range(mx.shape[0]) if np.isfinite(mx[js, jc])}
            for jc in range(mx.shape[1])}


def resumed_by(product: str) -> str:
    """The fkev command that continues ``product`` (a product's name) of an archive."""
    from fkev_slepc.archive import products as P

    return {P.SWEEP.name: "run", P.DESIGN.name: "design", P.FLOQUET.name: "floquet",
            P.RESPONSE.name: "response", P.PLANE_OUT.name: "run"}[product]


def pending_products(path) -> list[tuple[str, int, int]]:
    """(product, pending units, units) of every product of the archive with pending units, in
    the order they are written (the frozen sweep first)."""
    import h5py

    from fkev_slepc.archive import products as P
    from fkev_slepc.status import Status

    out = []
    with h5py.File(path, "r") as f:
        for product in P.PRODUCTS:
            if product.status in f:
                st = np.asarray(f[product.status][()], dtype=np.uint8)
                k = int(np.count_nonzero(st == Status.PENDING.code))
                if k:
                    out.append((product.name, k, int(st.size)))
    return out


def resume_command(attrs: dict, product: str) -> str:
    """The command that continues ``product``: the archived command line of that command with
    ``--resume``, else its form with the scene and the options of the interrupted run to repeat."""
    from fkev_slepc.archive.store import text

    word = f"fkev {resumed_by(product)} "
    for key in ("last_command_line", "command_line"):
        cmd = text(attrs.get(key, ""))
        if cmd.startswith(word):  # --force would start over: dropped
            words = [w for w in cmd.split(" ") if w != "--force"]
            return " ".join(words + ([] if "--resume" in words else ["--resume"]))
    return f"{word}{attrs.get('scene_source') or 'SCENE'} (the options of the interrupted run) -o ARCHIVE --resume"


def _floquet_lines(path) -> list[str]:
    """The cycle verdict of an archive written by ``fkev floquet`` (its ``/floquet`` product), else []:
    while speeds are pending, no verdict, only what is pending."""
    import h5py

    from fkev_slepc.archive import products as P

    with h5py.File(path, "r") as f:
        if P.FLOQUET.status not in f:
            return []
    pending = [(k, n) for name, k, n in pending_products(path) if name == "floquet"]
    if pending:
        k, n = pending[0]
        return [f"  cycle       Floquet verdict of this archive (fkev floquet): pending ({k} of {n} speeds not solved "
                "yet; no verdict until they are: see resume below)"]
    from fkev_slepc.cli.floquet import lines
    from fkev_slepc.sweep.floquet_run import read_floquet

    return ["  cycle       Floquet verdict of this archive (fkev floquet):"] + ["  " + ln for ln in
                                                                              lines(read_floquet(path).as_dict())[1:]]


def _planes(res) -> list[str]:
    """The planes of a two-plane archive: the out-of-plane sweep's size, its points by status and,
    while some are pending, the command that continues it (one-plane archives: nothing)."""
    from fkev_slepc.archive import products as P
    from fkev_slepc.archive.store import status_counts

    if len(res.planes) < 2:
        return []
    out = res.on_plane("out")
    counts = status_counts(out.status)
    lines = [f"  planes      in (root group) and out (/planes/out: bending out of the plane and torsion, "
             f"{out.attrs.get('n_free', '?')} free DOFs; fkev plot/margins/export --plane out)",
             "    out       " + ", ".join(f"{k} {v}" for k, v in counts.items())]
    if counts["pending"]:
        lines.append(f"    out       {counts['pending']} of {out.status.size} points pending: "
                     f"{resume_command(res.attrs, P.PLANE_OUT.name)}")
    return lines


def _tracking(res) -> list[str]:
    """What mode tracking found (``/tracking`` attributes, docs/tracking.md)."""
    from fkev_slepc.archive.tracks import read_tracking

    tracking = read_tracking(res.path, res.table_plane)
    t, fb = tracking["attrs"], tracking["fallback"]
    if "ambiguous_links" not in t:  # nothing tracked: sweep/tracking_angles.py wrote only the thresholds
        if "mac_min" not in t and "tracking_open_loops" in res.attrs:  # archives written before refinement existed
            return [f"  tracking    MAC along crank angle; {int(res.attrs['tracking_open_loops'])} (speed, case) "
                    "line(s) whose modes come back permuted after a revolution"]
        return ["  tracking    none (one angle and one speed)"]
    na, ns, nc = res.status.shape
    out = [f"  tracking    MAC >= {t['mac_min']:g} with a margin >= {t['mac_margin']:g} over the competitors; "
           f"links halved at most {int(t['max_halvings'])} times",
           f"    along crank angle: {int(t['ambiguous_links'])} ambiguous (link, line) pairs on the grid; "
           f"{int(t['refined_angles'])} extra angles solved ({int(t['refined_points'])} points, /tracking/refined"
           + _budget_words(t) + "); "
           f"{int(t['unresolved_links'])} ambiguous links left; {int(t.get('crossings', 0))} crossings confirmed; "
           f"{int(t['open_loops'])} open loops"]
    if fb is not None and fb.any():
        which = ", ".join(f"{res.speed_rad_s[s]:g} rad/s {res.cases[c]}" for s, c in np.argwhere(fb))
        out.append(f"    {int(fb.sum())} of {ns * nc} (speed, case) lines in SORTED order (fallback): {which}")
    else:
        out.append(f"    all {ns * nc} (speed, case) lines tracked")
    if "speed_fallback_lines" in t and ns > 1:
        out.append(f"    along speed: {int(t['speed_fallback_lines'])} of {na * nc} (angle, case) lines ambiguous "
                   "or crossing, left in sorted order")
    return out


def _errors(res, n: int) -> list[str]:
    errs = res.errors()
    if not errs:
        return ["  errors      none"]
    out = [f"  errors      {len(errs)} point(s) failed or did not converge; first {min(n, len(errs))}:"]
    out += [f"    {e.angle_deg:g} deg, {e.speed_rad_s:g} rad/s, {e.case}: {e.message}" for e in errs[:n]]
    return out


def _budget_words(t: dict) -> str:
    """``, budget 240 points: exhausted`` (archives written before the budget: nothing)."""
    if "refine_budget_points" not in t:
        return ""
    return f", budget {int(t['refine_budget_points'])} points" + (": exhausted" if t.get("refine_budget_exhausted") else "")
