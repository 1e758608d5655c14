"""The rigid-body impact laws of the n-link chain: Newton's, Poisson's and Stronge's.

An impact of rigid bodies is instantaneous: the positions do not change, and the speeds jump
by the impulse of the contact force alone (gravity's impulse over a zero time is zero). For
the chain of MODEL.md section 1 with generalized speeds u, the tip's velocity is
v = (v_t, v_n) = J(q) u and the impulse P = (P_t, P_n) at the tip gives

    M(q) (u+ - u-) = J^T P,    so    v+ - v- = W P,    W = J M^-1 J^T   (2 x 2)

with Coulomb's friction |dP_t| <= mu dP_n. The three laws differ in how P_n ends:

- Newton (kinematic): v_n+ = -e v_n-, with the friction impulse -mu P_n s against the
  initial slip s = sign(v_t-) for the whole impact (algebraic; it can gain energy when the
  slip stops or reverses during the impact: Kane and Levinson's double pendulum);
- Poisson (kinetic): P_n = (1 + e) P_c, P_c the normal impulse at the end of compression
  (v_n = 0);
- Stronge (energetic): the normal force's work in restitution is -e^2 times its work in
  compression, W_r = -e^2 W_c.

The last two integrate the impact in the normal impulse p as Stronge's "Impact Mechanics"
(chapter 5) does: while the tip slips, dv/dp = W (-mu s, 1); when v_t reaches 0 the tip
sticks if the tangential impulse rate that holds it, -W_tn / W_tt, is within mu, and
otherwise slips on, in the direction W_tn pushes it (slip reversal). W is constant during
the impact, so v is piecewise linear in p and every step is solved exactly.

This module is a derivation of its own (the mass matrix from the mass centres' velocity
Jacobians, numerically): it shares no code with codegen/, the generated C or the reference
engine, so that the comparison of `impactgen compare` is between independent statements.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ImpactgenError, excerpt

LAWS = ("newton", "poisson", "energetic")
SLIP_TOLERANCE = 1e-12  # |v_t| below this fraction of the tip speed counts as no slip
MAX_SWITCHES = 16  # slip-stick-reversal changes in one impact: W is constant, so at most a few


@dataclass(frozen=True)
class RigidChain:
    """The chain's masses and lengths: what its mass matrix and tip Jacobian need. A free
    chain (`free`) has its base point's velocity (u_x0, u_y0) after the angular speeds in u."""

    length: tuple[float, ...]
    mass: tuple[float, ...]
    free: bool = False

    @classmethod
    def from_scene(cls, scene) -> "RigidChain":
        return cls(tuple(scene.chain.length), tuple(scene.chain.mass), scene.free)

    @property
    def n(self) -> int:
        return len(self.length)

    @property
    def dof(self) -> int:
        """The generalized speeds: the links', and a free chain's base point's two."""
        return self.n + (2 if self.free else 0)

    def _base_columns(self) -> np.ndarray:
        """The velocity Jacobian's columns of the base point's speeds: (2, 2) unit for a free
        chain, none (2, 0) for a pinned one."""
        return np.eye(2) if self.free else np.zeros((2, 0))

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M = sum_j m_j Jc_j^T Jc_j + diag(m_j L_j^2 / 12), Jc_j the velocity Jacobian of
        link j's mass centre: column i < j is L_i (-sin q_i, cos q_i), column j half of it
        (and a free chain's base point's columns the unit vectors)."""
        L, m = np.asarray(self.length), np.asarray(self.mass)
        n = self.n
        M = np.zeros((self.dof, self.dof))
        M[:n, :n] = np.diag(m * L ** 2 / 12.0)
        e = np.vstack([-np.sin(q), np.cos(q)]) * L  # (2, n): column i is L_i e_i'
        for j in range(n):
            Jc = np.zeros((2, n))
            Jc[:, :j] = e[:, :j]
            Jc[:, j] = e[:, j] / 2.0
            Jc = np.hstack([Jc, self._base_columns()])
            M += m[j] * Jc.T @ Jc
        return M

    def tip_jacobian(self, q: np.ndarray) -> np.ndarray:
        """(2, dof): rows d v_t / du and d v_n / du of the tip (t along +x, n along +y)."""
        return self.point_jacobian(q, self.n)

    def point_jacobian(self, q: np.ndarray, point: int) -> np.ndarray:
        """(2, dof): the same rows for contact point `point` (its number: 0 a free chain's base,
        k the end of link k, n the tip): the links before it move it."""
        L = np.where(np.arange(self.n) < point, np.asarray(self.length), 0.0)
        return np.hstack([np.vstack([-L * np.sin(q), L * np.cos(q)]), self._base_columns()])

    def kinetic_energy(self, q: np.ndarray, u: np.ndarray) -> float:
        return 0.5 * float(u @ self.mass_matrix(q) @ u)


@dataclass(frozen=True)
class LawOutcome:
    """What one law gives for one impact: the speeds after, the impulses, the tip's
    velocity before and after, and the kinetic energy before and after."""

    law: str
    coefficient: float
    u_after: np.ndarray
    P_n: float  # N s, normal impulse
    P_t: float  # N s, tangential impulse
    P_c: float  # N s, normal impulse at the end of compression (NaN for Newton's law)
    v_before: tuple[float, float]  # (v_t, v_n), m/s
    v_after: tuple[float, float]
    T_before: float
    T_after: float
    path: tuple[tuple[float, float, float], ...] = ()  # (p, v_t, v_n) at each regime change, the ends included

    @property
    def energy_change(self) -> float:
        """T_after - T_before, J: positive means the law made energy."""
        return self.T_after - self.T_before


def solve_impact(chain: RigidChain, q, u, law: str, e: float, mu: float, point: int | None = None) -> LawOutcome:
    """The speeds after a rigid impact of one of the chain's points (the tip unless said) on the
    surface at (q, u).

    Parameters
    ----------
    chain : RigidChain
    q, u : array_like, shape (n,) and (dof,)
        Link angles (rad, from +x) and speeds (rad/s, and a free chain's base point's
        velocity after them, m/s) at the instant of impact.
    law : {"newton", "poisson", "energetic"}
    e : float
        The law's coefficient of restitution, >= 0: at most 1 for a rigid impact, though a
        compliant impact's e_N and e_P can exceed 1 where friction and the chain's motion
        act during the contact (`impactgen compare` passes them on as they are).
    mu : float
        Coulomb's friction coefficient, >= 0.
    point : int, optional
        The contact point that strikes, by its number (0 a free chain's base, k the end of
        link k); the tip (n) if not given.

    Returns
    -------
    LawOutcome

    Raises
    ------
    ImpactgenError
        For an unknown law, a negative coefficient, a point that does not approach the
        surface, or a contact that jams (friction stops the normal motion from ever
        reversing: Painleve's paradox).
    """
    if law not in LAWS:
        raise ImpactgenError(f"unknown impact law {excerpt(law)}: use one of {', '.join(LAWS)}")
    if not (e >= 0.0 and math.isfinite(e)):
        raise ImpactgenError(f"the {law} coefficient of restitution must be a number >= 0, got {excerpt(e)}")
    if mu < 0 or not math.isfinite(mu):
        raise ImpactgenError(f"the friction coefficient must be >= 0, got {excerpt(mu)}")
    q, u = np.asarray(q, dtype=float), np.asarray(u, dtype=float)
    M = chain.mass_matrix(q)
    number = chain.n if point is None else point
    J = chain.point_jacobian(q, number)
    W = J @ np.linalg.solve(M, J.T)
    v0 = J @ u
    if not v0[1] < 0:
        whose = "the tip" if number == chain.n else f"point {number}"
        raise ImpactgenError(f"{whose} does not approach the surface (v_n = {v0[1]:.3g} m/s): no impact")
    path: list[tuple[float, float, float]] = [(0.0, float(v0[0]), float(v0[1]))]
    if law == "newton":
        P, P_c = _newton(W, v0, e, mu), math.nan
    else:
        P, P_c = _integrated(W, v0, e, mu, law, path)
    u_after = u + np.linalg.solve(M, J.T @ P)
    v1 = J @ u_after
    if law == "newton":
        path.append((float(P[1]), float(v1[0]), float(v1[1])))
    return LawOutcome(law, e, u_after, float(P[1]), float(P[0]), P_c, (float(v0[0]), float(v0[1])),
                      (float(v1[0]), float(v1[1])), 0.5 * float(u @ M @ u), 0.5 * float(u_after @ M @ u_after),
                      tuple(path))


def _newton(W: np.ndarray, v0: np.ndarray, e: float, mu: float) -> np.ndarray:
    """v_n+ = -e v_n-, P_t = -mu s P_n with s the initial slip's sign."""
    s = _sign(v0[0], v0)
    rate = W[1, 1] - mu * s * W[1, 0]  # d v_n / d P_n along the friction's direction
    if rate <= 0:
        raise ImpactgenError("the contact jams: friction keeps the tip from leaving the surface "
                             "(Painleve's paradox); Newton's law has no solution here")
    P_n = -(1.0 + e) * v0[1] / rate
    return np.array([-mu * s * P_n, P_n])


def _sign(v_t: float, scale: np.ndarray) -> float:
    """The slip's direction, 0 for a tangential speed within SLIP_TOLERANCE of the speed
    `scale` (a vector: the tip's velocity before the impact)."""
    return 0.0 if abs(v_t) <= SLIP_TOLERANCE * max(float(np.hypot(*scale)), 1e-300) else math.copysign(1.0, v_t)


def _integrated(W: np.ndarray, v0: np.ndarray, e: float, mu: float, law: str,
                path: list[tuple[float, float, float]]) -> tuple[np.ndarray, float]:
    """Stronge's integration in the normal impulse p: slip, stick and slip reversal, to the
    end that the law sets (Poisson's impulse ratio or the energetic ratio of works). The tip
    velocity at each regime change is appended to `path` as (p, v_t, v_n)."""
    v = v0.astype(float).copy()
    scale = v0  # what a speed is small against
    p = P_t = work = 0.0  # normal impulse, tangential impulse, normal work int v_n dp
    P_c = W_c = math.nan  # at the end of compression
    for _ in range(MAX_SWITCHES * 4):
        if _sign(v[0], scale) == 0.0:
            v[0] = 0.0  # stuck, or starting from rest: no slip to follow
        dPt = _tangential_rate(W, v[0], mu)
        a = W @ np.array([dPt, 1.0])  # dv/dp in this regime
        steps = []
        if v[0] != 0.0 and v[0] * a[0] < 0:
            steps.append(("stops", -v[0] / a[0]))  # the slip stops: stick or reverse
        stalls = a[1] <= SLIP_TOLERANCE * W[1, 1]  # the normal impulse no longer lifts the tip
        if math.isnan(P_c):
            if stalls:
                raise ImpactgenError("the contact jams: friction keeps the tip from leaving the surface "
                                     "(Painleve's paradox); the rigid laws have no solution here")
            steps.append(("compressed", -v[1] / a[1]))
        elif stalls and v[1] <= SLIP_TOLERANCE * abs(scale[1]):
            raise ImpactgenError("the contact jams in restitution: friction holds the tip on the surface "
                                 "(a self-locking impact); the rigid laws have no restitution here")
        else:
            steps.append(("ends", _end_step(law, e, p, P_c, work, W_c, v[1], a[1])))
        event, dp = min(steps, key=lambda s: s[1])
        if not math.isfinite(dp):
            raise ImpactgenError("the contact jams in restitution: friction keeps the tip from leaving the "
                                 "surface (Painleve's paradox); the energetic law has no solution here")
        dp = max(dp, 0.0)
        work += v[1] * dp + 0.5 * a[1] * dp * dp
        p, P_t, v = p + dp, P_t + dPt * dp, v + a * dp
        path.append((p, float(v[0]), float(v[1])))
        if event == "stops":
            v[0] = 0.0
        elif event == "compressed":
            v[1] = 0.0
            P_c, W_c = p, work
        else:
            return np.array([P_t, p]), P_c
    raise ImpactgenError("the rigid impact did not end within its expected slip-stick changes")


def _tangential_rate(W: np.ndarray, v_t: float, mu: float) -> float:
    """dP_t/dp now: -mu s while slipping; the holding rate while the tip sticks, if it is
    within the friction cone and lets the normal impulse still move the tip off the surface;
    else a slip in a direction s that the tip then takes (d v_t / dp of sign s). With no such
    slip the holding rate stands, and a contact that cannot restitute is reported as jammed.
    v_t: the tangential speed, exactly 0 when the tip does not slip."""
    if v_t != 0.0:
        return -mu * math.copysign(1.0, v_t)
    if W[0, 0] <= SLIP_TOLERANCE * W[1, 1]:
        return 0.0  # no impulse moves the tip along the surface (a bar normal to it): nothing to hold
    hold = -W[0, 1] / W[0, 0]  # keeps d v_t / dp = 0
    if abs(hold) <= mu and W[1, 0] * hold + W[1, 1] > SLIP_TOLERANCE * W[1, 1]:
        return hold
    for slip in (math.copysign(1.0, W[0, 1]), -math.copysign(1.0, W[0, 1])):
        if (W[0, 1] - mu * slip * W[0, 0]) * slip > 0:  # the tip slips the way friction assumed
            return -mu * slip
    return hold


def _end_step(law: str, e: float, p: float, P_c: float, work: float, W_c: float, v_n: float, a_n: float) -> float:
    """The step in p, from p with normal work `work`, to the end the law sets; infinite when
    the end lies beyond this regime's reach (a regime change comes first)."""
    if law == "poisson":
        return (1.0 + e) * P_c - p
    target = W_c * (1.0 - e * e)  # total normal work at the end: W_c + W_r, W_r = -e^2 W_c
    # work + v_n dp + a_n dp^2 / 2 = target, with v_n >= 0 rising: the first root
    gap = target - work  # >= 0: the work still to do in restitution
    if gap <= 0:
        return 0.0
    disc = v_n * v_n + 2.0 * a_n * gap
    if disc < 0:
        return math.inf
    root = v_n + math.sqrt(disc)  # the first root, written without cancellation
    return 2.0 * gap / root if root > 0 else math.inf
