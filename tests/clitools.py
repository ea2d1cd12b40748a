"""Helpers of the command-line tests: run ``fkev`` as a subprocess, fingerprint archives."""

import hashlib
import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BW = ROOT / "runs/bahgat-willmert-1976.toml"
SMALL = ("--angles", "0,10", "--speeds", "0", "--cases", "structure")  # 2 points, dense, < 1 s


def fkev(*args, cwd=None, timeout=300, env_extra=None):
    """``python -m fkev_slepc ARGS`` with this checkout first on the path (and ``env_extra``)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), **(env_extra or {})}
    return subprocess.run([sys.executable, "-m", "fkev_slepc", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=cwd)


def digest(path: Path) -> str:
    """SHA-256 of a file's bytes (an archive left alone stays bit-identical)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def small_archive(out: Path, scene: Path = BW, *extra) -> Path:
    r = fkev("run", scene, *SMALL, "-q", "-o", out, *extra)
    assert r.returncode == 0, r.stderr
    return out


def problem_lines(stderr: str) -> list[str]:
    """The indented problem lines of a scene-error report."""
    return [ln.strip() for ln in stderr.splitlines() if ln.startswith("  ")]


@contextmanager
def edited(path):
    """A finished archive opened ``r+`` and re-stamped after the edit (``archive.verify.stamp``), as a
    run that stopped there would leave it: a resume refuses an edit left unstamped as damage."""
    import h5py

    from fkev_slepc.archive.verify import stamp

    with h5py.File(path, "r+") as f:
        yield f
        stamp(f)
