"""``fkev run --np N``: start the N ranks ourselves (``mpiexec -n N python -m fkev_slepc ...``
as a child process whose exit code we return), so that MPI runs do not depend on the Makefile
or on remembering the launcher's flags. Ctrl-C reaches only this process (mpiexec runs in its
own session); it is passed on as SIGUSR1, which mpiexec forwards to every rank: they stop at
their next sync and keep the archive resumable.

With Open MPI, ``--oversubscribe`` is added when N exceeds the CPUs this process may use
(Open MPI otherwise refuses with "not enough slots"), and ``--quiet`` (fkev's own one-line
messages say what went wrong; mpiexec's banner about non-zero exit codes would bury them). The variables that let Open MPI run as
root (``OMPI_ALLOW_RUN_AS_ROOT``...) are never set here: running as root is the user's
decision; without them Open MPI refuses, and we say so in one line before launching.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys

from fkev_slepc.status import EXIT_BAD_INPUT
from fkev_slepc.sweep.interrupt import NP_VARIABLE  # set for the launched ranks: their resume hint repeats --np N
from fkev_slepc.sweep.parallel import world

ROOT_VARS = ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM")


def strip_np(argv: list[str]) -> list[str]:
    """``argv`` without ``--np N`` / ``--np=N`` (the relaunched ranks must not launch again)."""
    out, skip = [], False
    for tok in argv:
        if skip:
            skip = False
        elif tok == "--np":
            skip = True
        elif not tok.startswith("--np="):
            out.append(tok)
    return out


def mpiexec_command(n: int, argv: list[str], library: str, cpus: int) -> list[str]:
    """The launcher command line for ``n`` ranks of ``python -m fkev_slepc ARGV``."""
    exe = shutil.which("mpiexec") or shutil.which("mpirun")
    if exe is None:
        raise LaunchError("--np: no mpiexec or mpirun on PATH (install Open MPI or MPICH, or run without --np)")
    cmd = [exe, "-n", str(n)]
    if "Open MPI" in library:
        cmd.append("--quiet")  # no "N processes returned a non-zero exit code" banner: ours says why
        if n > cpus:
            cmd.append("--oversubscribe")
    return cmd + [sys.executable, "-m", "fkev_slepc", *strip_np(argv)]


class LaunchError(ValueError):
    """``--np`` cannot be honoured (message: one line)."""


def relaunch(n: int, argv: list[str], environ: dict | None = None) -> int:
    """Run ``mpiexec -n n python -m fkev_slepc ARGV`` and return its exit code; -1 when there is
    nothing to launch (n = 1, or already running under mpiexec with n ranks).

    ``environ`` is the environment as it was before this process started MPI: the variables
    a singleton MPI_Init adds (Open MPI's ``OMPI_*``/``PMIX_*``) would make mpiexec fail."""
    comm = world()
    try:
        if n < 1:
            raise LaunchError(f"--np: must be >= 1 (got {n})")
        if comm.size > 1:  # already launched by mpiexec: --np must agree with it
            if comm.size != n:
                raise LaunchError(f"--np {n}: this process already runs on {comm.size} MPI ranks (drop --np "
                                  "when starting fkev under mpiexec)")
            return -1
        if n == 1:
            return -1
        from mpi4py import MPI

        library = MPI.Get_library_version()
        env = os.environ if environ is None else environ
        if "Open MPI" in library and os.geteuid() == 0 and not all(env.get(v) for v in ROOT_VARS):
            raise LaunchError("--np: Open MPI refuses to run as root; to allow it, export "
                              + " ".join(f"{v}=1" for v in ROOT_VARS) + " (see docs/cli.md)")
        cmd = mpiexec_command(n, argv, library, len(os.sched_getaffinity(0)))
    except LaunchError as err:
        if comm.rank == 0:
            print(f"fkev run: {err}", file=sys.stderr, flush=True)
        return EXIT_BAD_INPUT
    sys.stdout.flush()
    sys.stderr.flush()
    return _supervise(cmd, {**(os.environ if environ is None else environ), NP_VARIABLE: str(n)})


def _supervise(cmd: list[str], environ: dict | None) -> int:
    """Run the launcher in its own session and turn Ctrl-C/SIGTERM into SIGUSR1 for it.

    Open MPI's mpiexec answers SIGINT by killing the ranks one second later, but forwards
    SIGUSR1 to them: they then stop at their next sync, cleanly (fkev_slepc.sweep.interrupt).
    A second Ctrl-C is passed on as SIGINT (hard stop; the archive stays resumable)."""
    proc = subprocess.Popen(cmd, env=environ, start_new_session=True)
    count = 0

    def forward(signum, frame):
        nonlocal count
        count += 1
        proc.send_signal(signal.SIGUSR1 if count == 1 else signal.SIGINT)

    previous = {sig: signal.signal(sig, forward) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        code = proc.wait()
    finally:
        for sig, prev in previous.items():
            signal.signal(sig, prev)
    return code if code >= 0 else 128 - code  # killed by a signal: the shell's convention
