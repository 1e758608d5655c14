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
    energies."""

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

    @cached_property
    def inertia_matrix(self) -> np.ndarray:
        """diag(m_i L_i^2 / 12), the links' own rotational inertia in M."""
        return np.diag(self.inertia)

    @cached_property
    def weight(self) -> np.ndarray:
        """-g L_i, the factor of gravity's term in Q_i."""
        return -self.g * self.L

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return self.c * np.cos(np.subtract.outer(q, q)) + self.inertia_matrix

    def accelerations(self, q: np.ndarray, u: np.ndarray, F: float | np.ndarray,
                      F_f: float | np.ndarray) -> np.ndarray:
        """du/dt under the normal loads F and the friction loads F_f the links carry: arrays
        (n,) from `loads`, or numbers that every link carries (forces at point n alone). The
        right-hand side calls this at every evaluation: each angle difference, cosine and sine
        is taken once."""
        dq = np.subtract.outer(q, q)
        velocity_terms = (self.c * np.sin(dq)) @ (u * u)
        cos_q = np.cos(q)
        Q = self.weight * cos_q * self.gravity_arm + self.L * (F * cos_q - F_f * np.sin(q))
        return solve(self.c * np.cos(dq) + self.inertia_matrix, Q - velocity_terms)

    def loads(self, points: list[int], forces: list[float]) -> np.ndarray:
        """The force each link carries (n,): link i (from 0) carries the forces of the points
        k > i (point k, 1..n, is the end of link k and moves with the links up to it)."""
        carried = np.zeros(len(self.L))
        for k, force in zip(points, forces):
            carried[:k] += force
        return carried

    def point(self, q: np.ndarray, u: np.ndarray, k: int) -> tuple[float, float, float, float]:
        """x, y, v_x, v_y of point k, the end of link k (k = 1..n): sums over the links up to
        it. q and u may hold samples, of shape (n, N); for one state (the right-hand side and
        the events ask for one at every evaluation) the sums are taken over plain floats."""
        if q.ndim == 1:
            x = y = v_x = v_y = 0.0
            for L, q_i, u_i in zip(self.L[:k].tolist(), q[:k].tolist(), u[:k].tolist()):
                cos_q, sin_q = math.cos(q_i), math.sin(q_i)
                x, y = x + L * cos_q, y + L * sin_q
                v_x, v_y = v_x - L * u_i * sin_q, v_y + L * u_i * cos_q
            return x, y, v_x, v_y
        L, q, u = self.L[:k, None], q[:k], u[:k]
        return ((L * np.cos(q)).sum(0), (L * np.sin(q)).sum(0),
                (-L * u * np.sin(q)).sum(0), (L * u * np.cos(q)).sum(0))

    def height_and_rate(self, q: np.ndarray, u: np.ndarray, k: int) -> tuple[float, float]:
        """y and v_y of point k for one state: what its contact events need."""
        y = v_y = 0.0
        for L, q_i, u_i in zip(self.L[:k].tolist(), q[:k].tolist(), u[:k].tolist()):
            y += L * math.sin(q_i)
            v_y += L * u_i * math.cos(q_i)
        return y, v_y

    def holding_forces(self, q: np.ndarray, u: np.ndarray, F: np.ndarray, F_f: np.ndarray,
                       held: list[int]) -> np.ndarray:
        """The tangential forces at the points `held` (indices k) that keep their v_x at zero
        together, the links carrying the other forces F and F_f (`loads`). With A the rows
        a_k = (-L_i sin q_i for i < k, 0 beyond), d(v_x)/dt = A du/dt - c = 0 with
        c_k = sum_{i<k} L_i cos(q_i) u_i^2, and du/dt = free + M^-1 A^T F_hold. Two held points
        on one nearly horizontal link make A M^-1 A^T nearly singular: holding both exactly
        would take huge opposite forces for a motion of second order. The pseudo-inverse of the
        symmetric A M^-1 A^T with the cut-off HOLD_RCOND on its eigenvalues drops that direction
        (the least-squares solution: the smallest forces that hold the rest); for one held
        point it is the plain quotient."""
        n = len(self.L)
        A = np.array([np.where(np.arange(n) < k, -self.L * np.sin(q), 0.0) for k in held])
        c = np.array([np.sum((self.L * np.cos(q) * u ** 2)[:k]) for k in held])
        free = self.accelerations(q, u, F, F_f)
        per_newton = np.linalg.solve(self.mass_matrix(q), A.T)  # du/dt per newton at each held point
        w, V = np.linalg.eigh(A @ per_newton)
        kept = w > HOLD_RCOND * w.max()
        return V[:, kept] @ ((V[:, kept].T @ (c - A @ free)) / w[kept])

    def energies(self, q: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Kinetic energy per link (n, N) and potential energy (N,) for samples q, u (n, N)."""
        n = len(self.L)
        T = np.empty_like(u)
        V = np.zeros(q.shape[1])
        vx = np.zeros(q.shape[1])
        vy = np.zeros(q.shape[1])
        y = np.zeros(q.shape[1])
        for j in range(n):
            L = self.L[j]
            vcx = vx - L / 2 * u[j] * np.sin(q[j])
            vcy = vy + L / 2 * u[j] * np.cos(q[j])
            T[j] = 0.5 * self.m[j] * (vcx ** 2 + vcy ** 2) + 0.5 * self.inertia[j] * u[j] ** 2
            V += self.m[j] * self.g * (y + L / 2 * np.sin(q[j]))
            vx, vy = vx - L * u[j] * np.sin(q[j]), vy + L * u[j] * np.cos(q[j])
            y = y + L * np.sin(q[j])
        return T, V


def solve(M: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with M x = b, by LAPACK's dgesv (LU with partial pivoting), the routine
    numpy.linalg.solve calls, without its checks and conversions: on the chain's few links
    they took longer than the solve. M is overwritten."""
    _, _, x, info = dgesv(M, b, overwrite_a=True)
    if info:
        raise np.linalg.LinAlgError(f"singular mass matrix (dgesv info = {info})")
    return x
