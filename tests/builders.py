"""Programmatic scenes for tests (independent of the TOML loader)."""

from __future__ import annotations

import numpy as np

from fkev_slepc.scene.cases import CASE_NAMES
from fkev_slepc.scene import Analysis, Driver, Joint, Link, LinkEnd, LumpedMass, Scene

STEEL = dict(youngs_modulus=2.07e11, density=7760.0, area=1.61e-4, second_moment=8.66e-9)
ALUMINIUM = dict(youngs_modulus=7.1e10, density=2710.0)


def four_bar(lengths, ground, props, elements=(1, 2, 2), masses=(), speeds=(0.0,), accel=0.0,
             angles=(10.0,), cases=CASE_NAMES, modes=4, assembly="left") -> Scene:
    """Crank-rocker: O1=(0,0), O2=(ground,0); links crank, coupler, follower (docs/theory.md §2)."""
    names = ("crank", "coupler", "follower")
    props = props if isinstance(props, (list, tuple)) else (props,) * 3
    links = tuple(Link(n, L, elements=e, **p) for n, L, e, p in zip(names, lengths, elements, props))
    joints = (
        Joint("O1", "revolute", (LinkEnd("crank", "root"),), (0.0, 0.0)),
        Joint("A", "revolute", (LinkEnd("crank", "tip"), LinkEnd("coupler", "root"))),
        Joint("B", "revolute", (LinkEnd("coupler", "tip"), LinkEnd("follower", "tip")), assembly=assembly),
        Joint("O2", "revolute", (LinkEnd("follower", "root"),), (ground, 0.0)),
    )
    ms = tuple(LumpedMass(j, lk, m) for j, lk, m in masses)
    return Scene("four-bar", links, joints, Driver("crank", tuple(speeds), accel), ms,
                 Analysis(tuple(angles), tuple(cases), modes))


def bahgat_willmert(elements=(1, 2, 2), **kw) -> Scene:
    return four_bar((0.127, 0.2794, 0.2667), 0.254, STEEL, elements, **kw)


def turcic_midha(n=3, **kw) -> Scene:
    crank = dict(ALUMINIUM, area=1.07e-4, second_moment=1.62e-10)
    thin = dict(ALUMINIUM, area=0.41e-4, second_moment=8.67e-12)
    masses = (("A", "crank", 4.52e-2), ("B", "follower", 3.75e-2))
    return four_bar((0.108, 0.2794, 0.2705), 0.254, (crank, thin, thin), (n, n, n), masses=masses, **kw)


def cantilever(length, props, elements=16, speeds=(0.0,), accel=0.0, cases=("full",), modes=3) -> Scene:
    """One link driven about a clamped hub at the origin (a rotating cantilever)."""
    links = (Link("blade", length, elements=elements, **props),)
    joints = (Joint("hub", "revolute", (LinkEnd("blade", "root"),), (0.0, 0.0)),)
    return Scene("cantilever", links, joints, Driver("blade", tuple(speeds), accel), (),
                 Analysis((0.0,), tuple(cases), modes))


def rect_strip(width, thickness, E=2.07e11, rho=7760.0):
    """Section properties for in-plane bending across ``width``."""
    return dict(youngs_modulus=E, density=rho, area=width * thickness, second_moment=thickness * width**3 / 12)


def frequencies(model, theta_deg, omega, case, n=4, accel=None):
    from fkev_slepc.solve.dense import DenseEngine
    from fkev_slepc.solve.modes import postprocess

    q = model.qep(model.pieces(np.radians(theta_deg)), omega, case, accel)
    return postprocess(DenseEngine().solve(q, n), n)


def six_bar(elements=2, **kw) -> Scene:
    """Bahgat–Willmert four-bar with a second loop: a dyad (links 'arm', 'rocker2') hung from the
    compound joint B (coupler, follower, arm) and a third ground pivot O3 (a Watt-type chain)."""
    base = bahgat_willmert(elements=(elements,) * 3, **kw)
    links = base.links + tuple(Link(n, L, elements=elements, **STEEL) for n, L in (("arm", 0.2), ("rocker2", 0.22)))
    joints = list(base.joints)
    joints[2] = Joint("B", "revolute", (LinkEnd("coupler", "tip"), LinkEnd("follower", "tip"), LinkEnd("arm", "root")))
    joints += [
        Joint("C", "revolute", (LinkEnd("arm", "tip"), LinkEnd("rocker2", "tip"))),
        Joint("O3", "revolute", (LinkEnd("rocker2", "root"),), (0.25, 0.45)),
    ]
    from dataclasses import replace

    return replace(base, links=links, joints=tuple(joints), masses=(LumpedMass("C", "arm", 0.05),))
