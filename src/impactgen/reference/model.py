"""The reference model: the chain and its contact points, the forces at the points in contact,
the right-hand side and the outputs."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Mapping

import numpy as np

from ..results import point_name
from ..scene import TOUCH_TOLERANCE, Scene
from .body import Body
from .chain import ChainModel
from .contact import Contact

if TYPE_CHECKING:
    from .result import PointImpact


@dataclass
class ContactPoint:
    """A point of the chain that can touch the surface, with its own laws and state."""

    index: int  # k = 1..n: the end of link k (joint k; n: the chain's end, the scene's tip); 0: a free base
    name: str  # "joint k" or "tip" (results.point_name), or "base"
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
    resting: bool = False  # its F is the force that holds it on the surface (sustained contact)


def surface_height(scene: Scene, body: Body | None = None) -> float:
    """y_s: the scene's surface.height, or (surface.height = "initial") the height of the
    lowest contact point at the start: the chain's end for a pinned chain (its lowest point,
    as the scene's checks make it), the lowest of the base, the joints and the tip for a free
    chain. Read from `body`, which a test may start elsewhere than the scene says."""
    if scene.surface_height is not None:
        return scene.surface_height
    body = body or Body()
    y = body.base_position[1] if body.free else 0.0
    heights = [y]
    for L, q in zip(scene.chain.length, scene.q0):
        y += L * math.sin(q)
        heights.append(y)
    return min(heights) if body.free else heights[-1]


def reachable_joints(scene: Scene, y_s: float, free: bool = False) -> list[int]:
    """The joints (k = 1..n-1) that can reach the surface: the chain up to joint k is at least
    as long as the pivot is high above the surface (with the start's rounding); every joint
    of a free chain. The chain's end is always carried: the scene's surface is placed for it."""
    if free:
        return list(range(1, scene.n))
    slack = TOUCH_TOLERANCE * max(1.0, sum(scene.chain.length))
    reach = np.cumsum(scene.chain.length)
    return [k for k in range(1, scene.n) if reach[k - 1] >= -y_s - slack]


@dataclass
class ReferenceModel:
    """The chain and its contact points: a free chain's base (`base`, point 0), the joints
    that can reach the surface (`joints`) and point n, the chain's end (the scene's tip),
    whose laws are `contact`. Every point has its own laws, phase (`ContactPoint.phase`) and
    state, and acts through its own Jacobian."""

    chain: ChainModel
    contact: Contact  # the laws of point n
    n: int
    friction_state: bool  # the state carries W_friction
    joints: list[ContactPoint] = field(default_factory=list)
    base: ContactPoint | None = None  # a free chain's point 0
    body: Body = field(default_factory=Body)
    sustained: bool = False  # a run to a time that holds resting points (solver.sustained_contact)

    def __post_init__(self) -> None:
        tip = ContactPoint(self.n, point_name(self.n, self.n), self.contact)
        self.points = [*([self.base] if self.base else []), *self.joints, tip]  # by index
        self.dof = self.chain.dof  # the positions: the angles, then a free chain's base coordinates
        self.nstate = 2 * self.dof + (4 if self.friction_state else 2)  # positions, speeds, works, impulses

    @property
    def tip(self) -> ContactPoint:
        """Point n, the chain's end: the point the scene's tip names (its outputs x_B, ..., F)."""
        return self.points[-1]

    @property
    def state_names(self) -> tuple[str, ...]:
        """The columns of the state as `rhs` lays them out (the C model's, build.CompiledModel's)."""
        n = self.n
        integrated = (("W_normal", "W_friction", "P_normal", "P_friction") if self.friction_state
                      else ("W_normal", "P_normal"))  # the works, then the impulses
        base = (("x_0", "y_0"), ("u_x0", "u_y0")) if self.chain.free else ((), ())
        return (*(f"q{i + 1}" for i in range(n)), *base[0], *(f"u{i + 1}" for i in range(n)), *base[1],
                *integrated)

    @classmethod
    def from_scene(cls, scene: Scene, body: Body | None = None) -> "ReferenceModel":
        """The model of `scene`; `body` (the base and the surface's angle) as the scene's keys
        give it when None."""
        body = body or Body.from_scene(scene)
        y_s = surface_height(scene, body)
        joints = [ContactPoint(k, point_name(k, scene.n), Contact.from_scene(scene, y_s, scene.joint_radii[k - 1]))
                  for k in reachable_joints(scene, y_s, body.free)]
        base = (ContactPoint(0, point_name(0, scene.n), Contact.from_scene(scene, y_s, body.base_radius))
                if body.free else None)
        return cls(ChainModel.from_scene(scene, body.free, body.slope), Contact.from_scene(scene, y_s), scene.n,
                   scene.contact.friction > 0, joints, base, body,
                   scene.solver.t_end is not None and scene.solver.sustained_contact)

    def initial_state(self, scene: Scene) -> np.ndarray:
        """The state at t = 0: the positions and speeds (the base's after the angles for a free chain),
        the works and impulses at zero."""
        positions, speeds = self.body.start(scene)
        return np.concatenate([positions, speeds, np.zeros(self.nstate - 2 * self.dof)])

    def touching(self) -> list[ContactPoint]:
        """The points in contact (in a phase other than free), by index."""
        return [p for p in self.points if p.phase != "free"]

    def kinematics(self, y: np.ndarray, point: ContactPoint) -> tuple[float, float, float, float]:
        """x, y, v_x, v_y of a contact point."""
        return self.chain.point(y[:self.dof], y[self.dof:2 * self.dof], point.index)

    def delta_and_rate(self, y: np.ndarray, point: ContactPoint) -> tuple[float, float]:
        """The penetration of a point and its rate."""
        y_k, v_y = self.chain.height_and_rate(y[:self.dof], y[self.dof:2 * self.dof], point.index)
        return point.contact.y_s - y_k, -v_y

    def rhs(self, t: float, y: np.ndarray, phase: str | None = None) -> np.ndarray:
        """dy/dt, each point's forces acting through its own Jacobian (`ChainModel.loads`), every
        point in its own phase, or point n in `phase` when given (the callers that drive point n
        alone: crosscheck.rhs_pair, the benchmarks' integrators). A state longer than `nstate`
        carries, after it, the works and impulses of each point in contact on its own (when
        several are)."""
        active = self.contact_forces(y, {} if phase is None else {self.n: phase})
        indices = [a.point.index for a in active]
        F = self.chain.loads(indices, [a.F for a in active])
        F_f = self.chain.loads(indices, [a.F_f for a in active])
        own = [self.integrands(a) for a in active]
        total = [sum(rates) for rates in zip(*own)] if own else [0.0] * (self.nstate - 2 * self.dof)
        parts = [self.chain_rates(t, y, F, F_f), total]
        if len(y) > self.nstate:  # each point's own, in the order of `points`
            parts += own
        return np.concatenate(parts)

    def chain_rates(self, t: float, y: np.ndarray, F: np.ndarray, F_f: np.ndarray) -> np.ndarray:
        """dq/dt and du/dt of the chain under the normal and friction loads each link carries
        (`ChainModel.loads`)."""
        n = self.dof
        q, u = y[:n], y[n:2 * n]
        return np.concatenate([u, self.chain.accelerations(q, u, F, F_f)])

    def integrands(self, a: PointForce) -> list[float]:
        """The rates of W_normal[, W_friction], P_normal[, P_friction] of one point's forces."""
        if self.friction_state:
            return [a.F * a.v_y, a.F_f * a.v_x, a.F, a.F_f]
        return [a.F * a.v_y, a.F]

    def contact_forces(self, y: np.ndarray, phases: Mapping[int, str] | None = None,
                       still: ContactPoint | None = None) -> list[PointForce]:
        """The forces at every point in contact. `phases`: phases by point index that replace
        the points' own. `still`: a point held still as if stuck, to see whether it sticks at a
        stop. Stuck points (exact Coulomb) and resting ones (sustained contact: its v_y held,
        F the force that holds it, friction -mu F s with it when it slips) are held together:
        their forces depend on each other."""
        phases = phases or {}
        active = []
        for p in self.points:
            phase = phases.get(p.index, p.phase)
            if phase == "free":
                continue
            _, y_k, v_x, v_y = self.kinematics(y, p)
            resting = phase == "sustained" and self.sustained  # (a scene without it has no such phase)
            F = 0.0 if resting else p.contact.normal_force(phase, p.contact.y_s - y_k, -v_y)
            held = p is still or (p.contact.exact_coulomb and p.contact.slip == 0)
            active.append(PointForce(p, F, 0.0 if held else p.contact.friction(F, v_x), v_x, v_y, held, resting))
        if any(a.held or a.resting for a in active):
            self._hold(y, active)
        return active

    def _hold(self, y: np.ndarray, active: list[PointForce]) -> None:
        """Set the forces of the held points in `active` (ChainModel.holding_forces)."""
        n = self.dof
        indices = [a.point.index for a in active]
        stuck = [a for a in active if a.held]
        resting = [a for a in active if a.resting]
        per_newton = [0.0 if a.held else a.point.contact.friction(1.0, a.v_x) for a in resting]
        tangential, normal = self.chain.holding_forces(
            y[:n], y[n:2 * n], self.chain.loads(indices, [a.F for a in active]),
            self.chain.loads(indices, [a.F_f for a in active]), [a.point.index for a in stuck],
            [(a.point.index, f) for a, f in zip(resting, per_newton)])
        for a, h in zip(stuck, tangential):
            a.F_f = float(h)
        for a, h, f in zip(resting, normal, per_newton):
            a.F = float(h)
            if not a.held:
                a.F_f = f * a.F

    def friction_force(self, y: np.ndarray, point: ContactPoint) -> float:
        """The friction force at a point: 0 when it is free."""
        return next((a.F_f for a in self.contact_forces(y) if a.point is point), 0.0)

    def outputs(self, t: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
        """The outputs at samples y (N, nstate), as the C engine names them: point n's position,
        speed, penetration and forces (x_B, ..., F, F_f: the tip's), the energies, and each
        joint's penetration and normal force (delta_Jk, F_Jk), a free chain's base point's as
        point 0 (delta_J0, F_J0: its position and speed are the states x_0, ..., u_y0)."""
        n, tip, dof = self.n, self.tip, self.dof
        q, u = y[:, :dof].T, y[:, dof:2 * dof].T
        x_B, y_B, v_Bx, v_By = self.chain.point(q, u, n)
        delta = tip.contact.y_s - y_B
        F = self._normal_forces(y, tip, delta, v_By)
        out = {"x_B": x_B, "y_B": y_B, "v_Bx": v_Bx, "v_By": v_By, "delta": delta, "delta_rate": -v_By, "F": F}
        if self.friction_state:
            out["F_f"] = np.array([self.friction_force(row, tip) for row in y])
        T, V = self.chain.energies(q, u)
        out.update({f"T{i + 1}": T[i] for i in range(n)})
        out["T"], out["V"] = T.sum(0), V
        for p in self.points[:-1]:  # the base and the joints
            _, y_k, _, v_k = self.chain.point(q, u, p.index)
            delta_k = p.contact.y_s - y_k
            out[f"delta_J{p.index}"] = delta_k
            out[f"F_J{p.index}"] = self._normal_forces(y, p, delta_k, v_k)
        return out

    def _normal_forces(self, y: np.ndarray, point: ContactPoint, delta: np.ndarray, v_y: np.ndarray) -> np.ndarray:
        """A point's normal force at samples y: its law's, or (resting) the force that holds it."""
        if point.phase == "sustained":
            return np.array([next(a.F for a in self.contact_forces(row) if a.point is point) for row in y])
        return np.array([point.contact.normal_force(point.phase, d, -v) for d, v in zip(delta, v_y)])
