"""Scenes and closed forms shared by tests/test_linkages.py, tests/test_kinematics.py and
scripts/linkage_checks.py (a support module, not a test file: the scripts import it).

Scene texts built from parts (links, joints, a driver), the thesis-independent linkages of runs/
(slider-crank, Stephenson six-bar) and the frequency equations the tests compare against.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from builders import frequencies

from fkev_slepc.model.operators import Model
from fkev_slepc.scene import load_scene, parse_scene

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
RUNS = ROOT / "runs"
PIECES = ("mass", "structural", "coriolis", "tangential", "normal", "pseudo")


def _pieces(model, theta_deg):
    p = model.pieces(np.radians(theta_deg))
    return dict(mass=p.mass, structural=p.structural, coriolis=p.coriolis, tangential=np.stack(p.tangential),
                normal=p.normal, pseudo=np.stack(p.pseudo_normal))



SCENES = {"slider-crank": RUNS / "slider-crank.toml", "stephenson-six-bar": RUNS / "stephenson-six-bar.toml"}
THETA = np.radians(np.arange(0.0, 360.0, 7.5))




STEEL_TOML = """
[link_defaults]
youngs_modulus_pa = 2.07e11
density_kg_m3 = 7850.0
area_m2 = 1.8e-4
second_moment_m4 = 4.86e-9
"""


def link(name, length, elements, extra="") -> str:
    return f'[[links]]\nname = "{name}"\nlength_m = {length!r}\nelements = {elements}\n{extra}\n'


def joint(name, connects, xy=None, extra="") -> str:
    where = "" if xy is None else f"position_m = [{xy[0]!r}, {xy[1]!r}]\n"
    return f'[[joints]]\nname = "{name}"\nconnects = {connects!r}\n{where}{extra}\n'.replace("'", '"')


def driven(name) -> str:
    return f'[driver]\nlink = "{name}"\nspeeds_rad_s = [0.0]\n'


def slider_crank(stiff=1.0, slider_mass=0.45, rod_elements=8, extra="", guide="") -> str:
    """runs/slider-crank.toml's linkage: crank E scaled by ``stiff``, no big-end mass; ``guide``
    adds keys to the prismatic joint (its guide point is the origin unless given)."""
    crank = f"youngs_modulus_pa = {2.07e11 * stiff!r}\narea_m2 = 4.2e-4\nsecond_moment_m4 = 3.15e-8"
    point = None if "position_m" in guide else (0.0, 0.0)
    return (STEEL_TOML + link("crank", 0.045, 2, crank) + link("rod", 0.15, rod_elements)
            + joint("O", ["ground", "crank.root"], (0.0, 0.0)) + joint("A", ["crank.tip", "rod.root"])
            + joint("P", ["ground", "rod.tip"], point, f'type = "prismatic"\nslider_mass_kg = {slider_mass!r}\n{guide}')
            + extra + "\n" + driven("crank"))


def pinned_beam(n=32, mass="", length=1.0) -> str:
    """A beam pinned to ground at its root, its tip on a slider guided along its axis (transverse
    displacement held, axial free): a pinned-pinned beam. A lone crank is the driver."""
    return (STEEL_TOML + link("crank", 0.1, 1) + link("beam", length, n)
            + joint("O1", ["ground", "crank.root"], (0.0, -1.0)) + joint("O2", ["ground", "beam.root"], (0.0, 0.0))
            + joint("S", ["ground", "beam.tip"], (0.0, 0.0), 'type = "prismatic"') + mass + "\n" + driven("crank"))


def tip_inertia_cantilever(j, n=32, length=0.5) -> str:
    """A driven cantilever (clamped at its hub) with rotary inertia j·ρAL³ at its free end."""
    inertia = j * 7850.0 * 1.8e-4 * length**3
    mass = f'[[masses]]\nlink = "blade"\nposition_m = {length!r}\nmass_kg = 0.0\ninertia_kg_m2 = {inertia!r}\n'
    return STEEL_TOML + link("blade", length, n) + joint("hub", ["ground", "blade.root"], (0.0, 0.0)) + mass + driven("blade")


def tip_inertia_equation(x, j):
    """Clamped-free beam, tip rotary inertia j = J/ρAL³, at λ = βL (zero at a natural frequency)."""
    S, C, s, c = np.sinh(x), np.cosh(x), np.sin(x), np.cos(x)
    return (S - s) * ((S + s) - j * x**3 * (C - c)) - (C + c) * ((C + c) - j * x**3 * (S + s))


def central_mass_equation(a, r):
    """Pinned-pinned beam, central mass r·ρAL, a = βL/2: symmetric modes (zero at a frequency)."""
    return 2 * np.cos(a) - r * a * (np.sin(a) - np.cos(a) * np.tanh(a))


def link_eigen(model, link, theta=0.0):
    """Ω = 0 natural frequencies (rad/s) of the DOFs of one link (decoupled from the rest)."""
    import scipy.linalg as la

    mech = model.mechanism
    p = model.pieces(theta)
    dofs = np.unique(mech.node_dofs[mech.node_link == mech.link_names.index(link)])
    dofs = dofs[dofs >= 0]
    K = model.pattern.matrix(p.structural).toarray()[np.ix_(dofs, dofs)]
    M = model.pattern.matrix(p.mass).toarray()[np.ix_(dofs, dofs)]
    return np.sqrt(la.eigh(K, M, eigvals_only=True))


def _section(text):
    sc = parse_scene(text, "t.toml")
    lk = sc.links[-1]
    return sc, lk, lk.youngs_modulus * lk.second_moment, lk.density * lk.area


def dead_centre_rod(n_modes=3, element="thesis"):
    """(FE, closed-form) rod transverse frequencies (rad/s) of the stiff-crank slider-crank at θ = 0."""
    text = slider_crank(stiff=1e4, slider_mass=0.0, rod_elements=16) + f'[analysis]\nelement = "{element}"\n'
    sc = parse_scene(text, "t.toml")
    rod = sc.links[1]
    scale = np.sqrt(rod.youngs_modulus * rod.second_moment / (rod.density * rod.area * rod.length**4))
    exact = (np.arange(1, n_modes + 1) * np.pi) ** 2 * scale
    w = 2 * np.pi * frequencies(Model(sc, cases=("structure",)), 0.0, 0.0, "structure", n=6).frequency_hz
    return np.array([w[np.argmin(np.abs(w / x - 1))] for x in exact]), exact


def linkage_mechanisms() -> dict:
    """Mechanisms of the linkages beyond the four-bars: the two runs/ scenes and an inclined,
    offset slider carrying a lumped mass (kinematics and balance tests)."""
    from fkev_slepc.model.mechanism import build_mechanism

    text = slider_crank(extra='[[masses]]\nlink = "rod"\nposition_m = 0.05\nmass_kg = 0.1\ninertia_kg_m2 = 3e-5',
                        guide="position_m = [0.0, 0.012]\nguide_angle_deg = 25.0")
    out = {name: (lambda path=path: build_mechanism(load_scene(path))) for name, path in SCENES.items()}
    out["inclined-offset-slider"] = lambda: build_mechanism(parse_scene(text, "inclined.toml"))
    return out
