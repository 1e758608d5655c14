"""The chain's equations of motion, derived here by hand, independently of codegen/.

With absolute angles, the velocity of the mass centre of link j is
v_Cj = sum_i a_ji L_i u_i e_i', where e_i' = (-sin q_i, cos q_i) and a_ji = 1 for i < j,
1/2 for i = j, 0 for i > j. The kinetic energy is then T = 1/2 sum_ik M_ik u_i u_k with

    M_ik = c_ik cos(q_i - q_k) + delta_ik m_i L_i^2 / 12,   c_ik = L_i L_k mu_ik,
    mu_ik = sum_j m_j a_ji a_jk = m_k'/2 + sum_{j > k'} m_j,  k' = max(i, k)   (i != k)
    mu_ii = m_i/4 + sum_{j > i} m_j.

Lagrange's equations d/dt(dT/du_i) - dT/dq_i = Q_i (rather than Kane's method and sympy)
reduce to

    sum_k M_ik du_k/dt = Q_i - sum_k c_ik sin(q_i - q_k) u_k^2.

Contact point k (k = 1..n) is the end of link k: joint k for k < n, the chain's end (the
scene's tip) for k = n. It moves with the links i <= k: x_k = sum_{i<=k} L_i cos q_i,
y_k = sum_{i<=k} L_i sin q_i, so its Jacobian has the rows (-L_i sin q_i, L_i cos q_i) for
i <= k and zeros beyond. A normal force F_k and a friction force F_f,k at point k act through
it: they add L_i (F_k cos q_i - F_f,k sin q_i) to Q_i for every i <= k. Link i thus carries
the forces of every point at or beyond its end (`ChainModel.loads`), and with gravity

    Q_i = -g L_i cos(q_i) (m_i/2 + sum_{j > i} m_j) + L_i (F_i cos q_i - F_f,i sin q_i),

(F_i, F_f,i) the loads link i carries.

The surface may be inclined at an angle a (it descends towards +x). Coordinates stay in the
surface's frame, x along it and y normal to it, so gravity per unit mass is
(g_x, g_y) = (g sin a, -g cos a) and the potential energy is V = -sum_j m_j (g_x x_Cj + g_y y_Cj).
Its generalized force on q_i is then

    Q_i^g = b_i L_i (g_y cos q_i - g_x sin q_i),   b_i = m_i/2 + sum_{j > i} m_j,

which for a = 0 is the term -g L_i cos(q_i) b_i above.

A free chain: nothing holds the first link's start, the base point r_0 = (x_0, y_0); its two
coordinates join the angles, after them. The state is (q_1..q_n, x_0, y_0, u_1..u_n, u_x0, u_y0),
as the C model lays it out. Every point moves with the base: r_Cj = r_0 + sum_i a_ji L_i e_i,
v_Cj = v_0 + sum_i a_ji L_i u_i e_i', so that

    T = 1/2 m v_0.v_0 + v_0 . sum_i b_i L_i u_i e_i' + 1/2 sum_ik M_ik u_i u_k,

v_0 = (u_x0, u_y0), m = sum_j m_j, since sum_j m_j a_ji = b_i. The mass matrix in
(u_1..u_n, u_x0, u_y0) is

    [ M_ik                -b_i L_i sin q_i   b_i L_i cos q_i ]
    [ -b_k L_k sin q_k    m                  0               ]
    [ b_k L_k cos q_k     0                  m               ]

Lagrange's equation of x_0: d/dt(m u_x0 - sum_i b_i L_i sin(q_i) u_i) = Q_x, of y_0:
d/dt(m u_y0 + sum_i b_i L_i cos(q_i) u_i) = Q_y, so their rows read

    m du_x0/dt - sum_i b_i L_i sin q_i du_i/dt = Q_x + sum_i b_i L_i cos(q_i) u_i^2,
    m du_y0/dt + sum_i b_i L_i cos q_i du_i/dt = Q_y + sum_i b_i L_i sin(q_i) u_i^2.

In the equation of q_i, v_0's term gives d/dt(b_i L_i (-u_x0 sin q_i + u_y0 cos q_i)) =
b_i L_i (-sin q_i du_x0/dt + cos q_i du_y0/dt) - b_i L_i u_i (u_x0 cos q_i + u_y0 sin q_i), and
dT/dq_i the same last term, which cancels: the angles' rows gain the mass matrix's coupling
and nothing else. With point 0 the base (its Jacobian: the rows (1, 0) and (0, 1) of x_0, y_0
and nothing of the angles) and point k moving with the base and the links i <= k, a force
(F_f,k, F_k) at any point adds F_f,k to Q_x and F_k to Q_y (the base carries every point's
forces, `ChainModel.loads`), and gravity adds m g_x and m g_y.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.linalg.lapack import dgesv

from ..scene import Scene

# Several stuck points: a direction of their holding forces' system weaker than this fraction
# of its strongest is not held (ChainModel.holding_forces)
HOLD_RCOND = 1e-8


@dataclass(frozen=True)
class ChainModel:
    """The chain's constants and equations: its mass matrix, its accelerations under the loads
    its links carry, the kinematics of its points, the forces that hold points still and its
    energies. Positions and speeds are the generalized ones: the angles and their rates, and
    after them the base's coordinates and speeds for a free chain."""

    L: np.ndarray
    m: np.ndarray
    g: float
    c: np.ndarray  # c_ik of the docstring (n x n)
    inertia: np.ndarray  # m_i L_i^2 / 12
    gravity_arm: np.ndarray  # b_i = m_i/2 + sum_{j>i} m_j
    free: bool = False  # the base is free: its coordinates x_0, y_0 follow the angles
    slope: float = 0.0  # the surface's angle a (rad), descending towards +x

    @classmethod
    def from_scene(cls, scene: Scene, free: bool = False, slope: float = 0.0) -> "ChainModel":
        """The chain of `scene`; `free` and `slope` (rad) as `body.Body` reads them."""
        L, m = np.array(scene.chain.length), np.array(scene.chain.mass)
        n = len(L)
        outboard = np.array([m[i + 1:].sum() for i in range(n)])  # sum_{j > i} m_j
        mu = np.empty((n, n))
        for i in range(n):
            for k in range(n):
                j = max(i, k)
                mu[i, k] = m[i] / 4 + outboard[i] if i == k else m[j] / 2 + outboard[j]
        return cls(L, m, scene.chain.gravity, np.outer(L, L) * mu, m * L ** 2 / 12, m / 2 + outboard, free, slope)

    @cached_property
    def dof(self) -> int:
        """The generalized coordinates: the angles, and the base's two for a free chain."""
        return len(self.L) + (2 if self.free else 0)

    @cached_property
    def gravity_vector(self) -> tuple[float, float]:
        """(g_x, g_y) = (g sin a, -g cos a) in the surface's frame; (0, -g) exactly when level."""
        return self.g * math.sin(self.slope), -self.g * math.cos(self.slope)

    @cached_property
    def inertia_matrix(self) -> np.ndarray:
        """diag(m_i L_i^2 / 12), the links' own rotational inertia in M."""
        return np.diag(self.inertia)

    @cached_property
    def weight(self) -> np.ndarray:
        """g_y L_i (-g L_i on a level surface), the factor of gravity's term in Q_i."""
        return self.gravity_vector[1] * self.L

    @cached_property
    def total_mass(self) -> float:
        return float(self.m.sum())

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M at positions q (the base's coordinates after the angles for a free chain)."""
        angles = q[:len(self.L)]
        M_links = self.c * np.cos(np.subtract.outer(angles, angles)) + self.inertia_matrix
        if not self.free:
            return M_links
        return self._free_mass_matrix(M_links, self.gravity_arm * self.L, np.cos(angles), np.sin(angles))

    def _free_mass_matrix(self, M_links: np.ndarray, arm: np.ndarray, cos_q: np.ndarray,
                          sin_q: np.ndarray) -> np.ndarray:
        """The free chain's M around the angles' block (the module docstring), arm = b_i L_i."""
        n = len(self.L)
        M = np.empty((self.dof, self.dof))
        M[:n, :n] = M_links
        M[n:, n:] = np.eye(2) * self.total_mass
        M[n, :n], M[n + 1, :n] = -arm * sin_q, arm * cos_q
        M[:n, n:] = M[n:, :n].T
        return M

    def accelerations(self, q: np.ndarray, u: np.ndarray, F: float | np.ndarray,
                      F_f: float | np.ndarray) -> np.ndarray:
        """du/dt under the normal loads F and the friction loads F_f the chain carries: arrays
        from `loads`, or numbers that every link (and the base) carries (forces at point n
        alone). The right-hand side calls this at every evaluation: each angle difference,
        cosine and sine is taken once."""
        n = len(self.L)
        angles, rates = q[:n], u[:n]
        F_base, F = (F[n], F[:n]) if self.free and np.ndim(F) else (F, F)
        F_f_base, F_f = (F_f[n], F_f[:n]) if self.free and np.ndim(F_f) else (F_f, F_f)
        dq = np.subtract.outer(angles, angles)
        velocity_terms = (self.c * np.sin(dq)) @ (rates * rates)
        cos_q, sin_q = np.cos(angles), np.sin(angles)
        Q = self.weight * cos_q * self.gravity_arm + self.L * (F * cos_q - F_f * sin_q)
        g_x, g_y = self.gravity_vector
        if g_x:  # inclined: gravity along the surface too
            Q = Q - g_x * self.L * sin_q * self.gravity_arm
        M_links = self.c * np.cos(dq) + self.inertia_matrix
        if not self.free:
            return solve(M_links, Q - velocity_terms)
        arm = self.gravity_arm * self.L
        squares = arm * rates * rates
        forcing = np.concatenate([Q - velocity_terms, [self.total_mass * g_x + F_f_base + squares @ cos_q,
                                                       self.total_mass * g_y + F_base + squares @ sin_q]])
        return solve(self._free_mass_matrix(M_links, arm, cos_q, sin_q), forcing)

    def loads(self, points: list[int], forces: list[float]) -> np.ndarray:
        """The force each link carries (n,): link i (from 0) carries the forces of the points
        k > i (point k, 1..n, is the end of link k and moves with the links up to it). A free
        chain's base carries every point's force, after the links (n + 1,); point 0, the
        base, moves with it alone."""
        n = len(self.L)
        carried = np.zeros(n + 1 if self.free else n)
        for k, force in zip(points, forces):
            carried[:k] += force
        if self.free:
            carried[n] = sum(forces)
        return carried

    def point(self, q: np.ndarray, u: np.ndarray, k: int) -> tuple[float, float, float, float]:
        """x, y, v_x, v_y of point k: the end of link k (k = 1..n), or the base (k = 0, a free
        chain's): sums over the links up to it, from the base. q and u may hold samples, of
        shape (dof, N); for one state (the right-hand side and the events ask for one at every
        evaluation) the sums are taken over plain floats."""
        n = len(self.L)
        if q.ndim == 1:
            if self.free:
                x, y, v_x, v_y = float(q[n]), float(q[n + 1]), float(u[n]), float(u[n + 1])
            else:
                x = y = v_x = v_y = 0.0
            for L, q_i, u_i in zip(self.L[:k].tolist(), q[:k].tolist(), u[:k].tolist()):
                cos_q, sin_q = math.cos(q_i), math.sin(q_i)
                x, y = x + L * cos_q, y + L * sin_q
                v_x, v_y = v_x - L * u_i * sin_q, v_y + L * u_i * cos_q
            return x, y, v_x, v_y
        L, angles, rates = self.L[:k, None], q[:k], u[:k]
        x, y = (L * np.cos(angles)).sum(0), (L * np.sin(angles)).sum(0)
        v_x, v_y = (-L * rates * np.sin(angles)).sum(0), (L * rates * np.cos(angles)).sum(0)
        if self.free:
            return x + q[n], y + q[n + 1], v_x + u[n], v_y + u[n + 1]
        return x, y, v_x, v_y

    def height_and_rate(self, q: np.ndarray, u: np.ndarray, k: int) -> tuple[float, float]:
        """y and v_y of point k for one state: what its contact events need."""
        n = len(self.L)
        y, v_y = (float(q[n + 1]), float(u[n + 1])) if self.free else (0.0, 0.0)
        for L, q_i, u_i in zip(self.L[:k].tolist(), q[:k].tolist(), u[:k].tolist()):
            y += L * math.sin(q_i)
            v_y += L * u_i * math.cos(q_i)
        return y, v_y

    def holding_forces(self, q: np.ndarray, u: np.ndarray, F: np.ndarray, F_f: np.ndarray,
                       held: list[int], resting: list[tuple[int, float]] = ()) -> tuple[np.ndarray, np.ndarray]:
        """The forces that hold points still together, the chain carrying the other forces F and
        F_f (`loads`): the tangential forces at the points `held` (indices k) that keep their v_x
        at zero (stuck), and the normal forces at the points `resting` (k, f) that keep their
        v_y at zero (sustained contact), where a resting point that slips carries the friction
        force f times its normal force with it (f = 0 when it is also stuck).

        With the rows a_k of v_x (-L_i sin q_i for i < k, 0 beyond; then (1, 0) for a free
        chain's base) and of v_y (L_i cos q_i for i < k; then (0, 1)), d(v)/dt = a du/dt - c with
        c_k = sum_{i<k} L_i cos(q_i) u_i^2 for v_x and sum_{i<k} L_i sin(q_i) u_i^2 for v_y, and
        du/dt = free + M^-1 W^T F_hold, W the rows the forces act along (a resting, slipping
        point's: a_y + f a_x). Two held points on one nearly horizontal link make A M^-1 W^T
        nearly singular: holding both exactly would take huge opposite forces for a motion of
        second order. The pseudo-inverse with the cut-off HOLD_RCOND on its singular values
        drops that direction (the least-squares solution: the smallest forces that hold the
        rest); for one held point it is the plain quotient. Returns the tangential forces (by
        `held`) and the normal ones (by `resting`)."""
        n = len(self.L)
        angles, rates = q[:n], u[:n]
        base_x, base_y = ([1.0, 0.0], [0.0, 1.0]) if self.free else ([], [])
        sin_arm, cos_arm = self.L * np.sin(angles), self.L * np.cos(angles)

        def row(k: int, arm: np.ndarray, base: list[float]) -> list[float]:
            return [*np.where(np.arange(n) < k, arm, 0.0), *base]

        A = [row(k, -sin_arm, base_x) for k in held] + [row(k, cos_arm, base_y) for k, _ in resting]
        W = A[:len(held)] + [np.add(row(k, cos_arm, base_y), np.multiply(f, row(k, -sin_arm, base_x)))
                             for k, f in resting]
        c = ([np.sum((cos_arm * rates ** 2)[:k]) for k in held]
             + [np.sum((sin_arm * rates ** 2)[:k]) for k, _ in resting])
        A, W, c = np.array(A), np.array(W), np.array(c)
        free = self.accelerations(q, u, F, F_f)
        per_newton = np.linalg.solve(self.mass_matrix(q), W.T)  # du/dt per newton of each holding force
        system, rhs = A @ per_newton, c - A @ free
        if not any(f for _, f in resting):  # symmetric (A = W): by its eigenvalues, as it always was
            w, V = np.linalg.eigh(system)
            kept = w > HOLD_RCOND * w.max()
            forces = V[:, kept] @ ((V[:, kept].T @ rhs) / w[kept])
        else:
            forces = np.linalg.lstsq(system, rhs, rcond=HOLD_RCOND)[0]
        return forces[:len(held)], forces[len(held):]

    def energies(self, q: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Kinetic energy per link (n, N) and potential energy (N,) for samples q, u (dof, N):
        each link's centre moves with the base (a free chain's) and the links before it."""
        n = len(self.L)
        samples = q.shape[1]
        T = np.empty((n, samples))
        V = np.zeros(samples)
        x, y = (q[n].copy(), q[n + 1].copy()) if self.free else (np.zeros(samples), np.zeros(samples))
        vx, vy = (u[n].copy(), u[n + 1].copy()) if self.free else (np.zeros(samples), np.zeros(samples))
        g_x, g_y = self.gravity_vector
        for j in range(n):
            L, q_j, u_j = self.L[j], q[j], u[j]
            vcx = vx - L / 2 * u_j * np.sin(q_j)
            vcy = vy + L / 2 * u_j * np.cos(q_j)
            T[j] = 0.5 * self.m[j] * (vcx ** 2 + vcy ** 2) + 0.5 * self.inertia[j] * u_j ** 2
            V += self.m[j] * -g_y * (y + L / 2 * np.sin(q_j))
            if g_x:
                V -= self.m[j] * g_x * (x + L / 2 * np.cos(q_j))
            vx, vy = vx - L * u_j * np.sin(q_j), vy + L * u_j * np.cos(q_j)
            x, y = x + L * np.cos(q_j), y + L * np.sin(q_j)
        return T, V


def solve(M: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with M x = b, by LAPACK's dgesv (LU with partial pivoting), the routine
    numpy.linalg.solve calls, without its checks and conversions: on the chain's few links
    they took longer than the solve. M is overwritten."""
    _, _, x, info = dgesv(M, b, overwrite_a=True)
    if info:
        raise np.linalg.LinAlgError(f"singular mass matrix (dgesv info = {info})")
    return x
