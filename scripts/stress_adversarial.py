"""``scripts/stress.py adversarial``: absurd geometry and magnitudes, deeply divergent speeds.

Every variant of Bahgat-Willmert (docs/numerical-stability.md, "Adversarial inputs") is solved at
a few crank angles and cases by the dense engine, the SLEPc engine and ``--solver auto`` in
process, with numpy warnings turned into errors; its scene also goes through ``fkev check``.
Counted: outcomes per engine; exceptions (a traceback would reach the user); RuntimeWarnings;
points both engines call converged whose frequencies or statuses differ (one of them is wrong
but marked converged: "wrong but ok"); ``fkev check`` verdicts on scenes whose operators overflow.
"""

from __future__ import annotations

import warnings

import numpy as np

from stresslib import ROOT, Tally

BW = ROOT / "runs/bahgat-willmert-1976.toml"
ANGLES = (10.0, 100.0, 250.0)
CASES = ("structure", "full", "no_pseudo_normal")
AGREE = 1e-6  # relative frequency agreement of two converged engines (both accurate to ~1e-10 here)


def _replace(text: str, pairs) -> str:
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new)
    return text


def variants():
    """(label, scene text, speeds) of the adversarial cases."""
    text = BW.read_text()
    geometry = ("length_m = 0.1270", "length_m = 0.2794", "length_m = 0.2667", "position_m = [0.254, 0.0]")
    for k in (1e-6, 1e-3, 1e3, 1e6):  # the whole linkage scaled
        new = [(g, g.replace(v, f"{float(v) * k:.6g}")) for g, v in
               zip(geometry, ("0.1270", "0.2794", "0.2667", "0.254"))]
        yield f"linkage scaled by {k:g}", _replace(text, new), (0.0, 500.0 / max(k, 1e-3) ** 0.5)
    for crank in (1e-8, 1e-5, 1e-3):  # a vanishing crank, ground 0.254 m
        yield f"crank {crank:g} m", _replace(text, [(geometry[0], f"length_m = {crank:g}")]), (0.0, 500.0)
    for key, old, values in (("density", "density_kg_m3 = 7760.0", (1e-300, 1e-30, 1e30, 1e300)),
                             ("area", "area_m2 = 1.61e-4", (1e-30, 1e-12, 1e10, 1e300)),
                             ("modulus", "youngs_modulus_pa = 2.07e11", (1e-300, 1e-3, 1e30, 1e300)),
                             ("second moment", "second_moment_m4 = 8.66e-9", (1e-40, 1e-20, 1e10, 1e300))):
        for v in values:
            yield f"{key} {v:g}", _replace(text, [(old, old.split("=")[0] + f"= {v:g}")]), (0.0, 500.0)
    for w in (1e4, 5e4, 1e5, 1e6, 1e9, 1e155, 1e200):  # deeply divergent, then overflowing speeds
        yield f"speed {w:g} rad/s", text, (w,)


def cmd_adversarial(args) -> Tally:
    from fkev_slepc.cli.check import check_scene
    from fkev_slepc.scene import SceneError
    from fkev_slepc.solve.engines import make_engine
    from fkev_slepc.solve.finite import overflow_problems
    import fkev_slepc as fk
    import tempfile
    from pathlib import Path

    t = Tally("adversarial inputs (Bahgat-Willmert variants; dense, SLEPc, auto)")
    n_variants = 0
    with tempfile.TemporaryDirectory() as tmp:
        for label, text, speeds in variants():
            if args.n and n_variants >= args.n:
                break
            n_variants += 1
            path = Path(tmp) / "v.toml"
            path.write_text(text)
            t.add("variants")
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("error", RuntimeWarning)
                    check_scene(path)
                checked = "accepted"
            except SceneError as err:
                checked = "refused" if any("overflow" in p.message for p in err.problems) else "refused (other)"
            except RuntimeWarning as w:
                t.add("RuntimeWarnings")
                _note(t, label, f"check: {w}")
                checked = "warned"
            except Exception as exc:  # noqa: BLE001 - counting every escape is the point
                t.add("crashes (exceptions)")
                _note(t, label, f"check: {type(exc).__name__}: {exc}")
                continue
            t.add(f"fkev check {checked}")
            study = fk.load(path)
            for angle in ANGLES:
                for speed in speeds:
                    for case in CASES:
                        _point(t, study, label, angle, speed, case, speeds, checked)
    return t


def _point(t: Tally, study, label, angle, speed, case, speeds, checked) -> None:
    if case == "structure" and speed != speeds[0]:
        return
    res = {}
    for solver in ("dense", "slepc", "auto"):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", RuntimeWarning)
                r = study.point(angle, speed, case, solver=solver)
        except RuntimeWarning as w:
            t.add("RuntimeWarnings")
            _note(t, label, f"{angle:g}° {speed:g} {case} {solver}: {w}")
            continue
        except Exception as exc:  # noqa: BLE001
            t.add("crashes (exceptions)")
            _note(t, label, f"{angle:g}° {speed:g} {case} {solver}: {type(exc).__name__}: {exc}")
            continue
        res[solver] = r
        t.add(f"{solver} points {r.status.value}")
        if checked == "refused" and r.converged:
            t.add(f"{solver} converged on a scene fkev check refuses")
    d, s = res.get("dense"), res.get("slepc")
    if d is not None and s is not None and d.converged and s.converged:
        t.add("points both engines converged")
        rel = np.max(np.abs(d.frequency_hz - s.frequency_hz) / np.abs(d.frequency_hz))
        if not rel <= AGREE or d.status != s.status:
            t.add("wrong but ok (converged engines disagree)")
            _note(t, label, f"{angle:g}° {speed:g} {case}: dense {d.status.value} {d.frequency_hz}, "
                           f"slepc {s.status.value} {s.frequency_hz}")
        else:
            t.high("relative frequency difference dense vs SLEPc", rel)


def _note(t: Tally, label: str, text: str) -> None:
    """One note per variant (the first), so that the report names every variant that misbehaved."""
    if not any(n.startswith(label + ":") for n in t.notes):
        t.notes.append(f"{label}: {text}")
