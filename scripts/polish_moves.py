"""How far the polish moves right eigenvalues (the basis of ``SolveSettings.polish_max_move``).

    PYTHONPATH=$PWD .venv/bin/python scripts/polish_moves.py [ELEMENTS_PER_LINK ...]

Bahgat-Willmert, 10°, 500 rad/s, full, SLEPc: the 4 reported eigenvalues unpolished against
polished; prints the largest relative move |λ_polished - λ| / |λ| per mesh (default 64 256 1000).
"""

import sys

import numpy as np

from fkev_slepc.solve.petsc_init import init_petsc

init_petsc([])

from fkev_slepc.model.operators import Model  # noqa: E402
from fkev_slepc.scene import load_scene, with_elements  # noqa: E402
from fkev_slepc.solve.modes import postprocess  # noqa: E402
from fkev_slepc.solve.slepc import SlepcEngine  # noqa: E402
from fkev_slepc.solve.thresholds import SolveSettings  # noqa: E402

RAW = SolveSettings(polish_above=np.inf, polish_ratio=np.inf, max_pair_error=1.0)  # no polish, nothing refused

for n in map(int, sys.argv[1:] or (64, 256, 1000)):
    m = Model(with_elements(load_scene("runs/bahgat-willmert-1976.toml"), n), cases=("full",))
    q = m.qep(m.pieces(np.radians(10.0)), 500.0, "full")
    with SlepcEngine(settings=RAW) as raw, SlepcEngine() as polished:
        a = postprocess(raw.solve(q, 4), 4).eigenvalue
        b = postprocess(polished.solve(q, 4), 4)
    move = np.max(np.abs(a - b.eigenvalue) / np.abs(b.eigenvalue))
    print(f"{n:5d} elements per link, {q.n:6d} DOFs: largest relative move {move:.2g} ({b.status.value})", flush=True)
