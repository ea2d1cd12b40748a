"""Stress campaigns of numerical stability and robustness (issue 10; docs/numerical-stability.md).

    PYTHONPATH=$PWD .venv/bin/python scripts/stress.py SUBCOMMAND [--seed S] [--n N]

Sub-commands: ``random`` (random Grashof crank-rockers, dense vs SLEPc in-process), ``units``
(SI vs mm-t-s vs in-lbf·s²/in-s), ``toggle`` (approach of a toggle position), ``conditioning``
(slenderness, heavy/light masses, rigid links, refined meshes, near-repeated eigenvalues), ``refine``
(pair errors on meshes up to 9000 DOFs),
``fuzz`` (mutations of every scene in runs/ through the CLI), ``faults`` (kill -9 then resume,
concurrent writers, truncated and corrupted archives), ``adversarial`` (absurd geometry and
magnitudes, deeply divergent and overflowing speeds; scripts/stress_adversarial.py), ``metadata``
(one flipped byte in an object header of a finished archive, against fkev verify, info and
export), ``products`` (adversarial inputs to the product commands, one-byte faults in the Floquet,
response and design archives against verify, --resume, their readers and fkev_slepc.open_dataset, a design
point failing in its solve; scripts/stress_products.py),
``all``. Seeded and reproducible; each
prints its counts and whether the targets hold, and exits 1 if one does not.

Every converged point is judged against its *conditioning floor*: the largest relative change
of its frequencies when every matrix entry is changed by one unit in the last place (dense
solve, two random sign patterns). Dense and SLEPc must agree within 10x that floor.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from stresslib import FLOOR_FACTOR, ROOT, Judge, Tally, four_bar, mp_real_eigenvalues, rel_diff, scale_units

CASES = ("structure", "no_coriolis", "no_tangential", "no_normal", "no_pseudo_normal", "full")


def random_crank_rocker(rng, n_points: int = 4):
    """A random Grashof crank-rocker (crank the shortest link, s + l < p + q) and its points."""
    s = rng.uniform(0.05, 0.15)
    while True:
        b, c, d = rng.uniform(1.3 * s, 4.0 * s, 3)
        v = sorted([s, b, c, d])
        if v[0] == s and v[0] + v[3] < v[1] + v[2]:
            break
    lengths = (s, b, c)
    sections = []
    for L in lengths:
        A = 10 ** rng.uniform(-5, -3.5)
        r = L / 10 ** rng.uniform(1.2, 2.5)  # radius of gyration: slenderness L/r in 16..300
        sections.append((A, A * r * r))
    elements = tuple(int(e) for e in rng.integers(1, 4, 3))
    masses = [(j, lk, float(rng.uniform(0.0, 0.3))) for j, lk in (("A", "crank"), ("B", "follower"))
              if rng.random() < 0.5]
    accel = float(rng.choice([0.0, 0.0, 100.0, -50.0]))
    for _ in range(n_points):
        yield four_bar(lengths, d, sections, elements, masses, speed=float(rng.choice([0.0, rng.uniform(0, 800)])),
                       accel=accel, angle=float(rng.uniform(0, 360)), case=str(rng.choice(CASES)))


def _qep(scene):
    from fkev_slepc.model.operators import Model

    model = Model(scene)
    pieces = model.pieces(np.radians(scene.analysis.crank_angles_deg[0]))
    return model, model.qep(pieces, scene.driver.speeds[0], scene.analysis.cases[0])


def _guarded(tally: Tally, label: str, fn):
    """Run one point; an exception is a crash of the campaign's target (counted, not raised)."""
    try:
        return fn()
    except Exception as exc:  # noqa: BLE001 - counting every escape is the point
        tally.add("crashes (exceptions)")
        tally.notes.append(f"{label}: {type(exc).__name__}: {exc}")
        return None


# ----------------------------------------------------------------------------- campaigns
def cmd_random(args) -> Tally:
    rng, t = np.random.default_rng(args.seed), Tally("random Grashof crank-rockers")
    judge = Judge(4, args.seed)
    for i in range(args.n):
        for k, scene in enumerate(random_crank_rocker(rng)):
            _guarded(t, f"linkage {i} point {k}", lambda: judge(_qep(scene)[1], t, f"linkage {i} point {k}"))
    judge.close()
    return t


UNIT_SYSTEMS = {"SI (m, kg, s)": (1.0, 1.0), "mm, t, s": (1e-3, 1e3),
                "in, lbf·s²/in, s": (0.0254, 4.4482216152605 / 0.0254)}


def cmd_units(args) -> Tally:
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.slepc import SlepcEngine

    rng, t = np.random.default_rng(args.seed), Tally("unit-system invariance")
    dense, slepc = DenseEngine(), SlepcEngine()
    for i in range(args.n):
        scene = next(random_crank_rocker(rng, 1))
        for name, engine in (("dense", dense), ("slepc", slepc)):
            freqs = {}
            for system, (L, M) in UNIT_SYSTEMS.items():
                res = postprocess(engine.solve(_qep(scale_units(scene, L, M))[1], 4), 4)
                freqs[system] = res.frequency_hz
                t.add(f"{name} points")
            ref = freqs["SI (m, kg, s)"]
            worst = max(rel_diff(f, ref) for f in freqs.values())
            t.high(f"{name}: frequency change between unit systems", worst)
            t.add(f"{name}: invariant to 1e-10" if worst <= 1e-10 else f"{name}: NOT invariant to 1e-10")
    slepc.close()
    return t


TOGGLE_SECTIONS = ((1.07e-4, 1.62e-10), (4.1e-5, 8.67e-12), (4.1e-5, 8.67e-12))
ALUMINIUM = dict(youngs_modulus=7.1e10, density=2710.0)


def toggle_scene(delta: float = 0.0):
    """Turcic-Midha links with a 0.35 m crank (non-Grashof), ``delta`` degrees before the limit of
    assembly, full case at 100 rad/s; and that limit θ_lim (degrees)."""
    from fkev_slepc.model.kinematics import assembly_ranges
    from fkev_slepc.model.mechanism import build_mechanism

    geometry = ((0.35, 0.2794, 0.2705), 0.254, TOGGLE_SECTIONS, (3, 3, 3))
    lim = assembly_ranges(build_mechanism(four_bar(*geometry, props=ALUMINIUM)))[0][0]
    return four_bar(*geometry, props=ALUMINIUM, speed=100.0, angle=lim - delta, case="full", modes=3), lim


def cmd_toggle(args) -> Tally:
    """Approach the toggle of a non-Grashof four-bar (Turcic-Midha with a 0.35 m crank)."""
    from fkev_slepc.model.kinematics import TRANSMISSION_WARN_DEG

    t = Tally("toggle approach")
    lim = toggle_scene()[1]
    judge = Judge(3, args.seed)
    print(f"toggle at θ = {lim:.9f}°; full case, Ω = 100 rad/s")
    print(f"{'θlim-θ [°]':>11} {'μ [°]':>9} {'max Re λ dense':>15} {'max Re λ slepc':>15} {'status d/s':>22} warn")
    for delta in 10.0 ** np.arange(1, -7, -0.25):
        scene = toggle_scene(delta)[0]

        def point():
            model, qep = _qep(scene)
            mu = float(np.degrees(model.kinematics(np.radians(lim - delta)).transmission[0]))
            out = judge(qep, t, f"θlim-{delta:.1e}")
            d, s = out["dense"], out["slepc"]
            warn = mu < TRANSMISSION_WARN_DEG
            t.add("μ below the warning threshold" if warn else "μ at or above the warning threshold")
            big = max(abs(d.max_real), abs(s.max_real))
            if big > 1e3 and not warn:
                t.add("divergence rate > 1e3 1/s without a warning")
            print(f"{delta:11.1e} {mu:9.3g} {d.max_real:15.4g} {s.max_real:15.4g} "
                  f"{d.status.value + '/' + s.status.value:>22} {'yes' if warn else 'no'}")
            if getattr(args, "mpmath", False) and delta < 4e-6:  # the points where the engines once disagreed
                exact = mp_real_eigenvalues(qep)
                for name, r in (("dense", d), ("SLEPc", s)):
                    same = r.divergent.size == exact.size
                    err = float(np.max(np.abs(r.divergent / exact - 1))) if same else np.inf
                    t.high(f"{name}: real eigenvalues vs 40-digit mpmath", err)
                    t.add(f"{name}: real eigenvalues as many as 40-digit mpmath's" if same else
                          f"{name}: real eigenvalues NOT as many as 40-digit mpmath's")

        _guarded(t, f"θlim-{delta:.1e}", point)
    judge.close()
    return t


def cmd_conditioning(args) -> Tally:
    t = Tally("conditioning")
    judge = Judge(4, args.seed)
    bw = ((0.127, 0.2794, 0.2667), 0.254)
    steel = (1.61e-4, 8.66e-9)
    runs = []
    for ratio in 10.0 ** np.arange(3, 10):  # slenderness EA·L²/EI of every link
        secs = tuple((steel[0], steel[0] * L * L / ratio) for L in bw[0])
        runs += [(f"slenderness {ratio:.0e}", secs, (2, 2, 2), (), c, w) for c, w in (("structure", 0), ("full", 300))]
    for m in 10.0 ** np.arange(-6, 5):  # lumped mass at B, kg (the links weigh ~0.3 kg)
        runs += [(f"mass at B {m:.0e} kg", (steel,) * 3, (2, 2, 2), (("B", "follower", m),), c, w)
                 for c, w in (("structure", 0), ("no_tangential", 300), ("full", 300))]
    for ne in (1, 2, 5, 10, 20, 40):
        runs += [(f"{ne} el/link", (steel,) * 3, (ne,) * 3, (), c, w) for c, w in (("structure", 0), ("full", 500))]
    for label, secs, el, masses, case, w in runs:
        scene = four_bar(*bw, secs, el, masses, speed=float(w), case=case)
        _guarded(t, label, lambda: judge(_qep(scene)[1], t, f"{label} {case}"))
    for stiff in 10.0 ** np.arange(0, 7):  # rigid crank and a heavy mass at B: the rhombus of issue 10
        props = dict(youngs_modulus=2.07e11 * stiff, density=7760.0)
        scene = four_bar((0.25,) * 3, 0.25, (steel,) * 3, (2, 2, 2), (("B", "follower", 1e4),), angle=90.0,
                         case="structure", props=props)
        _guarded(t, f"rigid crank x{stiff:.0e}", lambda: judge(_qep(scene)[1], t, f"rigid crank x{stiff:.0e}"))
    for case, w in (("structure", 0.0), ("full", 200.0)):  # equal links at 90°: near-repeated pairs
        scene = four_bar((0.25,) * 3, 0.25, (steel,) * 3, (2, 2, 2), angle=90.0, case=case, speed=w, modes=6)
        j6 = Judge(6, args.seed)
        _guarded(t, f"rhombus {case}", lambda: j6(_qep(scene)[1], t, f"rhombus {case}"))
        j6.close()
    judge.close()
    return t


def cmd_refine(args) -> Tally:
    """Pair errors of SLEPc on ever finer Bahgat-Willmert meshes, absolute and over their floor."""
    from fkev_slepc.model.operators import Model
    from fkev_slepc.scene import load_scene, with_elements
    from fkev_slepc.solve.modes import postprocess
    from fkev_slepc.solve.slepc import SlepcEngine
    from stresslib import pair_ratio

    t = Tally("refined meshes (Bahgat-Willmert, 10°, SLEPc, max_pair_error 0.5)")
    print(f"{'el/link':>7} {'DOFs':>6} {'case':>9} {'max η':>9} {'η/η0':>9} status")
    for ne in (10, 100, 300, 1000)[: max(args.n, 1)]:
        model = Model(with_elements(load_scene(ROOT / "runs" / "bahgat-willmert-1976.toml"), ne), cases=("full",))
        for case, w in (("structure", 0.0), ("full", 500.0)):
            q = model.qep(model.pieces(np.radians(10.0)), w, case)
            with SlepcEngine([("max_pair_error", "0.5")]) as engine:
                sol = engine.solve(q, 4, want_vectors=True, hint=2000.0)
            res, ratio = postprocess(sol, 4), pair_ratio(q, sol, 4)
            t.add("points")
            t.high("pair error / its one-ulp floor", ratio)
            print(f"{ne:7d} {q.n:6d} {case:>9} {np.nanmax(res.residual):9.1e} {ratio:9.1e} {res.status.value}")
    return t


def main(argv=None) -> int:
    import stress_adversarial
    import stress_io
    import stress_products

    commands = {"random": cmd_random, "units": cmd_units, "toggle": cmd_toggle, "conditioning": cmd_conditioning,
                "refine": cmd_refine, "fuzz": stress_io.cmd_fuzz, "faults": stress_io.cmd_faults,
                "adversarial": stress_adversarial.cmd_adversarial, "metadata": stress_io.cmd_metadata,
                "products": stress_products.cmd_products}
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("command", choices=(*commands, "all"))
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--n", type=int, default=None, help="size of the campaign (linkages, mutations, trials)")
    ap.add_argument("--mpmath", action="store_true",
                    help="toggle: also check the real eigenvalues of the last points in 40-digit arithmetic (~5 min)")
    args = ap.parse_args(argv)
    from fkev_slepc.solve.petsc_init import init_petsc

    init_petsc([])
    names = list(commands) if args.command == "all" else [args.command]
    failed = []
    for name in names:
        a = argparse.Namespace(**vars(args))
        a.n = args.n if args.n is not None else DEFAULT_N[name]
        tally = commands[name](a)
        print(tally.report(), flush=True)
        missed = targets_missed(tally)
        print(f"  targets: {'met' if not missed else 'MISSED: ' + '; '.join(missed)}", flush=True)
        failed += missed
    return 1 if failed else 0


DEFAULT_N = {"random": 150, "units": 30, "toggle": 0, "conditioning": 0, "refine": 4, "fuzz": 40, "faults": 3,
             "adversarial": 0, "metadata": 3, "products": 0}
BAD_KEYS = ("crashes (exceptions)", "status differs", f"dense != SLEPc beyond {FLOOR_FACTOR:g}x floor",
            "NOT invariant", "tracebacks", "damaged archives", "undetected", "without a warning", "not refused",
            "differs after resume", "first writer harmed", "NOT as many", "RuntimeWarnings", "wrong but ok",
            "on a scene fkev check refuses", "not refused", "accepted by --resume", "reader exceptions",
            "product runs failed", "xarray read exceptions", "not flagged")


def targets_missed(tally: Tally) -> list[str]:
    return [f"{k} = {v}" for k, v in tally.counts.items() if v and any(b in k for b in BAD_KEYS)]


if __name__ == "__main__":
    sys.exit(main())
