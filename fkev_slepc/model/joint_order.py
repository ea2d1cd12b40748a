"""Order in which the rigid-body kinematics locates the joints (docs/theory.md §3, docs/linkages.md).

The driver is placed first (clamped at its ground pivot, direction θ); then, repeatedly, an
unknown joint is solved in closed form from the links that reach it from located joints:

* RRR dyad: a revolute joint J reached by two unplaced links, each with another of its joint
  points at a located joint (P, Q). J is where the two circles about P and Q meet.
* RRP dyad: a prismatic joint J (a slider on a ground guide) reached by one unplaced link from
  a located joint P. J is where the circle about P meets the guide line.

A placed link is a rigid body: all its joint points (root, tip, a ternary link's third point)
are then located. Each link of a step is described by the vector ``d`` from its point at the
located joint to its point at J, in its own frame, so binary and ternary links are alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fkev_slepc.scene import Problem


@dataclass(frozen=True)
class Arm:
    """One link of a step: reaches joint J from located joint ``p``."""

    link: int
    p: int  # located joint
    r_p: tuple[float, float]  # the link's point at p, link frame
    d: tuple[float, float]  # from that point to the link's point at J, link frame


@dataclass(frozen=True)
class Step:
    """Locate joint ``joint``: RRR (two arms) or RRP (one arm and the joint's guide)."""

    joint: int
    arms: tuple[Arm, ...]
    sign: float  # RRR: +1 = J left of the ray P->Q; RRP: +1 = J ahead of P's foot along the guide


def order_steps(scene, names, attach, points, ground_known, prismatic, driver, problems) -> list[Step]:
    """Steps after the driver; ``attach[j]`` lists (link, point index) at joint j, ``points``
    (n_link, 3, 2) the link-frame points. Unlocatable links are reported in ``problems``."""
    n_link = len(names)
    known = ground_known.copy()
    placed = np.zeros(n_link, dtype=bool)
    link_joints = [[(j, k) for j, lst in enumerate(attach) for (lk, k) in lst if lk == i] for i in range(n_link)]

    def place(lk):
        placed[lk] = True
        for j, _ in link_joints[lk]:
            known[j] = True

    place(driver)
    steps: list[Step] = []
    progress = True
    while progress and not placed.all():
        progress = False
        for jj, joint in enumerate(scene.joints):
            if known[jj]:
                continue
            arms = []
            for lk, k in attach[jj]:
                if placed[lk]:
                    continue
                other = [(j, kp) for j, kp in link_joints[lk] if j != jj and known[j]]
                if other:
                    j_p, k_p = other[0]
                    r_p = points[lk, k_p]
                    d = points[lk, k] - r_p
                    arms.append(Arm(lk, j_p, (float(r_p[0]), float(r_p[1])), (float(d[0]), float(d[1]))))
            need = 1 if prismatic[jj] else 2
            if len(arms) >= need:
                branch = ("left", "ahead")
                sign = 1.0 if joint.assembly in branch else -1.0
                steps.append(Step(jj, tuple(arms[:need]), sign))
                for a in arms[:need]:
                    place(a.link)
                known[jj] = True
                progress = True
    for lk in np.flatnonzero(~placed):
        problems.append(
            Problem(
                f"links[{lk}]",
                f"link {names[lk]!r} cannot be located: the linkage must be the driven link plus "
                "dyads (two links meeting at a joint, or one link reaching a slider, their other "
                "joints located)",
            )
        )
    return steps
