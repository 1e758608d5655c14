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

The contact laws are written again from the model documentation (docs/model.md). The phases
are integrated with scipy.integrate.solve_ivp and its terminal, direction-filtered events.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from .dense import DenseSolution, TimeSampler
from .errors import SceneError, SolverError
from .results import Impact, PhaseSpan, Ready, SimulationResult, Trajectory
from .scene import Scene

METHODS = ("Radau", "BDF", "LSODA", "DOP853", "RK45")
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

    def accelerations(self, q: np.ndarray, u: np.ndarray, F: float, F_f: float) -> np.ndarray:
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
    def from_scene(cls, scene: Scene, y_s: float) -> "Contact":
        Er, Es = scene.rod.E, scene.surface.E
        E_star = 1.0 / ((1 - scene.rod.nu ** 2) / Er + (1 - scene.surface.nu ** 2) / Es)
        weak = min((scene.rod, scene.surface), key=lambda mat: mat.yield_strength)
        C_j = 1.295 * math.exp(0.736 * weak.nu)
        R = scene.tip_radius
        p0 = math.pi * C_j * weak.yield_strength / 2  # the pressure scale pi C_j S_y / 2
        return cls(E_star=E_star, R=R, delta_c=R * (p0 / E_star) ** 2,
                   P_c=4.0 / 3.0 * (R / E_star) ** 2 * p0 ** 3, C_j=C_j,
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


# ----------------------------------------------------------------------------- right-hand side

@dataclass
class ReferenceModel:
    chain: ChainModel
    contact: Contact
    n: int
    friction_state: bool  # the state carries W_friction

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
        return cls(ChainModel.from_scene(scene), Contact.from_scene(scene, y_s), scene.n,
                   scene.contact.friction > 0)

    def rhs(self, t: float, y: np.ndarray, phase: str) -> np.ndarray:
        n = self.n
        _, y_B, v_Bx, v_By = self.chain.tip(y[:n], y[n:2 * n])
        F = self.contact.normal_force(phase, self.contact.y_s - y_B)
        F_f = self.tangential_force(y, phase, F, v_Bx)
        works = [F * v_By] + ([F_f * v_Bx] if self.friction_state else [])
        impulses = [F] + ([F_f] if self.friction_state else [])  # P_normal[, P_friction]
        return np.concatenate([self.chain_rates(t, y, F, F_f), works, impulses])

    def stuck(self, phase: str) -> bool:
        return self.contact.exact_coulomb and self.contact.slip == 0 and phase != "free"

    def tangential_force(self, y: np.ndarray, phase: str, F: float, v_Bx: float) -> float:
        if self.stuck(phase):
            return self.chain.holding_force(y[:self.n], y[self.n:2 * self.n], F)
        return self.contact.friction(F, v_Bx)

    def chain_rates(self, t: float, y: np.ndarray, F: float, F_f: float) -> np.ndarray:
        """dq/dt and du/dt of the chain under the tip forces F (normal) and F_f (friction)."""
        n = self.n
        q, u = y[:n], y[n:2 * n]
        return np.concatenate([u, self.chain.accelerations(q, u, F, F_f)])

    def delta_and_rate(self, y: np.ndarray) -> tuple[float, float]:
        n = self.n
        _, y_B, _, v_By = self.chain.tip(y[:n], y[n:2 * n])
        return self.contact.y_s - y_B, -v_By

    def outputs(self, t: np.ndarray, y: np.ndarray, phase: str) -> dict[str, np.ndarray]:
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


def _friction_events(model: ReferenceModel, phase: str) -> dict[str, object]:
    """Exact Coulomb: a slip ends when v_Bx returns to 0, a stick when the holding force
    leaves the cone |F_f| <= mu F."""
    c, n = model.contact, model.n
    if not c.exact_coulomb or phase == "free":
        return {}
    if c.slip != 0:
        return {"slip_stops": _event(lambda t, y: model.chain.tip(y[:n], y[n:2 * n])[2], -int(c.slip))}

    def cone(side: float):
        def gap(t: float, y: np.ndarray) -> float:
            F = c.normal_force(phase, model.delta_and_rate(y)[0])
            return c.mu * F - side * model.chain.holding_force(y[:n], y[n:2 * n], F)
        return gap
    return {"slip_backward": _event(cone(+1.0), -1), "slip_forward": _event(cone(-1.0), -1)}


def _slip_at_stop(model: ReferenceModel, y: np.ndarray, phase: str) -> float:
    """Stick if the force holding the tip still lies strictly inside the cone, else slip
    against it."""
    n, c = model.n, model.contact
    F = c.normal_force(phase, model.delta_and_rate(y)[0])
    hold = model.chain.holding_force(y[:n], y[n:2 * n], F)
    return 0.0 if abs(hold) < c.mu * F or hold == 0 else -math.copysign(1.0, hold)


def _phase_events(model: ReferenceModel, phase: str) -> dict[str, object]:
    return {**_contact_events(model, phase), **_friction_events(model, phase)}


def _contact_events(model: ReferenceModel, phase: str) -> dict[str, object]:
    c = model.contact
    delta = lambda t, y: model.delta_and_rate(y)[0]  # noqa: E731
    rate = lambda t, y: model.delta_and_rate(y)[1]  # noqa: E731
    if phase == "free":
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

    def add(self, model: ReferenceModel, t: np.ndarray, y: np.ndarray, phase: str) -> None:
        self.t.append(t)
        self.y.append(y)
        self.phase.append(np.full(len(t), phase))
        self.outputs.append(model.outputs(t, y, phase))
        self.count += len(t)


def _slip_direction_check(model: ReferenceModel, y: np.ndarray, phase: str, t: float, impact: Impact) -> None:
    """After a contact event with no stick-slip event: a slip whose tip has stopped, or moves
    the other way, is decided as at a stop (its event can coincide with the contact event:
    a single bar stops sliding exactly when it stops penetrating)."""
    c, n = model.contact, model.n
    if not c.exact_coulomb or c.slip == 0:
        return
    _, _, v_x, v_y = model.chain.tip(y[:n], y[n:2 * n])
    if v_x * c.slip > 1e-9 * math.hypot(v_x, v_y):
        return
    old, c.slip = c.slip, _slip_at_stop(model, y, phase)
    if c.slip != old:
        impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))


def _begin_slip(model: ReferenceModel, y: np.ndarray) -> None:
    """A contact begins slipping the way the tip moves (as at a stop if it does not); frozen
    friction keeps that direction to separation."""
    n = model.n
    _, _, v_x, v_y = model.chain.tip(y[:n], y[n:2 * n])
    model.contact.frozen_sign = float(np.sign(v_x))
    if not model.contact.exact_coulomb:
        return
    moving = abs(v_x) > 1e-12 * math.hypot(v_x, v_y)
    model.contact.slip = math.copysign(1.0, v_x) if moving else _slip_at_stop(model, y, "elastic")


def simulate(scene: Scene, method: str = "Radau", rtol: float | None = None,
             atol: float | None = None, model: ReferenceModel | None = None,
             integrate=solve_ivp_segment, engine: str = "reference", t_eval: np.ndarray | None = None,
             dense_output: bool = False) -> SimulationResult:
    """Run `scene` through the phases with solve_ivp; the result has the C engine's shape.
    `model` and `integrate` let a benchmark put another right-hand side or integrator
    under the same phase loop. solver.max_steps is checked after each phase segment (solve_ivp
    has no step limit of its own). A failure ends the run with status "failed"."""
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
    atol_vec = np.full(nstate, atol_q)
    atol_vec[2 * n:] = atol_q * energy_scale
    dense = dense_output or t_eval is not None
    extra = {"dense": True} if dense else {}

    y = np.concatenate([scene.q0, scene.u0, np.zeros(nstate - 2 * n)])
    t = 0.0
    delta0, rate0 = model.delta_and_rate(y)
    touching = delta0 >= -1e-12 * max(1.0, sum(scene.chain.length))
    _, _, v_x, v_y = model.chain.tip(y[:n], y[n:2 * n])
    if abs(rate0) <= 1e-12 * (abs(v_x) + abs(v_y)):  # a tangential start, up to rounding
        rate0 = 0.0
    phase = "elastic" if touching and rate0 > 0 else "free"
    t_final = scene.solver.t_end if scene.solver.t_end is not None else scene.solver.t_max
    if touching and rate0 <= 0 and scene.solver.t_end is None:  # touching, not approaching
        rec = _Recorder()
        rec.add(model, np.array([0.0]), y[None, :], "free")
        trajectory = Trajectory(rec.t[0], rec.y[0], rec.phase[0], rec.outputs[0], state_names)
        return SimulationResult(scene, engine, "no-impact", "the tip touches the surface but does not "
                                f"approach it (d(delta)/dt = {rate0:.3g} m/s): no impact", Ready(trajectory),
                                Ready([]), [], Ready({"nsteps": 0, "nfev": 0, "njev": 0, "segments": 0, "samples": 1}))

    rec = _Recorder()
    if phase == "elastic":
        _begin_slip(model, y)
    rec.add(model, np.array([t]), y[None, :], phase)
    spans: list[PhaseSpan] = []
    impacts: list[Impact] = [Impact(t_start=0.0, i_start=0)] if phase == "elastic" else []
    stats = {"nsteps": 0, "nfev": 0, "njev": 0}
    status, message = "ok", ""
    breaks, pieces = [t], []
    sampler = TimeSampler(t_eval) if t_eval is not None else None
    try:
        while True:
            if len(spans) >= MAX_SEGMENTS:
                raise SolverError(f"more than {MAX_SEGMENTS} phase switches; shorten solver.t_end", phase, t)
            try:
                seg = integrate(model, phase, t, y, t_final, _phase_events(model, phase), method, rtol,
                                atol_vec, **extra)
            except SolverError as error:
                partial = getattr(error, "partial", None)
                if partial is not None and len(partial[0]):
                    rec.add(model, partial[0], partial[1], phase)
                raise
            stats["nsteps"] += seg.nsteps
            stats["nfev"] += seg.nfev
            stats["njev"] += seg.njev
            fired, seg_t, seg_y = seg.fired, seg.t, seg.y
            below = _under_floor(model, seg_t, seg_y)
            if below is not None:  # kept up to the sample found under the floor
                rec.add(model, seg_t[:below[0] + 1], seg_y[:below[0] + 1], phase)
                raise SolverError(below[1], phase, float(seg_t[below[0]]))
            rec.add(model, seg_t, seg_y, phase)
            if seg.nsteps > scene.solver.max_steps:
                raise SolverError(f"{seg.nsteps} steps in one phase, more than solver.max_steps = "
                                  f"{scene.solver.max_steps}", phase, float(seg_t[-1]))
            if dense and seg.sol is not None and len(seg_t):
                breaks.append(float(seg_t[-1]))
                pieces.append(seg.sol)
                if sampler is not None:
                    sampler.segment(float(seg_t[-1]), seg.sol,
                                    lambda tt, yy, ph=phase: model.outputs(tt, yy, ph), phase)
            t, y = float(seg_t[-1]), seg_y[-1].copy()
            c = model.contact
            friction = SLIP_NAMES[c.slip] if c.exact_coulomb and phase != "free" else ""
            spans.append(PhaseSpan(phase, spans[-1].t1 if spans else 0.0, t, fired[0] if fired else "t_end",
                                   friction))
            if not fired:
                if not impacts and scene.solver.t_end is None:
                    status, message = "no-impact", f"no contact within solver.t_max = {scene.solver.t_max:g} s"
                elif scene.solver.t_end is None:
                    message = f"no separation within solver.t_max = {scene.solver.t_max:g} s"
                break
            impact = impacts[-1] if impacts else None
            slipping = [e for e in fired if e in FRICTION_EVENTS]
            if slipping:  # possibly at the same instant as a contact event (a single bar: u = 0)
                old = c.slip
                if old == 0:
                    c.slip = -1.0 if slipping[0] == "slip_backward" else 1.0
                else:
                    c.slip = _slip_at_stop(model, y, phase)
                    c.slip = 0.0 if c.slip == old else c.slip  # pushed on only by rounding: stuck
                impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))
            fired = [e for e in fired if e not in FRICTION_EVENTS]
            if not fired:
                continue
            new = _after(phase, fired[0], model.contact)
            if new != "free" and phase != "free" and not slipping:
                _slip_direction_check(model, y, new, t, impact)
            if phase == "free":
                model.contact.reset()
                impacts.append(Impact(t_start=t, i_start=rec.count - 1))
                _begin_slip(model, y)
            else:
                if new == "restitution" and phase in ("elastic", "elastoplastic"):
                    delta_m = model.delta_and_rate(y)[0]
                    model.contact.at_maximum_compression(delta_m, model.contact.normal_force(phase, delta_m))
                    impact.delta_max = delta_m
                    impact.P_max = model.contact.normal_force(phase, delta_m)
                    impact.delta_r, impact.R_res = model.contact.delta_r, model.contact.R_res
                    impact.i_max = rec.count - 1
                impact.switches.append((t, phase, new))
                if new == "free":
                    impact.t_end, impact.i_end = t, rec.count - 1
                    if scene.solver.t_end is None:
                        break
            phase = new
    except SolverError as error:
        status, message = "failed", str(error)

    outputs = {k: np.concatenate([o[k] for o in rec.outputs]) for k in rec.outputs[0]}
    trajectory = Trajectory(np.concatenate(rec.t), np.concatenate(rec.y), np.concatenate(rec.phase), outputs,
                            state_names)
    stats.update(segments=len(spans), samples=rec.count, wall_s=time.perf_counter() - started,
                 method=method)
    sampled = Trajectory(*sampler.gathered(nstate, list(outputs)), state_names) if sampler else None
    sol = DenseSolution(breaks, pieces, nstate) if dense_output else None
    return SimulationResult(scene, engine, status, message, Ready(trajectory), Ready(spans), impacts, Ready(stats),
                            sampled, sol)
