"""The HDF5 product of a run-up (``fkev runup -o``, docs/runup.md): the per-revolution envelopes and
the checkpoint that continues the run (``--resume``), one self-describing file (archive/labelled.py),
rewritten whole (under a temporary name, then moved) at every checkpoint.

Coordinates ``revolution``, ``link``, ``coordinate`` (the integrated unknowns) and ``sample`` (the
open revolution's samples); variables ``time_s``, ``speed_rad_s``, ``peak_stress_pa`` and
``peak_deflection_m`` (revolution[, link]) and the checkpoint ``checkpoint_q``, ``checkpoint_q_dot``
(coordinate), ``open_t``, ``open_q``, ``open_q_dot`` (sample[, coordinate]); root attributes the scene
text, the case, the run's arguments (JSON), ``complete`` and the checkpoint's time, steps and step size.
"""

from __future__ import annotations

import json

import h5py
import numpy as np

from fkev_slepc.archive.labelled import write_labelled
from fkev_slepc.archive.product_types import CASE, SPEED
from fkev_slepc.archive.store import ArchiveMismatch

RUNUP_FORMAT = "fkev-runup"
CHECKPOINT_ATTRS = ("t", "steps", "rejected", "dt", "revolution")


def write_runup(path, result, run) -> None:
    """Write ``result`` (api.runup.RunupResult) with the checkpoint of ``run`` (periodic.runup.Integration)."""
    cp = run.checkpoint()
    n_link, n = len(result.link_names), int(run.system.n)
    rev = np.arange(len(result.time_s))
    coords = {"revolution": (rev, "1", "crank revolution (0: the first)"),
              "link": (list(result.link_names), "1", "link name (scene order)"),
              "coordinate": (np.arange(n), "1", "integrated coordinate (model DOF or reduced basis vector)"),
              "sample": (np.arange(len(cp["buffer_t"])), "1", "sample of the open revolution")}
    table = lambda x: np.array(x, float).reshape(len(rev), n_link)  # noqa: E731
    variables = {
        "time_s": (("revolution",), np.array(result.time_s, float), "s", "time at the revolution's end"),
        SPEED: (("revolution",), np.array(result.speed_rad_s, float), "rad/s", "crank speed at its end"),
        "peak_stress_pa": (("revolution", "link"), table(result.peak_stress_pa), "Pa",
                           "peak extreme-fibre |stress| over the revolution (NaN without fibre distance)"),
        "peak_deflection_m": (("revolution", "link"), table(result.peak_deflection_m), "m",
                              "peak elastic displacement |(u, v)| over the revolution"),
        "checkpoint_q": (("coordinate",), cp["q"], "m or rad", "state at the checkpoint"),
        "checkpoint_q_dot": (("coordinate",), cp["q_dot"], "m/s or rad/s", "rate at the checkpoint"),
        "open_t": (("sample",), cp["buffer_t"], "s", "times of the open revolution's samples"),
        "open_q": (("sample", "coordinate"), cp["buffer_q"].reshape(-1, n), "m or rad", "its states"),
        "open_q_dot": (("sample", "coordinate"), cp["buffer_q_dot"].reshape(-1, n), "m/s or rad/s", "its rates"),
    }
    attrs = {"title": result.title, "scene_toml": result.scene_text, CASE: result.case,
             "arguments": json.dumps(result.arguments, sort_keys=True), "complete": bool(run.done),
             "steps_total": int(run.steps), "ts_type": run.ts_type,
             **{f"checkpoint_{k}": cp[k] for k in CHECKPOINT_ATTRS}}
    write_labelled(path, RUNUP_FORMAT, coords, variables, attrs)


def read_checkpoint(path, result, run) -> None:
    """Restore ``result``'s revolutions and ``run``'s state from the file at ``path``; ArchiveMismatch
    (naming ``--resume``) where it is not a run-up of the same scene, case and arguments."""
    with h5py.File(path, "r") as f:
        if f.attrs.get("format") != RUNUP_FORMAT:
            raise ArchiveMismatch(f"--resume: {path} is not a run-up product (format {f.attrs.get('format')!r})")
        for key, want in (("scene_toml", result.scene_text), (CASE, result.case),
                          ("arguments", json.dumps(result.arguments, sort_keys=True))):
            if f.attrs.get(key) != want:
                raise ArchiveMismatch(f"--resume: {path} was run with another {key.replace('_toml', '')} "
                                      "(use another -o, or run without --resume to replace it)")
        result.time_s = [float(x) for x in f["time_s"][()]]
        result.speed_rad_s = [float(x) for x in f[SPEED][()]]
        result.peak_stress_pa = [list(map(float, r)) for r in f["peak_stress_pa"][()]]
        result.peak_deflection_m = [list(map(float, r)) for r in f["peak_deflection_m"][()]]
        cp = {k: f.attrs[f"checkpoint_{k}"] for k in CHECKPOINT_ATTRS}
        cp.update(q=f["checkpoint_q"][()], q_dot=f["checkpoint_q_dot"][()], buffer_t=f["open_t"][()],
                  buffer_q=f["open_q"][()], buffer_q_dot=f["open_q_dot"][()])
    run.restore(cp)
