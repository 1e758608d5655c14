"""The pure-Python reference engine: an independent implementation to check the C against.

It shares no code with codegen/ or the generated C: only the scene loader and the result
types. Clarity comes first; speed is not a goal.

How the equations were derived (by hand, with Lagrange's equations rather than Kane's
method and sympy). With absolute angles, the velocity of the mass centre of link j is
v_Cj = sum_i a_ji L_i u_i e_i', where e_i' = (-sin q_i, cos q_i) and a_ji = 1 for i < j,
1/2 for i = j, 0 for i > j. The kinetic energy is then T = 1/2 sum_ik M_ik u_i u_k with

    M_ik = c_ik cos(q_i - q_k) + delta_ik m_i L_i^2 / 12,   c_ik = L_i L_k mu_ik,
    mu_ik = sum_j m_j a_ji a_jk = m_k'/2 + sum_{j > k'} m_j,  k' = max(i, k)   (i != k)
    mu_ii = m_i/4 + sum_{j > i} m_j.

Lagrange's equations d/dt(dT/du_i) - dT/dq_i = Q_i reduce to

    sum_k M_ik du_k/dt = Q_i - sum_k c_ik sin(q_i - q_k) u_k^2,

with the generalized forces of gravity and of the tip force (F_f, F):

    Q_i = -g L_i cos(q_i) (m_i/2 + sum_{j > i} m_j) + L_i (F cos q_i - F_f sin q_i).

Every joint (the end of link k, k = 1..n-1) and the tip (k = n) is a contact point with its
own laws and state (docs/model.md section 8). A normal force F_k and a friction force F_f,k at
point k act through the point's Jacobian: point k moves with the links i <= k, so they add
L_i (F_k cos q_i - F_f,k sin q_i) to Q_i for i <= k. Link i thus carries the forces of every
point at or beyond its end, and the tip's alone give the formula above.

The contact laws are written again from the model documentation (docs/model.md). The phases
are integrated with scipy.integrate.solve_ivp and its terminal, direction-filtered events.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from .dense import DenseSolution, TimeSampler
from .errors import SceneError, SolverError
from .results import (Impact, PhaseSpan, Ready, SimulationResult, Trajectory, impact_coefficients,
                      point_name, point_number)
from .scene import TOUCH_TOLERANCE, Scene

METHODS = ("Radau", "BDF", "LSODA", "DOP853", "RK45")
# Several stuck points: a direction of their holding forces' system weaker than this fraction
# of its strongest is not held (ChainModel.holding_forces)
HOLD_RCOND = 1e-8
MAX_SEGMENTS = 100_000  # phase and stick-slip switches in one run: beyond this, stop


# ----------------------------------------------------------------------------- the chain

@dataclass(frozen=True)
class ChainModel:
    L: np.ndarray
    m: np.ndarray
    g: float
    c: np.ndarray  # c_ik of the docstring (n x n)
    inertia: np.ndarray  # m_i L_i^2 / 12
    gravity_arm: np.ndarray  # m_i/2 + sum_{j>i} m_j

    @classmethod
    def from_scene(cls, scene: Scene) -> "ChainModel":
        L, m = np.array(scene.chain.length), np.array(scene.chain.mass)
        n = len(L)
        outboard = np.array([m[i + 1:].sum() for i in range(n)])  # sum_{j > i} m_j
        mu = np.empty((n, n))
        for i in range(n):
            for k in range(n):
                j = max(i, k)
                mu[i, k] = m[i] / 4 + outboard[i] if i == k else m[j] / 2 + outboard[j]
        return cls(L, m, scene.chain.gravity, np.outer(L, L) * mu, m * L ** 2 / 12, m / 2 + outboard)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return self.c * np.cos(q[:, None] - q[None, :]) + np.diag(self.inertia)

    def accelerations(self, q: np.ndarray, u: np.ndarray, F: float | np.ndarray,
                      F_f: float | np.ndarray) -> np.ndarray:
        """du/dt under the tip forces F (normal) and F_f (friction); or, as arrays (n,), under
        the forces each link carries (`loads`: those of every point at or beyond its end)."""
        velocity_terms = (self.c * np.sin(q[:, None] - q[None, :])) @ (u ** 2)
        Q = -self.g * self.L * np.cos(q) * self.gravity_arm + self.L * (F * np.cos(q) - F_f * np.sin(q))
        return np.linalg.solve(self.mass_matrix(q), Q - velocity_terms)

    def holding_force(self, q: np.ndarray, u: np.ndarray, F: float) -> float:
        """The tangential tip force that keeps v_Bx = -sum L_i sin(q_i) u_i at zero: with
        a_i = -L_i sin q_i, d(v_Bx)/dt = a . du/dt - sum L_i cos(q_i) u_i^2 = 0, and du/dt is
        affine in the force F_f (its generalized force is a F_f)."""
        a = -self.L * np.sin(q)
        free = self.accelerations(q, u, F, 0.0)
        per_newton = np.linalg.solve(self.mass_matrix(q), a)  # du/dt per newton of F_f
        return (np.sum(self.L * np.cos(q) * u ** 2) - a @ free) / (a @ per_newton)

    def loads(self, points: list[int], forces: list[float]) -> np.ndarray:
        """The force each link carries (n,): link i (from 0) carries the forces of the points
        k > i (point k, 1..n, is the end of link k and moves with the links up to it)."""
        carried = np.zeros(len(self.L))
        for k, force in zip(points, forces):
            carried[:k] += force
        return carried

    def point(self, q: np.ndarray, u: np.ndarray, k: int) -> tuple[float, float, float, float]:
        """x, y, v_x, v_y of the end of link k (k = 1..n; n is the tip): the sums of `tip`
        over the links up to it."""
        L, q, u = (self.L[:k] if q.ndim == 1 else self.L[:k, None]), q[:k], u[:k]
        return ((L * np.cos(q)).sum(0), (L * np.sin(q)).sum(0),
                (-L * u * np.sin(q)).sum(0), (L * u * np.cos(q)).sum(0))

    def holding_forces(self, q: np.ndarray, u: np.ndarray, F: np.ndarray, F_f: np.ndarray,
                       held: list[int]) -> np.ndarray:
        """The tangential forces at the points `held` (indices k) that keep their v_x at zero
        together, the links carrying the other forces F and F_f (`loads`). With A the rows
        a_k = (-L_i sin q_i for i < k, 0 beyond), d(v_x)/dt = A du/dt - c = 0 with
        c_k = sum_{i<k} L_i cos(q_i) u_i^2, and du/dt = free + M^-1 A^T F_hold. Two held points
        on one nearly horizontal link make A M^-1 A^T nearly singular: holding both exactly
        would take huge opposite forces for a motion of second order. Least squares with the
        cut-off HOLD_RCOND drops that direction (the smallest forces that hold the rest)."""
        n = len(self.L)
        A = np.array([np.where(np.arange(n) < k, -self.L * np.sin(q), 0.0) for k in held])
        c = np.array([np.sum((self.L * np.cos(q) * u ** 2)[:k]) for k in held])
        free = self.accelerations(q, u, F, F_f)
        per_newton = np.linalg.solve(self.mass_matrix(q), A.T)  # du/dt per newton at each held point
        return np.linalg.lstsq(A @ per_newton, c - A @ free, rcond=HOLD_RCOND)[0]

    def tip(self, q: np.ndarray, u: np.ndarray) -> tuple[float, float, float, float]:
        """x_B, y_B, v_Bx, v_By (works on arrays of samples too, q of shape (n, N))."""
        L = self.L if q.ndim == 1 else self.L[:, None]
        return ((L * np.cos(q)).sum(0), (L * np.sin(q)).sum(0),
                (-L * u * np.sin(q)).sum(0), (L * u * np.cos(q)).sum(0))

    def energies(self, q: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Kinetic energy per link (n, N) and potential energy (N,) for samples q, u (n, N)."""
        n = len(self.L)
        T = np.empty_like(u)
        V = np.zeros(q.shape[1])
        vx = np.zeros(q.shape[1])
        vy = np.zeros(q.shape[1])
        x = np.zeros(q.shape[1])
        y = np.zeros(q.shape[1])
        for j in range(n):
            L = self.L[j]
            vcx = vx - L / 2 * u[j] * np.sin(q[j])
            vcy = vy + L / 2 * u[j] * np.cos(q[j])
            T[j] = 0.5 * self.m[j] * (vcx ** 2 + vcy ** 2) + 0.5 * self.inertia[j] * u[j] ** 2
            V += self.m[j] * self.g * (y + L / 2 * np.sin(q[j]))
            vx, vy = vx - L * u[j] * np.sin(q[j]), vy + L * u[j] * np.cos(q[j])
            x, y = x + L * np.cos(q[j]), y + L * np.sin(q[j])
        return T, V


# ----------------------------------------------------------------------------- the contact

@dataclass
class Contact:
    """Material constants (docs/model.md section 3) and the state fixed at the switches."""

    E_star: float
    R: float
    delta_c: float
    P_c: float
    C_j: float
    B: float
    mu: float
    eps: float
    y_s: float
    plastic: bool
    exact_coulomb: bool = False
    slip: float = 1.0  # exact Coulomb: +1 / -1 slipping along +x / -x, 0 stuck
    frozen: bool = False  # friction keeps the direction it had at contact start
    frozen_sign: float = 0.0  # frozen: the sign of v_Bx when the contact began
    delta_m: float = 0.0
    delta_r: float = 0.0
    R_res: float = 0.0

    @classmethod
    def from_scene(cls, scene: Scene, y_s: float, radius: float | None = None) -> "Contact":
        """The contact of the tip, or of a point of contact radius `radius` (a joint's)."""
        Er, Es = scene.rod.E, scene.surface.E
        E_star = 1.0 / ((1 - scene.rod.nu ** 2) / Er + (1 - scene.surface.nu ** 2) / Es)
        weak = min((scene.rod, scene.surface), key=lambda mat: mat.yield_strength)
        C_j = 1.295 * math.exp(0.736 * weak.nu)
        R = scene.tip_radius if radius is None else radius
        p0 = math.pi * C_j * weak.yield_strength / 2  # the pressure scale pi C_j S_y / 2
        delta_c, P_c = R * (p0 / E_star) ** 2, 4.0 / 3.0 * (R / E_star) ** 2 * p0 ** 3
        if not all(0 < v < math.inf for v in (E_star, delta_c, P_c)):  # the laws divide by them
            key, value = ("rod.E", Er) if Er >= Es else ("surface.E", Es)
            raise SceneError(key, f"{value!r} is outside its physical range (the contact constants E*, delta_c "
                                  "and P_c it gives leave double precision's range)")
        return cls(E_star=E_star, R=R, delta_c=delta_c, P_c=P_c, C_j=C_j,
                   B=0.14 * math.exp(23 * weak.yield_strength / E_star),
                   mu=scene.contact.friction, eps=scene.contact.friction_eps, y_s=y_s,
                   plastic=scene.contact.model == "three-phase", R_res=R,
                   exact_coulomb=scene.contact.friction_mode == "coulomb" and scene.contact.friction > 0,
                   frozen=scene.contact.friction_mode == "frozen")

    def hertz(self, delta: float, radius: float) -> float:
        return 4.0 / 3.0 * self.E_star * math.sqrt(radius) * delta ** 1.5 if delta > 0 else 0.0

    def jackson_green(self, delta: float) -> float:
        if delta <= 0:
            return 0.0
        w = delta / self.delta_c
        a = math.sqrt(self.R * delta * (delta / (1.9 * self.delta_c)) ** self.B)
        H_Sy = 2.84 - 0.92 * (1 - math.cos(math.pi * a / self.R))
        return self.P_c * (math.exp(-0.17 * w ** (5 / 12)) * w ** 1.5
                           + 4 * H_Sy / self.C_j * (1 - math.exp(-(w ** (5 / 9)) / 78)) * w ** 1.1)

    def normal_force(self, phase: str, delta: float) -> float:
        if phase == "elastic":
            return self.hertz(delta, self.R)
        if phase == "elastoplastic":
            return self.jackson_green(delta)
        if phase in ("restitution", "reloading"):
            return self.hertz(delta - self.delta_r, self.R_res) if self.plastic else self.hertz(delta, self.R)
        return 0.0

    def friction(self, F: float, v_Bx: float) -> float:
        """Sliding friction: the regularized sign of v_Bx, or exact Coulomb's fixed slip sign."""
        if self.mu == 0:
            return 0.0
        if self.exact_coulomb:
            return -self.mu * F * self.slip
        if self.frozen:
            return -self.mu * F * self.frozen_sign
        return -self.mu * F * v_Bx / math.sqrt(v_Bx ** 2 + self.eps ** 2)

    def at_maximum_compression(self, delta_m: float, P_m: float) -> None:
        """Fix delta_m, delta_r (Eq. 12, clamped) and R_res (continuity at delta_m)."""
        self.delta_m = delta_m
        if self.plastic:
            self.delta_r = max(0.0, delta_m * (1 - math.sqrt(6.5 / (delta_m / self.delta_c + 5.5))))
            self.R_res = (3 * P_m / (4 * self.E_star)) ** 2 / (delta_m - self.delta_r) ** 3
        else:
            self.delta_r, self.R_res = 0.0, self.R

    def reset(self) -> None:
        self.delta_m, self.delta_r, self.R_res = 0.0, 0.0, self.R


# ----------------------------------------------------------------------------- contact points

@dataclass
class ContactPoint:
    """A point of the chain that can touch the surface, with its own laws and state."""

    index: int  # 1..n-1: joint k, the end of link k; n: the tip (the floor net's numbering)
    name: str  # "joint k" or "tip"
    contact: Contact  # its material constants (its own radius) and the state fixed at its switches
    phase: str = "free"
    impact: "PointImpact | None" = None  # the impact it is in, if any


@dataclass
class PointForce:
    """The forces at one point in contact, and its velocity (for the works)."""

    point: ContactPoint
    F: float
    F_f: float
    v_x: float
    v_y: float
    held: bool  # its F_f is the force that holds it still (exact Coulomb, stuck)


def reachable_joints(scene: Scene, y_s: float) -> list[int]:
    """The joints (k = 1..n-1) that can reach the surface: the chain up to joint k is at least
    as long as the pivot is high above the surface (with the start's rounding)."""
    slack = TOUCH_TOLERANCE * max(1.0, sum(scene.chain.length))
    reach = np.cumsum(scene.chain.length)
    return [k for k in range(1, scene.n) if reach[k - 1] >= -y_s - slack]


# ----------------------------------------------------------------------------- right-hand side

@dataclass
class ReferenceModel:
    """The chain, the tip's contact (`contact`) and the joints that can touch the surface
    (`joints`, each with its own contact). The tip's phase is the argument of `rhs`, as the
    phase loop passes it; a joint's is its own `phase`."""

    chain: ChainModel
    contact: Contact
    n: int
    friction_state: bool  # the state carries W_friction
    joints: list[ContactPoint] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.tip = ContactPoint(self.n, "tip", self.contact)
        self.points = [*self.joints, self.tip]  # by index: the tip last
        self.nstate = 2 * self.n + (4 if self.friction_state else 2)  # q, u, the works, the impulses

    @property
    def state_names(self) -> tuple[str, ...]:
        """The columns of the state as `rhs` lays them out (the C model's, build.CompiledModel's)."""
        n = self.n
        integrated = (("W_normal", "W_friction", "P_normal", "P_friction") if self.friction_state
                      else ("W_normal", "P_normal"))  # the works, then the impulses
        return (*(f"q{i + 1}" for i in range(n)), *(f"u{i + 1}" for i in range(n)), *integrated)

    @classmethod
    def from_scene(cls, scene: Scene) -> "ReferenceModel":
        y_s = scene.surface_height
        if y_s is None:
            y_s = sum(L * math.sin(q) for L, q in zip(scene.chain.length, scene.q0))
        joints = [ContactPoint(k, point_name(k, scene.n), Contact.from_scene(scene, y_s, scene.joint_radii[k - 1]))
                  for k in reachable_joints(scene, y_s)]
        return cls(ChainModel.from_scene(scene), Contact.from_scene(scene, y_s), scene.n,
                   scene.contact.friction > 0, joints)

    def joints_in_contact(self) -> bool:
        return any(p.phase != "free" for p in self.joints)

    def rhs(self, t: float, y: np.ndarray, phase: str) -> np.ndarray:
        """dy/dt with the tip in `phase`. A state longer than `nstate` carries, after it, the
        works and impulses of each point in contact on its own (when several are)."""
        n = self.n
        if self.joints_in_contact():
            return self._rhs_of_points(t, y, phase)
        _, y_B, v_Bx, v_By = self.chain.tip(y[:n], y[n:2 * n])
        F = self.contact.normal_force(phase, self.contact.y_s - y_B)
        F_f = self.tangential_force(y, phase, F, v_Bx)
        works = [F * v_By] + ([F_f * v_Bx] if self.friction_state else [])
        impulses = [F] + ([F_f] if self.friction_state else [])  # P_normal[, P_friction]
        return np.concatenate([self.chain_rates(t, y, F, F_f), works, impulses])

    def _rhs_of_points(self, t: float, y: np.ndarray, phase: str) -> np.ndarray:
        """dy/dt with joints in contact: each point's forces act through its own Jacobian."""
        active = self.contact_forces(y, phase)
        indices = [a.point.index for a in active]
        F = self.chain.loads(indices, [a.F for a in active])
        F_f = self.chain.loads(indices, [a.F_f for a in active])
        total = sum((self.integrands(a) for a in active), np.zeros(self.nstate - 2 * self.n))
        parts = [self.chain_rates(t, y, F, F_f), total]
        if len(y) > self.nstate:  # each point's own, in the order of `points`
            parts += [self.integrands(a) for a in active]
        return np.concatenate(parts)

    def integrands(self, a: PointForce) -> np.ndarray:
        """The rates of W_normal[, W_friction], P_normal[, P_friction] of one point's forces."""
        if self.friction_state:
            return np.array([a.F * a.v_y, a.F_f * a.v_x, a.F, a.F_f])
        return np.array([a.F * a.v_y, a.F])

    def contact_forces(self, y: np.ndarray, phase: str, stopping: ContactPoint | None = None,
                       stopping_phase: str = "") -> list[PointForce]:
        """The forces at every point in contact, the tip in `phase`. `stopping`: a point held
        still (in `stopping_phase`) as if stuck, to see whether it sticks at a stop. Stuck
        points are held together (exact Coulomb): their forces depend on each other."""
        n = self.n
        q, u = y[:n], y[n:2 * n]
        active = []
        for p in self.points:
            ph = stopping_phase if p is stopping else (phase if p is self.tip else p.phase)
            if ph == "free":
                continue
            _, y_k, v_x, v_y = self.kinematics(y, p)
            F = p.contact.normal_force(ph, p.contact.y_s - y_k)
            held = p is stopping or (p.contact.exact_coulomb and p.contact.slip == 0)
            active.append(PointForce(p, F, 0.0 if held else p.contact.friction(F, v_x), v_x, v_y, held))
        held = [a for a in active if a.held]
        if len(active) == 1 and held and active[0].point is self.tip:  # the tip alone, as ever
            held[0].F_f = self.chain.holding_force(q, u, held[0].F)
        elif held:
            indices = [a.point.index for a in active]
            hold = self.chain.holding_forces(q, u, self.chain.loads(indices, [a.F for a in active]),
                                             self.chain.loads(indices, [a.F_f for a in active]),
                                             [a.point.index for a in held])
            for a, h in zip(held, hold):
                a.F_f = float(h)
        return active

    def kinematics(self, y: np.ndarray, point: ContactPoint) -> tuple[float, float, float, float]:
        """x, y, v_x, v_y of a contact point."""
        n = self.n
        if point is self.tip:
            return self.chain.tip(y[:n], y[n:2 * n])
        return self.chain.point(y[:n], y[n:2 * n], point.index)

    def stuck(self, phase: str) -> bool:
        return self.contact.exact_coulomb and self.contact.slip == 0 and phase != "free"

    def tangential_force(self, y: np.ndarray, phase: str, F: float, v_Bx: float) -> float:
        """The tip's friction force."""
        if self.joints_in_contact():
            return next((a.F_f for a in self.contact_forces(y, phase) if a.point is self.tip), 0.0)
        if self.stuck(phase):
            return self.chain.holding_force(y[:self.n], y[self.n:2 * self.n], F)
        return self.contact.friction(F, v_Bx)

    def chain_rates(self, t: float, y: np.ndarray, F: float | np.ndarray, F_f: float | np.ndarray) -> np.ndarray:
        """dq/dt and du/dt of the chain under the tip forces F (normal) and F_f (friction), or
        under the forces each link carries (arrays, `ChainModel.loads`)."""
        n = self.n
        q, u = y[:n], y[n:2 * n]
        return np.concatenate([u, self.chain.accelerations(q, u, F, F_f)])

    def delta_and_rate(self, y: np.ndarray, point: ContactPoint | None = None) -> tuple[float, float]:
        """The penetration of the tip (or of `point`) and its rate."""
        n = self.n
        if point is None or point is self.tip:
            _, y_B, _, v_By = self.chain.tip(y[:n], y[n:2 * n])
            return self.contact.y_s - y_B, -v_By
        _, y_k, _, v_y = self.kinematics(y, point)
        return point.contact.y_s - y_k, -v_y

    def outputs(self, t: np.ndarray, y: np.ndarray, phase: str) -> dict[str, np.ndarray]:
        """The tip's outputs, the energies, and each joint's penetration and normal force."""
        n = self.n
        q, u = y[:, :n].T, y[:, n:2 * n].T
        x_B, y_B, v_Bx, v_By = self.chain.tip(q, u)
        delta = self.contact.y_s - y_B
        F = np.array([self.contact.normal_force(phase, d) for d in delta])
        out = {"x_B": x_B, "y_B": y_B, "v_Bx": v_Bx, "v_By": v_By, "delta": delta, "delta_rate": -v_By, "F": F}
        if self.friction_state:
            out["F_f"] = np.array([self.tangential_force(yk, phase, f, v) for yk, f, v in zip(y, F, v_Bx)])
        T, V = self.chain.energies(q, u)
        out.update({f"T{i + 1}": T[i] for i in range(n)})
        out["T"], out["V"] = T.sum(0), V
        for p in self.joints:
            delta_k = p.contact.y_s - self.chain.point(q, u, p.index)[1]
            out[f"delta_J{p.index}"] = delta_k
            out[f"F_J{p.index}"] = np.array([p.contact.normal_force(p.phase, d) for d in delta_k])
        return out


# ----------------------------------------------------------------------------- phase loop

def _event(fn, direction: int):
    """A terminal solve_ivp event that fires only on crossings in `direction`."""
    def event(t: float, y: np.ndarray) -> float:
        return fn(t, y)
    event.terminal = True
    event.direction = direction
    return event


FRICTION_EVENTS = ("slip_stops", "slip_backward", "slip_forward")
SLIP_NAMES = {1.0: "slip+", -1.0: "slip-", 0.0: "stick"}
POINT_SEPARATOR = ": "  # a joint's event is named "joint k: <event>"; the tip's has no prefix


def _event_name(point: ContactPoint, event: str) -> str:
    return event if point.name == "tip" else f"{point.name}{POINT_SEPARATOR}{event}"


def _split_event(model: ReferenceModel, name: str) -> tuple[ContactPoint, str]:
    """The point and the event of an event's name."""
    prefix, _, event = name.rpartition(POINT_SEPARATOR)
    return (next(p for p in model.joints if p.name == prefix) if prefix else model.tip), event


def _friction_events(model: ReferenceModel, phase: str, point: ContactPoint) -> dict[str, object]:
    """Exact Coulomb: a slip ends when the point's v_x returns to 0, a stick when the holding
    force leaves the cone |F_f| <= mu F. `phase`: the tip's."""
    c = point.contact
    if not c.exact_coulomb or (phase if point is model.tip else point.phase) == "free":
        return {}
    if c.slip != 0:
        return {"slip_stops": _event(lambda t, y: model.kinematics(y, point)[2], -int(c.slip))}

    def cone(side: float):
        def gap(t: float, y: np.ndarray) -> float:
            a = next(a for a in model.contact_forces(y, phase) if a.point is point)
            return c.mu * a.F - side * a.F_f
        return gap
    return {"slip_backward": _event(cone(+1.0), -1), "slip_forward": _event(cone(-1.0), -1)}


def _slip_at_stop(model: ReferenceModel, y: np.ndarray, phase: str, point: ContactPoint | None = None) -> float:
    """Stick if the force holding the point (the tip by default, in `phase`) still lies
    strictly inside the cone, else slip against it."""
    point = point or model.tip
    a = next(a for a in model.contact_forces(y, model.tip.phase, point, phase) if a.point is point)
    hold = a.F_f
    return 0.0 if abs(hold) < point.contact.mu * a.F or hold == 0 else -math.copysign(1.0, hold)


def _phase_events(model: ReferenceModel, phase: str, y: np.ndarray | None = None) -> dict[str, object]:
    """The events of every point, the tip's first (the tip in `phase`), for a segment that
    begins at state `y`."""
    events = {}
    for point in (model.tip, *model.joints):
        ph = phase if point is model.tip else point.phase
        start = model.delta_and_rate(y, point)[0] if y is not None and ph == "free" else 0.0
        own = {**_contact_events(model, ph, point, start), **_friction_events(model, phase, point)}
        events.update({_event_name(point, name): event for name, event in own.items()})
    return events


def _contact_events(model: ReferenceModel, phase: str, point: ContactPoint, start: float = 0.0) -> dict[str, object]:
    """The events of one point in `phase`; `start`: its penetration where a free segment begins."""
    c = point.contact
    delta = lambda t, y: model.delta_and_rate(y, point)[0]  # noqa: E731
    rate = lambda t, y: model.delta_and_rate(y, point)[1]  # noqa: E731
    if phase == "free":
        # A point that separated is still at delta_r (or a rounding inside 0): were it to turn
        # back before leaving the surface, delta rising through 0 would never fire. "reentry"
        # fires where it comes back to where it separated, its dent's bottom; having left the
        # surface, it meets "contact" first (the earlier root of the two).
        entry = max(c.delta_r, start)
        if entry > 0:
            return {"contact": _event(delta, 1), "reentry": _event(lambda t, y: delta(t, y) - entry, 1)}
        return {"contact": _event(delta, 1)}
    if phase == "elastic":
        ev = {"max_compression": _event(rate, -1)}
        if c.plastic:
            ev["yield"] = _event(lambda t, y: delta(t, y) - 1.9 * c.delta_c, 1)
        return ev
    if phase == "elastoplastic":
        return {"max_compression": _event(rate, -1)}
    if phase == "restitution":
        return {"separation": _event(lambda t, y: delta(t, y) - c.delta_r, -1),
                "reloading": _event(rate, 1)}
    # reloading
    return {"unloading": _event(rate, -1),
            "passes_delta_m": _event(lambda t, y: delta(t, y) - c.delta_m, 1)}


def _after(phase: str, event: str, contact: Contact) -> str:
    if (phase, event) == ("free", "reentry"):  # into its own dent (with one), else a new impact
        return "reloading" if contact.delta_r > 0 else "elastic"
    table = {("free", "contact"): "elastic", ("elastic", "yield"): "elastoplastic",
             ("elastic", "max_compression"): "restitution",
             ("elastoplastic", "max_compression"): "restitution",
             ("restitution", "separation"): "free", ("restitution", "reloading"): "reloading",
             ("reloading", "unloading"): "restitution"}
    if (phase, event) in table:
        return table[(phase, event)]
    # reloading passed delta_m: back onto the loading curve it left
    return "elastoplastic" if contact.plastic and contact.delta_m >= 1.9 * contact.delta_c else "elastic"


@dataclass
class Segment:
    """What an integrator returns for one phase: samples after t0 (the event point last when
    an event fired), the events that fired, and its counters."""

    t: np.ndarray
    y: np.ndarray
    fired: list[str]
    nsteps: int
    nfev: int
    njev: int
    sol: object = None  # solve_ivp's OdeSolution of the segment, when dense output was asked for


def solve_ivp_segment(model: "ReferenceModel", phase: str, t0: float, y0: np.ndarray, t_final: float,
                      events: dict[str, object], method: str, rtol: float, atol: np.ndarray,
                      dense: bool = False) -> Segment:
    """Integrate one phase with scipy.integrate.solve_ivp and its terminal events."""
    names = list(events)
    sol = solve_ivp(lambda t_, y_: model.rhs(t_, y_, phase), (t0, t_final), y0, method=method,
                    rtol=rtol, atol=atol, events=list(events.values()), dense_output=dense)
    if sol.status < 0:
        error = SolverError(f"solve_ivp ({method}): {sol.message}", phase, float(sol.t[-1]))
        error.partial = (sol.t[1:], sol.y.T[1:])
        raise error
    fired = [names[i] for i, te in enumerate(sol.t_events) if len(te)]
    seg_t, seg_y = sol.t[1:], sol.y.T[1:]
    if fired:  # the last sample is the event point
        seg_t = np.append(seg_t[:-1], sol.t_events[names.index(fired[0])][0])
        seg_y = np.vstack([seg_y[:-1], sol.y_events[names.index(fired[0])][0]])
    return Segment(seg_t, seg_y, fired, len(sol.t) - 1, sol.nfev, sol.njev, sol.sol)


FLOOR_DEPTH = 0.01  # the floor net: deeper than this fraction of the shortest link below the surface fails


def _under_floor(model: ReferenceModel, t: np.ndarray, y: np.ndarray) -> tuple[int, str] | None:
    """The floor net, written again from the chain: joint k's height is sum_{i <= k} L_i sin q_i
    (the tip's is the whole sum). The first sample where a joint or the tip lies deeper below
    the surface than FLOOR_DEPTH of the shortest link, and the message naming it; None if none."""
    n = model.n
    heights = np.cumsum(model.chain.L[:, None] * np.sin(y[:, :n].T), axis=0) - model.contact.y_s
    below = heights < -FLOOR_DEPTH * model.chain.L.min()
    hits = np.flatnonzero(below.any(axis=0))
    if not len(hits):
        return None
    k = int(hits[0])
    point = int(np.flatnonzero(below[:, k])[0])
    name = "the tip" if point == n - 1 else f"joint {point + 1}"
    return k, (f"{name} is {-heights[point, k]:.3g} m below the surface at t = {t[k]:.6g} s (deeper than "
               f"{100 * FLOOR_DEPTH:g} % of the shortest link, beyond any contact's depth): the chain went "
               "through the surface")


@dataclass
class _Recorder:
    t: list = field(default_factory=list)
    y: list = field(default_factory=list)
    phase: list = field(default_factory=list)
    outputs: list = field(default_factory=list)
    count: int = 0

    def add(self, model: ReferenceModel, t: np.ndarray, y: np.ndarray, phase: str, label: str | None = None) -> None:
        """Samples of one segment: the tip in `phase`, the segment named `label` (the phases of
        the points in contact; the tip's phase by default)."""
        self.t.append(t)
        self.y.append(y)
        self.phase.append(np.full(len(t), phase if label is None else label))
        self.outputs.append(model.outputs(t, y, phase))
        self.count += len(t)


def _segment_label(model: ReferenceModel) -> tuple[str, str]:
    """The phase and stick-slip state a segment is listed with: the tip's, as ever, while no
    joint is in contact; else "joint 2: restitution, tip: elastic" (the points in contact)."""
    c = model.contact
    if not model.joints_in_contact():
        return model.tip.phase, (SLIP_NAMES[c.slip] if c.exact_coulomb and model.tip.phase != "free" else "")
    touching = [p for p in model.points if p.phase != "free"]
    friction = ", ".join(f"{p.name}: {SLIP_NAMES[p.contact.slip]}" for p in touching) if c.exact_coulomb else ""
    return ", ".join(f"{p.name}: {p.phase}" for p in touching), friction


def _slip_direction_check(model: ReferenceModel, y: np.ndarray, phase: str, t: float, impact: Impact,
                          point: ContactPoint | None = None) -> None:
    """After a contact event with no stick-slip event: a slip whose point (the tip by
    default, now in `phase`) has stopped, or moves the other way, is decided as at a stop (its
    event can coincide with the contact event: a single bar stops sliding exactly when it
    stops penetrating)."""
    point = point or model.tip
    c = point.contact
    if not c.exact_coulomb or c.slip == 0:
        return
    _, _, v_x, v_y = model.kinematics(y, point)
    if v_x * c.slip > 1e-9 * math.hypot(v_x, v_y):
        return
    old, c.slip = c.slip, _slip_at_stop(model, y, phase, point)
    if c.slip != old:
        impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))


def _release_overloaded(model: ReferenceModel, y: np.ndarray, t: float) -> None:
    """Exact Coulomb with joints in contact: the stuck points are held together, so a switch
    of one point can push another's holding force out of its cone (two points of a nearly flat
    link hold it only by huge opposite forces). The point furthest out of its cone then slips
    against its force, and the rest are held again, until every stuck point holds."""
    if not model.joints_in_contact():
        return  # the tip alone: its own cone events decide
    while True:
        over = [(abs(a.F_f) / (a.point.contact.mu * a.F) if a.F > 0 else math.inf, a)
                for a in model.contact_forces(y, model.tip.phase)
                if a.held and a.F_f != 0 and abs(a.F_f) >= a.point.contact.mu * a.F]
        if not over:
            return
        _, a = max(over, key=lambda item: item[0])
        c = a.point.contact
        old, c.slip = c.slip, -math.copysign(1.0, a.F_f)
        a.point.impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))


def _begin_slip(model: ReferenceModel, y: np.ndarray, point: ContactPoint | None = None) -> None:
    """A contact begins slipping the way the point (the tip by default) moves (as at a stop if
    it does not); frozen friction keeps that direction to separation."""
    point = point or model.tip
    _, _, v_x, v_y = model.kinematics(y, point)
    point.contact.frozen_sign = float(np.sign(v_x))
    if not point.contact.exact_coulomb:
        return
    moving = abs(v_x) > 1e-12 * math.hypot(v_x, v_y)
    point.contact.slip = math.copysign(1.0, v_x) if moving else _slip_at_stop(model, y, "elastic", point)


# ----------------------------------------------------------------------------- per-point records

@dataclass
class PointImpact(Impact):
    """An impact of one contact point. `W_normal` and `W_friction` (and the energy budget) are
    those of every contact force over the impact's time, as for any impact; `W_normal_point`
    and `W_friction_point` are this point's own, and the impulses and coefficients
    (docs/model.md section 9) are this point's, from its own normal speed and forces."""

    # its integrals (W_normal[, W_friction], P_normal[, P_friction]) at its start, maximum
    # compression and end, and its normal speed at its start and end; filled by the engine
    own: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def use_own_values(self, names: tuple[str, ...]) -> None:
        """This point's works, impulses and coefficients from its own integrals (`names`:
        the integrals' names, as the state carries them)."""
        marks = {key: dict(zip(names, values)) for key, values in self.own.items() if key in ("begin", "at_max", "end")}
        if "begin" not in marks or "end" not in marks:
            return
        begin, end = marks["begin"], marks["end"]
        self.W_normal_point = end["W_normal"] - begin["W_normal"]
        self.W_friction_point = end.get("W_friction", 0.0) - begin.get("W_friction", 0.0)
        self.v_n0 = self.own["v_n0"]
        if self.i_end is not None and "at_max" in marks:
            values = impact_coefficients(begin, marks["at_max"], end, self.own["v_n0"], self.own["v_n1"])
            for name, value in values.items():
                setattr(self, name, value)


@dataclass
class ReferenceResult(SimulationResult):
    """The reference engine's result: its impacts are those of each contact point
    (`PointImpact`), with each point's own works and coefficients."""

    several_points: bool = False  # joints can touch: the points' own integrals differ from the totals

    @cached_property
    def impacts(self) -> list[Impact]:
        """The impacts (their energies from the samples), each with its point's own values."""
        impacts = SimulationResult.impacts.func(self)
        names = self.trajectory.state_names[2 * self.n:]  # the works, then the impulses
        if self.several_points:  # the tip alone: its own values are the totals, as made already
            for impact in impacts:
                impact.use_own_values(names)
        return impacts

    @property
    def point_works(self) -> dict[str, dict[str, float]]:
        """The works of each point's own forces over the run, by point name ("joint 1", ...,
        "tip"), as {"W_normal": J, "W_friction": J}; their sums are the run's W_normal and
        W_friction (every contact force acts within an impact of its point)."""
        works = {point_name(k, self.n): {"W_normal": 0.0, "W_friction": 0.0} for k in range(1, self.n + 1)}
        for impact in self.impacts:
            works[impact.point]["W_normal"] += impact.W_normal_point
            works[impact.point]["W_friction"] += impact.W_friction_point
        return works


class _PointIntegrals:
    """Each point's own works and impulses, summed as the run goes: a segment with one point
    in contact gives it the change of the state's totals; one with several integrates each
    point's own (extra states after the totals, for that segment only, so that a run with one
    point in contact at a time integrates exactly the states it always did)."""

    def __init__(self, model: ReferenceModel):
        self.model = model
        self.width = model.nstate - 2 * model.n
        self.sums = {id(p): np.zeros(self.width) for p in model.points}

    def extra_states(self, touching: list[ContactPoint]) -> int:
        return self.width * len(touching) if len(touching) > 1 else 0

    def at(self, touching: list[ContactPoint], y_begin: np.ndarray, row: np.ndarray) -> dict[int, np.ndarray]:
        """The sums at a sample `row` (the extended state) of a segment that began at `y_begin`."""
        n, sums = self.model.n, dict(self.sums)
        base = self.model.nstate
        if len(touching) == 1:
            p = touching[0]
            sums[id(p)] = sums[id(p)] + (row[2 * n:base] - y_begin[2 * n:base])
        elif touching:
            for j, p in enumerate(touching):
                sums[id(p)] = sums[id(p)] + row[base + j * self.width: base + (j + 1) * self.width]
        return sums


def _mark(impact: "PointImpact", key: str, sums: dict[int, np.ndarray], point: ContactPoint) -> None:
    impact.own[key] = sums[id(point)].tolist()


def simulate(scene: Scene, method: str = "Radau", rtol: float | None = None,
             atol: float | None = None, model: ReferenceModel | None = None,
             integrate=solve_ivp_segment, engine: str = "reference", t_eval: np.ndarray | None = None,
             dense_output: bool = False) -> SimulationResult:
    """Run `scene` through the phases with solve_ivp; the result has the C engine's shape.
    `model` and `integrate` let a benchmark put another right-hand side or integrator
    under the same phase loop. solver.max_steps is checked after each phase segment (solve_ivp
    has no step limit of its own). A failure ends the run with status "failed".

    Every joint that can reach the surface and the tip are contact points, each with its own
    phase and impacts (`PointImpact`); a run to separation ends when, after the first
    contact, no point touches the surface any more."""
    if method not in METHODS and integrate is solve_ivp_segment:
        raise SceneError("method", f"{method!r} is not one of {', '.join(METHODS)}")
    if scene.solver.t_end is not None and scene.solver.sustained_contact:
        raise SceneError("solver.sustained_contact", "the reference engine simulates every impact "
                         "and has no sustained-contact phase: set it to false to compare the engines")
    started = time.perf_counter()
    model = model or ReferenceModel.from_scene(scene)
    n = scene.n
    rtol = scene.solver.rtol if rtol is None else rtol
    atol_q = scene.solver.atol if atol is None else atol
    state_names = model.state_names
    nstate = len(state_names)  # q, u, the works, the impulses
    energy_scale = max(sum(scene.chain.mass) * max(scene.chain.gravity, 1.0) * sum(scene.chain.length), 1e-30)
    atol_integrals = atol_q * energy_scale
    atol_vec = np.full(nstate, atol_q)
    atol_vec[2 * n:] = atol_integrals
    dense = dense_output or t_eval is not None
    extra = {"dense": True} if dense else {}

    y = np.concatenate([scene.q0, scene.u0, np.zeros(nstate - 2 * n)])
    t = 0.0
    touch = 1e-12 * max(1.0, sum(scene.chain.length))
    delta0, rate0 = model.delta_and_rate(y)
    touching = delta0 >= -touch
    _, _, v_x, v_y = model.chain.tip(y[:n], y[n:2 * n])
    if abs(rate0) <= 1e-12 * (abs(v_x) + abs(v_y)):  # a tangential start, up to rounding
        rate0 = 0.0
    tip = model.tip
    tip.phase = "elastic" if touching and rate0 > 0 else "free"
    for joint in model.joints:  # the same start for every joint
        delta_k, rate_k = model.delta_and_rate(y, joint)
        _, _, vx_k, vy_k = model.kinematics(y, joint)
        approaching = rate_k > 1e-12 * (abs(vx_k) + abs(vy_k))
        joint.phase = "elastic" if delta_k >= -touch and approaching else "free"
    t_final = scene.solver.t_end if scene.solver.t_end is not None else scene.solver.t_max
    if touching and rate0 <= 0 and scene.solver.t_end is None and not model.joints_in_contact():
        rec = _Recorder()  # the tip touches, not approaching
        rec.add(model, np.array([0.0]), y[None, :], "free")
        trajectory = Trajectory(rec.t[0], rec.y[0], rec.phase[0], rec.outputs[0], state_names)
        return ReferenceResult(scene, engine, "no-impact", "the tip touches the surface but does not "
                               f"approach it (d(delta)/dt = {rate0:.3g} m/s): no impact", Ready(trajectory),
                               Ready([]), [], Ready({"nsteps": 0, "nfev": 0, "njev": 0, "segments": 0,
                                                     "samples": 1}), several_points=bool(model.joints))

    rec = _Recorder()
    integrals = _PointIntegrals(model)
    impacts: list[PointImpact] = []
    for point in model.points:
        if point.phase != "free":
            _begin_slip(model, y, point)
    for point in model.points:
        if point.phase != "free":
            point.impact = PointImpact(t_start=0.0, i_start=0, point=point.name)
            point.impact.own.update(begin=[0.0] * integrals.width, v_n0=-model.delta_and_rate(y, point)[1])
            impacts.append(point.impact)
    impacts.sort(key=lambda i: point_number(i.point, n))
    _release_overloaded(model, y, t)
    rec.add(model, np.array([t]), y[None, :], tip.phase, _segment_label(model)[0])
    spans: list[PhaseSpan] = []
    stats = {"nsteps": 0, "nfev": 0, "njev": 0}
    status, message = "ok", ""
    breaks, pieces = [t], []
    sampler = TimeSampler(t_eval) if t_eval is not None else None
    try:
        while True:
            if len(spans) >= MAX_SEGMENTS:
                raise SolverError(f"more than {MAX_SEGMENTS} phase switches; shorten solver.t_end", tip.phase, t)
            in_contact = [p for p in model.points if p.phase != "free"]
            more = integrals.extra_states(in_contact)
            y_begin = y
            label, friction = _segment_label(model)
            y0 = np.concatenate([y, np.zeros(more)]) if more else y
            atol_seg = np.concatenate([atol_vec, np.full(more, atol_integrals)]) if more else atol_vec
            try:
                seg = integrate(model, tip.phase, t, y0, t_final, _phase_events(model, tip.phase, y), method, rtol,
                                atol_seg, **extra)
            except SolverError as error:
                partial = getattr(error, "partial", None)
                if partial is not None and len(partial[0]):
                    rec.add(model, partial[0], partial[1][:, :nstate], tip.phase, label)
                raise
            stats["nsteps"] += seg.nsteps
            stats["nfev"] += seg.nfev
            stats["njev"] += seg.njev
            fired, seg_t, seg_rows = seg.fired, seg.t, seg.y
            seg_y = seg_rows[:, :nstate]
            below = _under_floor(model, seg_t, seg_y)
            if below is not None:  # kept up to the sample found under the floor
                rec.add(model, seg_t[:below[0] + 1], seg_y[:below[0] + 1], tip.phase, label)
                integrals.sums = integrals.at(in_contact, y_begin, seg_rows[below[0]])
                raise SolverError(below[1], tip.phase, float(seg_t[below[0]]))
            rec.add(model, seg_t, seg_y, tip.phase, label)
            if len(seg_t):
                integrals.sums = integrals.at(in_contact, y_begin, seg_rows[-1])
            if seg.nsteps > scene.solver.max_steps:
                raise SolverError(f"{seg.nsteps} steps in one phase, more than solver.max_steps = "
                                  f"{scene.solver.max_steps}", tip.phase, float(seg_t[-1]))
            if dense and seg.sol is not None and len(seg_t):
                piece = seg.sol if not more else (lambda tt, sol=seg.sol: sol(tt)[:nstate])
                breaks.append(float(seg_t[-1]))
                pieces.append(piece)
                if sampler is not None:
                    sampler.segment(float(seg_t[-1]), piece,
                                    lambda tt, yy, ph=tip.phase: model.outputs(tt, yy, ph), label)
            t, y = float(seg_t[-1]), seg_y[-1].copy()
            spans.append(PhaseSpan(label, spans[-1].t1 if spans else 0.0, t, fired[0] if fired else "t_end",
                                   friction))
            if not fired:
                if not impacts and scene.solver.t_end is None:
                    status, message = "no-impact", f"no contact within solver.t_max = {scene.solver.t_max:g} s"
                elif scene.solver.t_end is None:
                    message = f"no separation within solver.t_max = {scene.solver.t_max:g} s"
                break
            by_point: dict[int, list[str]] = {}
            for name in fired:
                point, event = _split_event(model, name)
                by_point.setdefault(id(point), []).append(event)
            separated = False
            for point in model.points:
                if id(point) in by_point:
                    separated |= _switch(model, point, by_point[id(point)], t, y, rec.count - 1, impacts,
                                         integrals.sums)
            _release_overloaded(model, y, t)
            if separated and scene.solver.t_end is None and not any(p.phase != "free" for p in model.points):
                break
    except SolverError as error:
        status, message = "failed", str(error)

    for point in model.points:  # an impact the run ends in: its point's integrals at the last sample
        if point.impact is not None:
            _mark(point.impact, "end", integrals.sums, point)
            point.impact.own["v_n1"] = -model.delta_and_rate(rec.y[-1][-1], point)[1]
    outputs = {k: np.concatenate([o[k] for o in rec.outputs]) for k in rec.outputs[0]}
    trajectory = Trajectory(np.concatenate(rec.t), np.concatenate(rec.y), np.concatenate(rec.phase), outputs,
                            state_names)
    stats.update(segments=len(spans), samples=rec.count, wall_s=time.perf_counter() - started,
                 method=method)
    sampled = Trajectory(*sampler.gathered(nstate, list(outputs)), state_names) if sampler else None
    sol = DenseSolution(breaks, pieces, nstate) if dense_output else None
    return ReferenceResult(scene, engine, status, message, Ready(trajectory), Ready(spans), impacts, Ready(stats),
                           sampled, sol, several_points=bool(model.joints))


def _switch(model: ReferenceModel, point: ContactPoint, events: list[str], t: float, y: np.ndarray,
            sample: int, impacts: list[PointImpact], sums: dict[int, np.ndarray]) -> bool:
    """Apply the events of one point at time t (state y, sample index `sample`): its stick-slip
    switch, then its phase switch; a new impact at contact. True if it separated."""
    c, phase = point.contact, point.phase
    impact = point.impact
    slipping = [e for e in events if e in FRICTION_EVENTS]
    if slipping:  # possibly at the same instant as a contact event (a single bar: u = 0)
        old = c.slip
        if old == 0:
            c.slip = -1.0 if slipping[0] == "slip_backward" else 1.0
        else:
            c.slip = _slip_at_stop(model, y, phase, point)
            c.slip = 0.0 if c.slip == old else c.slip  # pushed on only by rounding: stuck
        impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))
    events = [e for e in events if e not in FRICTION_EVENTS]
    if not events:
        return False
    new = _after(phase, events[0], c)
    if new != "free" and phase != "free" and not slipping:
        _slip_direction_check(model, y, new, t, impact, point)
    if phase == "free":
        point.impact = PointImpact(t_start=t, i_start=sample, point=point.name)
        if new == "reloading":  # back into its own dent before leaving it: reloads along its restitution curve
            impact = point.impact
            impact.delta_max, impact.P_max = c.delta_m, c.normal_force("reloading", c.delta_m)
            impact.delta_r, impact.R_res = c.delta_r, c.R_res
        else:
            c.reset()
        _mark(point.impact, "begin", sums, point)
        point.impact.own["v_n0"] = -model.delta_and_rate(y, point)[1]
        impacts.append(point.impact)
        point.phase = new
        _begin_slip(model, y, point)
        return False
    if new == "restitution" and phase in ("elastic", "elastoplastic"):
        delta_m = model.delta_and_rate(y, point)[0]
        c.at_maximum_compression(delta_m, c.normal_force(phase, delta_m))
        impact.delta_max = delta_m
        impact.P_max = c.normal_force(phase, delta_m)
        impact.delta_r, impact.R_res = c.delta_r, c.R_res
        impact.i_max = sample
        _mark(impact, "at_max", sums, point)
    impact.switches.append((t, phase, new))
    point.phase = new
    if new == "free":
        impact.t_end, impact.i_end = t, sample
        _mark(impact, "end", sums, point)
        impact.own["v_n1"] = -model.delta_and_rate(y, point)[1]
        point.impact = None
        return True
    return False
