"""The rigid machine's periodic steady state in the crank angle (docs/theory.md §20.3, §20.4):
speed, acceleration and time over one revolution, the mean speed, the coefficient of speed
fluctuation δ, and the flywheel for a requested δ.

The deviation Δ(θ) = ω − ω_r from the reference speed solves Δ′ = g(θ, ω) on the circle; it is
collocated at the Radau IIA points of a mesh of the revolution whose nodes include every knot of
the process-load tables, and the whole periodic system is solved at once by Newton's method.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fkev_slepc.model.drive_inertia import LinkageInertia, linkage_inertia
from fkev_slepc.model.drive_radau import cycle_mesh, hermite_extremes, radau_iia
from fkev_slepc.model.mechanism import Mechanism
from fkev_slepc.scene.model import Drive

STAGES = 4  # Radau IIA points per interval: order 2s - 1 = 7 at the nodes
MAX_STEP_DEG = 0.5  # the extremes of ω between nodes (cubic Hermite, error ~ h⁴) to ~3e-10 of δ at δ = 0.17
NEWTON_TOL = 1e-14  # on max |ΔΩ| / ω_r
STALL_TOL = 1e-11  # below, a Newton step that no longer halves is round-off
NEWTON_MAX = 60
FLYWHEEL_TOL = 1e-10  # |δ/δ_req - 1|


class DriveError(ValueError):
    """A drive that cannot turn the linkage steadily; ``key`` names the scene field to change."""

    def __init__(self, key: str, message: str):
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class DriveCycle:
    """The steady cycle at the mesh nodes θ_k ∈ [0, 2π) (``theta``, rad)."""

    theta: np.ndarray
    speed: np.ndarray  # ω(θ), rad/s
    accel: np.ndarray  # θ̈ = ω ω′, rad/s²
    time: np.ndarray  # t(θ) from θ = 0, s
    period: float  # s
    mean_speed: float  # 2π / period, rad/s
    speed_min: float
    speed_max: float
    fluctuation: float  # δ = (ω_max - ω_min) / ω_mean
    reference_speed: float  # ω_r: n T_m(n ω_r) = mean load torque
    motor_torque: np.ndarray  # T_m(n ω) on the motor shaft, N m
    crank_torque: np.ndarray  # n T_m - J_d θ̈: what the drive puts into the crank, N m
    load_torque: np.ndarray  # T_L(θ), N m
    inertia: np.ndarray  # J(θ) = J_d + J_L(θ), kg m²
    inertia_slope: np.ndarray  # J′(θ)
    energy_estimate: float  # δ by the energy method (§20.4)
    iterations: int  # Newton steps
    drive: Drive


class DriveProblem:
    """The linkage's J_L, J_L′ and T_L at the collocation points of the revolution, computed once;
    :meth:`solve` finds the steady cycle of any drive on it (a flywheel iteration re-solves)."""

    def __init__(self, mech: Mechanism, gravity=(0.0, 0.0), max_step_deg: float = MAX_STEP_DEG,
                 stages: int = STAGES):
        knots = [np.radians(np.asarray(pl.crank_angle_deg, float)) for pl in mech.scene.process_loads]
        self.nodes = cycle_mesh(knots, np.radians(max_step_deg))  # (M + 1,), 0 .. 2π
        self.h = np.diff(self.nodes)
        self.c, self.A = radau_iia(stages)
        at = (self.nodes[:-1, None] + self.h[:, None] * self.c[None, :]).ravel()
        self.link: LinkageInertia = linkage_inertia(mech, at, gravity)
        weights = (self.h[:, None] * self.A[-1][None, :]).ravel() / (2.0 * np.pi)  # mean over θ
        self.mean = lambda x: float(weights @ x)

    @property
    def shape(self) -> tuple[int, int]:
        return self.h.size, self.c.size

    @property
    def node_stage(self) -> np.ndarray:
        """The collocation index of each mesh node θ_0..θ_{M-1}: the last stage of the interval before it."""
        M, s = self.shape
        return np.roll(np.arange(M * s).reshape(M, s)[:, -1], 1)

    def solve(self, drive: Drive) -> DriveCycle:
        """The steady cycle of ``drive``."""
        n, Jd = drive.gear_ratio, drive.inertia
        J, dJ, TL = Jd + self.link.inertia, self.link.inertia_slope, self.link.load_torque
        wr = reference_speed(drive, self.mean(TL))
        T_ref = float(drive.motor_torque(n * wr))

        def g(delta):
            w = wr + delta
            F = n * (T_ref + drive.motor_change(n * wr, n * delta)) - TL
            val = (F - 0.5 * dJ * w * w) / (J * w)
            return val, (n * n * drive.motor_slope(n * w) - dJ * w) / (J * w) - val / w

        delta, its = self._newton(g, np.zeros(J.size), wr, drive.motor_field)
        return self._cycle(drive, delta, g(delta)[0], wr, its)

    def _newton(self, g, delta, wr, motor_field):
        M, s = self.shape
        hA = self.h[:, None, None] * self.A[None]  # (M, s, s)
        rows = np.arange(M * s).reshape(M, s)
        prev = self.node_stage  # the left node of every interval
        block_r = np.repeat(rows[:, :, None], s, axis=2).ravel()
        block_c = np.repeat(rows[:, None, :], s, axis=1).ravel()
        last = np.inf
        for it in range(1, NEWTON_MAX + 1):
            G, dG = g(delta)
            D = delta.reshape(M, s)
            R = D - D.ravel()[prev][:, None] - np.einsum("mij,mj->mi", hA, G.reshape(M, s))
            vals = np.eye(s)[None] - hA * dG.reshape(M, 1, s)
            jac = sp.csc_matrix((np.r_[vals.ravel(), -np.ones(M * s)],
                                 (np.r_[block_r, rows.ravel()], np.r_[block_c, np.repeat(prev, s)])),
                                shape=(M * s, M * s))
            step = spla.spsolve(jac, -R.ravel())
            if not np.all(np.isfinite(step)):
                break
            scale = 1.0
            while np.any(wr + delta + scale * step <= 0.0) and scale > 1e-3:
                scale *= 0.5
            delta = delta + scale * step
            size = float(np.max(np.abs(step))) / wr
            if scale == 1.0 and (size <= NEWTON_TOL or (size <= STALL_TOL and size > 0.5 * last)):
                return delta, it  # converged, or stalled at round-off
            last = size
        raise DriveError(motor_field, "no steady cycle: Newton's method on the periodic speed "
                         f"did not converge in {NEWTON_MAX} steps (the crank may stop: a stronger motor or a "
                         "larger flywheel?)")

    def _cycle(self, drive: Drive, delta, G, wr, its) -> DriveCycle:
        M, s = self.shape
        n, Jd = drive.gear_ratio, drive.inertia
        w_st = wr + delta
        t = np.r_[0.0, np.cumsum(self.h * ((self.A[-1][None, :] / w_st.reshape(M, s)).sum(axis=1)))]
        node = self.node_stage
        d, slope = delta[node], G[node]
        lo, hi = hermite_extremes(d, np.roll(d, -1), slope, np.roll(slope, -1), self.h)
        w, accel = wr + d, (wr + d) * slope
        motor = drive.motor_torque(n * wr) + drive.motor_change(n * wr, n * d)
        period = float(t[-1])
        mean = 2.0 * np.pi / period
        link = self.link
        return DriveCycle(
            theta=self.nodes[:-1], speed=w, accel=accel, time=t[:-1], period=period, mean_speed=mean,
            speed_min=wr + lo, speed_max=wr + hi, fluctuation=(hi - lo) / mean, reference_speed=wr,
            motor_torque=motor, crank_torque=n * motor - Jd * accel, load_torque=link.load_torque[node],
            inertia=Jd + link.inertia[node], inertia_slope=link.inertia_slope[node],
            energy_estimate=self.energy_excess(wr)[0] / ((Jd + self.mean(link.inertia)) * wr * wr),
            iterations=its, drive=drive)

    def energy_excess(self, speed: float) -> tuple[float, float]:
        """(ΔE_max − ΔE_min, J̄_L) of §20.4 at speed ``speed``: the excess energy's range over the
        revolution (extremes between nodes by Hermite interpolation) and the mean linkage inertia."""
        M, s = self.shape
        link = self.link
        rate = self.mean(link.load_torque) - link.load_torque - 0.5 * link.inertia_slope * speed**2
        work = np.r_[0.0, np.cumsum(self.h * (self.A[-1][None, :] * (self.mean(link.load_torque)
                                                                      - link.load_torque).reshape(M, s)).sum(axis=1))]
        node = self.node_stage
        E = work[:-1] - 0.5 * (link.inertia[node] - self.mean(link.inertia)) * speed**2
        lo, hi = hermite_extremes(E, np.roll(E, -1), rate[node], np.roll(rate[node], -1), self.h)
        return hi - lo, self.mean(link.inertia)


def reference_speed(drive: Drive, mean_load: float) -> float:
    """ω_r with n T_m(n ω_r) = T̄_L (§20.3), the crank speed; refused when the motor cannot carry
    the mean load or its torque does not fall with speed there."""
    n = drive.gear_ratio
    x, y = np.asarray(drive.speeds), n * np.asarray(drive.torques)  # crank-side torque at motor speeds x
    key = drive.motor_field
    if mean_load >= y.max() and (y[-1] - y[-2]) >= 0:
        raise DriveError(key, f"the motor cannot carry the mean load torque {mean_load:.6g} N m at the crank "
                         f"(its largest torque there, gear ratio x torque, is {y.max():.6g} N m)")
    above = np.flatnonzero((y[:-1] >= mean_load) & (y[1:] < mean_load))  # a falling crossing
    if above.size:
        i = int(above[0])
        wm = x[i] + (y[i] - mean_load) * (x[i + 1] - x[i]) / (y[i] - y[i + 1])
    elif y[-1] - y[-2] < 0 and y[-1] >= mean_load:  # on the extension beyond the table
        wm = x[-1] + (y[-1] - mean_load) * (x[-1] - x[-2]) / (y[-2] - y[-1])
    else:
        raise DriveError(key, f"the motor's torque does not fall with speed where it meets the mean load torque "
                         f"{mean_load:.6g} N m at the crank: no stable steady speed (docs/theory.md §20.3)")
    return float(wm / n)


def flywheel_for(problem: DriveProblem, drive: Drive, fluctuation: float, progress=None):
    """(J_f, cycle): the flywheel inertia (kg m², motor shaft) whose steady cycle has δ =
    ``fluctuation``, by the secant method on 1/δ(J_f) from the energy estimate (§20.4); 0 when the
    machine without a flywheel already fluctuates less. ``progress(k, J_f, δ)`` is told each step."""
    bare = problem.solve(replace(drive, flywheel_inertia=0.0))
    if bare.fluctuation <= fluctuation:
        return 0.0, bare
    n, wr = drive.gear_ratio, bare.reference_speed
    pp, J_mean = problem.energy_excess(wr)
    J_f = max(0.0, (pp / (wr * wr * fluctuation) - J_mean) / n**2 - drive.motor_inertia)
    points = [(0.0, 1.0 / bare.fluctuation)]
    cycle = bare
    for k in range(1, 40):
        cycle = problem.solve(replace(drive, flywheel_inertia=J_f))
        if progress is not None:
            progress(k, J_f, cycle.fluctuation)
        if abs(cycle.fluctuation / fluctuation - 1.0) <= FLYWHEEL_TOL:
            return J_f, cycle
        points.append((J_f, 1.0 / cycle.fluctuation))
        (x0, y0), (x1, y1) = points[-2], points[-1]
        J_f = max(0.0, x1 + (1.0 / fluctuation - y1) * (x1 - x0) / (y1 - y0))
    raise DriveError("fluctuation", f"the flywheel iteration for δ = {fluctuation:g} did not converge "
                     f"(last J_f = {J_f:.6g} kg m², δ = {cycle.fluctuation:.6g})")
