"""Stress campaigns through the command line: scene mutation fuzz and archive faults
(scripts/stress.py fuzz | faults). Not part of the package."""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

from stresslib import ROOT, Tally

NUMBER = re.compile(r"(?<![\w.])-?\d+(\.\d+)?([eE][-+]?\d+)?(?![\w.])")
REPLACEMENTS = ["-1", "0", "nan", "inf", "1e300", "1e-300", '"x"', "true", "[]", "{}", "-0.0", "3.5"]


def mutate(text: str, rng) -> str:
    """One random, syntax-level or value-level change of a scene file."""
    lines = text.splitlines()
    op = rng.integers(6)
    if op == 0 and lines:  # drop a line
        del lines[rng.integers(len(lines))]
    elif op == 1:  # a number becomes something else
        spots = list(NUMBER.finditer(text))
        if spots:
            m = spots[rng.integers(len(spots))]
            return text[: m.start()] + str(rng.choice(REPLACEMENTS)) + text[m.end():]
    elif op == 2 and lines:  # duplicate a line
        i = rng.integers(len(lines))
        lines.insert(i, lines[i])
    elif op == 3:  # truncate
        return text[: rng.integers(len(text) + 1)]
    elif op == 4:  # rename a key
        keys = [i for i, ln in enumerate(lines) if "=" in ln and not ln.lstrip().startswith("#")]
        if keys:
            i = keys[rng.integers(len(keys))]
            lines[i] = "x" + lines[i].lstrip()
    else:  # swap two lines
        if len(lines) > 1:
            i, j = rng.integers(len(lines), size=2)
            lines[i], lines[j] = lines[j], lines[i]
    return "\n".join(lines) + "\n"


def _cli(argv) -> tuple[int | None, str, str]:
    """fkev in-process: (exit code or None on an escaped exception, stdout, stderr)."""
    from fkev_slepc.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
        except Exception:  # noqa: BLE001 - a traceback is what the campaign counts
            traceback.print_exc()
            code = None
    return code, out.getvalue(), err.getvalue()


# the commands each mutated scene goes through, and which scenes (by their unmutated text): every scene
# through fkev check and fkev point; the design check and the loads where the scene has [[loads]] or
# [materials] (issue 36 item 6: what they read is mutated too), the out-of-plane point where its
# sections are given by shape (both planes' data)
FUZZ_COMMANDS = (
    (("check",), lambda text: True),
    (("point", "--modes", "2"), lambda text: True),
    (("loads", "--angles", "0:360:90"), lambda text: "[[loads]]" in text or "[materials" in text),
    (("design-check", "--harmonics", "4", "--elements", "1", "--angles", "0:355:15"),
     lambda text: "[[loads]]" in text or "[materials" in text),
    (("point", "--plane", "out", "--modes", "2"), lambda text: "section = {shape" in text),
)


def cmd_fuzz(args) -> Tally:
    rng, t = np.random.default_rng(args.seed), Tally("mutation fuzz of runs/*.toml (fkev check, point, loads, "
                                                     "design-check, point --plane out)")
    scenes = sorted((ROOT / "runs").glob("*.toml"))
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.n):
            for src in scenes:
                path, text = Path(tmp) / f"m{i}-{src.name}", src.read_text()
                path.write_text(mutate(text, rng))
                for argv in ([cmd[0], path, *cmd[1:]] for cmd, wanted in FUZZ_COMMANDS if wanted(text)):
                    code, out, err = _cli(map(str, argv))
                    t.add(f"{argv[0]} runs")
                    if code is None or "Traceback" in err:
                        t.add("tracebacks")
                        t.notes.append(f"{argv[0]} {path.name}: {err.strip().splitlines()[-1]}")
                        shutil.copy(path, Path(tempfile.gettempdir()) / f"stress-traceback-{path.name}")
                    else:
                        t.add(f"{argv[0]} exit {code}")
                        if code == 2:
                            t.high(f"{argv[0]}: lines of a refusal", err.count("\n"))
    return t


def _fkev(*args, **kw):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "fkev_slepc", *map(str, args)], env=env, cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True, **kw)


def _wait(p, timeout=600):
    out, err = p.communicate(timeout=timeout)
    return p.returncode, out, err


def _datasets(path) -> dict:
    import h5py

    with h5py.File(path, "r") as f:
        return {k: f[k][()] for k in ("frequency_hz", "eigenvalue", "residual", "max_real", "status")}


def cmd_faults(args) -> Tally:
    from fkev_slepc.archive.verify import verify

    rng, t = np.random.default_rng(args.seed), Tally("faults (archives)")
    scene = ROOT / "runs" / "turcic-midha-1984.toml"
    grid = ["--speeds", "0,100,200", "--cases", "structure,no_coriolis,full"]
    with tempfile.TemporaryDirectory() as tmp:
        ref = Path(tmp) / "ref.h5"
        code, _, err = _wait(_fkev("run", scene, *grid, "-o", ref))
        assert code == 0, err
        want = _datasets(ref)
        for trial in range(args.n):
            # kill -9 mid-sweep, then --resume: bit-identical to the uninterrupted run
            out = Path(tmp) / f"kill{trial}.h5"
            p = _fkev("run", scene, *grid, "-o", out)
            time.sleep(float(rng.uniform(1.0, 3.0)))
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
            code, _, err = _wait(_fkev("run", scene, *grid, "-o", out, "--resume"))
            same = code == 0 and all(np.array_equal(a, b, equal_nan=True) for a, b in
                                     zip(want.values(), _datasets(out).values()))
            t.add("kill -9 then --resume: identical" if same else "kill -9 then --resume: differs after resume")
            # a second writer one second later: refused with exit 2, the first unharmed
            out = Path(tmp) / f"two{trial}.h5"
            first = _fkev("run", scene, *grid, "-o", out)
            time.sleep(1.0)
            c2, _, e2 = _wait(_fkev("run", scene, *grid, "-o", out))
            c1, _, _ = _wait(first)
            refused = c2 == 2 and e2.strip().count("\n") == 0 and "lock" in e2 and "Traceback" not in e2
            t.add("second writer refused (exit 2, one line)" if refused else "second writer not refused")
            intact = c1 == 0 and verify(out).ok and all(np.array_equal(a, b, equal_nan=True) for a, b in
                                                        zip(want.values(), _datasets(out).values()))
            t.add("first writer's archive intact" if intact else "first writer harmed (damaged archives)")
        blob = ref.read_bytes()
        spots = _data_offsets(ref)
        for trial in range(max(10, 10 * args.n)):
            bad = Path(tmp) / "bad.h5"
            cut = int(rng.integers(0, len(blob)))
            bad.write_bytes(blob[:cut])  # truncated
            _judge_damaged(t, bad, "truncated")
            data = bytearray(blob)  # bytes overwritten inside stored values
            name, (off, size) = list(spots.items())[trial % len(spots)]
            at = off + int(rng.integers(0, size))
            data[at] ^= 0xFF
            bad.write_bytes(bytes(data))
            _judge_damaged(t, bad, "corrupted")
    return t


def _data_offsets(path) -> dict:
    import h5py

    found = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.id.get_offset() is not None and obj.id.get_storage_size():
                found[name] = (obj.id.get_offset(), obj.id.get_storage_size())
        f.visititems(visit)
    return found


def _judge_damaged(t: Tally, path: Path, what: str) -> None:
    # a subprocess: HDF5 reading damaged metadata may crash the process, which is what we count
    code, _, err = _wait(_fkev("info", path))
    if code < 0 or code > 3:
        t.add("crashes (exceptions)")
        t.notes.append(f"fkev info on a {what} archive: exit {code}: {err.strip().splitlines()[-1] if err.strip() else ''}")
        shutil.copy(path, Path(tempfile.gettempdir()) / f"stress-crash-{what}-{code}.h5")
    elif "Traceback" in err:
        t.add("tracebacks")
    elif code == 2 and err.strip().count("\n") == 0:
        t.add(f"{what} archive refused by fkev info (exit 2, one line)")
    else:
        t.add(f"{what} archive undetected (damaged archives)")


_FINGERPRINT = r"""
import hashlib, sys, h5py, numpy as np
h = hashlib.sha256()
def visit(name, obj):
    h.update(name.encode())
    for k in sorted(obj.attrs):
        if k in ("DIMENSION_LIST", "REFERENCE_LIST"):
            continue
        h.update(k.encode() + repr(obj.attrs[k]).encode())
    if isinstance(obj, h5py.Dataset):
        v = obj[()]
        h.update(str(obj.dtype).encode() + str(obj.shape).encode() + repr(v.tolist() if hasattr(v, "tolist") else v).encode())
        h.update(repr([[s.name for s in obj.dims[i].values()] for i in range(obj.ndim)]).encode())
with h5py.File(sys.argv[1], "r") as f:
    visit("/", f)
    f.visititems(visit)
print(h.hexdigest())
"""


def _fingerprint(path: Path) -> str | None:
    """Digest of everything h5py decodes from ``path`` (values, dtypes, shapes, attributes, the
    scale attached to each axis), in a child process; None when decoding fails or crashes."""
    r = subprocess.run([sys.executable, "-c", _FINGERPRINT, str(path)], capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else None


def _headers(path) -> dict:
    """(address, size) of the object header of every dataset and group of an archive."""
    import h5py

    found = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            info = h5py.h5o.get_info(obj.id)
            found[name] = (info.addr, info.hdr.space.total)
        f.visititems(visit)
    return found


def cmd_metadata(args) -> Tally:
    """One flipped byte in the object header of a dataset or group of a finished archive (every
    object, ``--n`` random bytes of each header, ``/errors/status`` first): ``fkev verify``,
    ``fkev info`` and ``fkev export`` must refuse it with exit 2 and one line, or the flip must
    be harmless (everything HDF5 decodes unchanged); never a crash or a traceback."""
    rng, t = np.random.default_rng(args.seed), Tally("metadata byte flips (archives)")
    scene = ROOT / "runs" / "turcic-midha-1984.toml"
    with tempfile.TemporaryDirectory() as tmp:
        ref = Path(tmp) / "ref.h5"
        code, _, err = _wait(_fkev("run", scene, "--speeds", "0,100", "--cases", "structure,full", "--angles",
                                   "0,20", "-o", ref))
        assert code == 0, err
        want, blob = _fingerprint(ref), ref.read_bytes()
        headers = sorted(_headers(ref).items(), key=lambda kv: kv[0] != "errors/status")
        for name, (addr, size) in headers:
            for at in addr + rng.choice(size, size=min(args.n, size), replace=False):
                data = bytearray(blob)
                data[int(at)] ^= 0xFF
                bad = Path(tmp) / "bad.h5"
                bad.write_bytes(bytes(data))
                runs = {cmd: _wait(_fkev(cmd, bad)) for cmd in ("verify", "info", "export")}
                t.add("flips")
                if any(c < 0 or c > 3 for c, _, _ in runs.values()):
                    t.add("crashes (exceptions)")
                    t.notes.append(f"{name} byte {int(at) - addr}: exits {[c for c, _, _ in runs.values()]}")
                elif any("Traceback" in e for _, _, e in runs.values()):
                    t.add("tracebacks")
                    t.notes.append(f"{name} byte {int(at) - addr}: " + "; ".join(
                        f"{cmd}: {e.strip().splitlines()[-1]}" for cmd, (_, _, e) in runs.items() if "Traceback" in e))
                elif all(c == 2 and e.strip().count("\n") == 0 for c, _, e in runs.values()):
                    t.add("refused by verify, info and export (exit 2, one line)")
                elif all(c == 0 for c, _, _ in runs.values()) and _fingerprint(bad) == want:
                    t.add("harmless (every decoded value, dtype, shape, attribute and scale unchanged), accepted")
                else:
                    t.add("undetected or inconsistent (damaged archives)")
                    t.notes.append(f"{name} byte {int(at) - addr}: exits {[c for c, _, _ in runs.values()]}")
    return t
