"""Acceptance numbers quoted in docs/linkages.md, from the same scenes and helpers as
tests/test_linkages.py. Run from the repository root:

    PYTHONPATH=$PWD .venv/bin/python scripts/linkage_checks.py

With ``--acceptance`` it prints instead the worst SLEPc-vs-dense difference of the 10 lowest
frequencies on the acceptance grid of tests/test_eigen.py::test_acceptance_slepc_matches_dense
(both thesis scenes, every pep_type/LU pair the test runs; the test asserts <= 1e-9), quoted in
README.md and docs/engine.md.
"""

import sys

sys.path.insert(0, "tests")  # the support modules of the tests: linkage_cases, eigen_cases, balance, builders

import numpy as np  # noqa: E402
from balance import newton_euler_residual, power_residual  # noqa: E402
from scipy.optimize import brentq  # noqa: E402
from linkage_cases import (  # noqa: E402
    SCENES, THETA, _section, central_mass_equation, dead_centre_rod, link_eigen, pinned_beam,
    tip_inertia_cantilever, tip_inertia_equation,
)
from fkev_slepc.model.kinematics import point_local, solve_kinematics  # noqa: E402
from fkev_slepc.model.mechanism import build_mechanism  # noqa: E402
from fkev_slepc.model.operators import Model  # noqa: E402
from fkev_slepc.scene import load_scene  # noqa: E402


def acceptance_worst() -> None:
    """The largest ``rel(got.frequency_hz, ref.frequency_hz)`` of test_acceptance_slepc_matches_dense."""
    from eigen_cases import ACCEPTANCE_SOLVERS, SCENES as THESIS, rel, scene_qeps

    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.slepc import SlepcEngine

    pairs = ACCEPTANCE_SOLVERS  # the list test_eigen.py's acceptance test runs
    dense, worst, at, n = DenseEngine(), -1.0, None, 0
    for path in THESIS:
        for pep_type, lu in pairs:
            with SlepcEngine([("pep_type", pep_type), ("st_pc_factor_mat_solver_type", lu)]) as engine:
                for where, q in scene_qeps(path):
                    got, ref = postprocess(engine.solve(q, 10), 10), postprocess(dense.solve(q, 10), 10)
                    e, n = rel(got.frequency_hz, ref.frequency_hz), n + 1
                    if e > worst:
                        worst, at = e, (path, pep_type, lu, where)
    path, pep_type, lu, (th, om, case) = at
    print(f"acceptance grid of test_eigen.py ({n} solves: {len(THESIS)} scenes x {len(pairs)} pep_type/LU "
          f"pairs x {n // len(THESIS) // len(pairs)} points), 10 modes: SLEPc vs dense max rel diff {worst:.1e} "
          f"({path}, {pep_type}/{lu}, θ = {th}°, Ω = {om:g} rad/s, case {case})")


if "--acceptance" in sys.argv[1:]:
    acceptance_worst()
    sys.exit(0)

got, exact = dead_centre_rod()
print("dead centre rod f_n (Hz):", np.round(got / 2 / np.pi, 3), "closed form:", np.round(exact / 2 / np.pi, 3),
      "rel err:", ["%.1e" % e for e in np.abs(got / exact - 1)])
r = 1.0
sc, lk, ei, rho_a = _section(pinned_beam(mass=f'[[masses]]\nlink = "beam"\nposition_m = 0.5\nmass_kg = {r * 7850.0 * 1.8e-4!r}\n'))
a = brentq(central_mass_equation, 0.5, np.pi / 2, args=(r,))
ex = (2 * a / lk.length) ** 2 * np.sqrt(ei / rho_a)
w1 = link_eigen(Model(sc, cases=("structure",)), "beam")[0]
print("mid-span mass r=1, 32 el: w1 = %.6f rad/s, closed form %.6f, rel err %.1e" % (w1, ex, abs(w1 / ex - 1)))
for name, path in SCENES.items():
    mech = build_mechanism(load_scene(path))
    kin = solve_kinematics(mech, THETA)
    worst = max(np.abs(point_local(kin, [lk], mech.link_points[lk, k][None])[0][:, 0] - kin.pos[:, jj]).max()
                for jj, here in enumerate(mech.attach) for lk, k in here)
    ne = max(newton_euler_residual(mech, THETA, om, al) for om, al in ((500, 0), (300, 4e4), (0, -2e5)))
    p, dE = power_residual(mech, THETA)
    print(f"{name}: closure {worst / mech.length.max():.1e} L, Newton-Euler {ne:.1e}, "
          f"power |TΩ - dE/dt|/max|TΩ| {np.abs(p - dE).max() / np.abs(p).max():.1e}")

# rotary inertia j = J/(ρAL³) = 0.05 at the free end of a 32-element cantilever
j = 0.05
sc, lk, ei, rho_a = _section(tip_inertia_cantilever(j))
lam = brentq(tip_inertia_equation, 0.5, 1.875104, args=(j,))
ex = (lam / lk.length) ** 2 * np.sqrt(ei / rho_a)
w1 = link_eigen(Model(sc, cases=("structure",)), "blade")[0]
print("tip rotary inertia j=0.05, 32 el: w1 = %.6f rad/s, closed form %.6f, rel err %.1e" % (w1, ex, abs(w1 / ex - 1)))

from fkev_slepc.solve.dense import DenseEngine  # noqa: E402
from fkev_slepc.solve.engines import frequencies as engine_frequencies, relative_difference  # noqa: E402
from fkev_slepc.solve.slepc import SlepcEngine  # noqa: E402

for name, path in SCENES.items():
    model = Model(load_scene(path), cases=("full",))
    worst = 0.0
    with SlepcEngine() as engine:
        for angle in range(0, 360, 30):
            for omega in (0.0, 300.0):
                q = model.qep(model.pieces(np.radians(angle)), omega, "full")
                fa, fb = engine_frequencies(engine, q, 4), engine_frequencies(DenseEngine(), q, 4)
                worst = max(worst, relative_difference(fa, fb))
    print(f"{name}: SLEPc vs dense, 12 angles x Ω = 0, 300 rad/s, case full, 4 modes: max rel diff {worst:.1e}")

# the four-bars through the general path against the binary-link model's recorded operators
from builders import frequencies  # noqa: E402
from linkage_cases import DATA, PIECES, RUNS, _pieces  # noqa: E402

from fkev_slepc.scene.cases import CASE_NAMES  # noqa: E402

for name in ("bahgat-willmert-1976", "turcic-midha-1984"):
    ref = np.load(DATA / f"{name}-operators.npz")
    model = Model(load_scene(RUNS / f"{name}.toml"), cases=CASE_NAMES)
    wo = wf = 0.0
    for i, angle in enumerate(ref["angles"]):
        got = _pieces(model, angle)
        for key in PIECES:
            want = ref[f"a{i}_{key}"]
            wo = max(wo, np.abs(got[key] - want).max() / np.abs(want).max())
        for case in CASE_NAMES:
            f = frequencies(model, angle, 1000.0, case).frequency_hz
            wf = max(wf, np.abs(f / ref[f"a{i}_freq_{case}"] - 1).max())
    print(f"{name}: operators max rel diff {wo:.1e}, frequencies max rel diff {wf:.1e}")
