"""Stage 2 of the pipeline: the equations of motion of an n-link chain, by Kane's method.

The chain of MODEL.md section 1: homogeneous bars joined by pins, link 1 pinned at O,
absolute angles q_i from +x, generalized speeds u_i = dq_i/dt. The tip B carries a normal
contact force F (along +y) and a friction force F_f (along +x), kept as symbols here so
that the contact laws (contact.py) stay separate and prunable.

Kane's equations come out as M(q) du/dt = f(q, u, F, F_f); M is kept as a matrix and
solved numerically in the generated C, never inverted symbolically. Beyond KANE_MAX_LINKS
links the generator takes the same equations from their closed form (`closed_form_chain`),
which the tests hold equal to Kane's method: Kane's symbolic expansion grows to minutes
there (52 s to derive 30 links) while the closed form takes about 2 s.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sm
import sympy.physics.mechanics as me


@dataclass(frozen=True)
class ChainSymbols:
    """The plain (non-function) symbols the generated code is written in."""

    q: tuple[sm.Symbol, ...]
    u: tuple[sm.Symbol, ...]
    L: tuple[sm.Symbol, ...]
    m: tuple[sm.Symbol, ...]
    g: sm.Symbol
    F: sm.Symbol
    F_f: sm.Symbol

    @classmethod
    def for_links(cls, n: int) -> "ChainSymbols":
        idx = range(1, n + 1)
        return cls(
            q=tuple(sm.Symbol(f"q{i}") for i in idx),
            u=tuple(sm.Symbol(f"u{i}") for i in idx),
            L=tuple(sm.Symbol(f"L{i}", positive=True) for i in idx),
            m=tuple(sm.Symbol(f"m{i}", positive=True) for i in idx),
            g=sm.Symbol("g", nonnegative=True),
            F=sm.Symbol("F"),
            F_f=sm.Symbol("F_f"),
        )


@dataclass(frozen=True)
class ChainEquations:
    """Kane's equations and the kinematic outputs of the chain, in plain symbols."""

    n: int
    symbols: ChainSymbols
    mass_matrix: sm.Matrix  # M(q), n x n, symmetric positive definite
    forcing: sm.Matrix  # f(q, u, g, F, F_f), n x 1
    tip_position: tuple[sm.Expr, sm.Expr]  # x_B, y_B
    tip_velocity: tuple[sm.Expr, sm.Expr]  # v_Bx, v_By
    kinetic_energy: tuple[sm.Expr, ...]  # T_i per link
    potential_energy: sm.Expr  # V
    joint_y: tuple[sm.Expr, ...] = ()  # y of the joints between the links (1 to n - 1): the floor net
    joint_x: tuple[sm.Expr, ...] = ()  # and their x: contact at the joints


@dataclass(frozen=True)
class KaneSystem:
    """The chain as sympy.physics.mechanics builds it (dynamic symbols q(t), u(t))."""

    kane: me.KanesMethod
    N: me.ReferenceFrame
    O: me.Point
    tip: me.Point
    bodies: tuple[me.RigidBody, ...]
    q: tuple
    u: tuple
    symbols: ChainSymbols


@lru_cache(maxsize=8)
def kane_system(n: int) -> KaneSystem:
    """Form Kane's equations of the n-link chain with sympy.physics.mechanics.KanesMethod."""
    if n < 1:
        raise ValueError("a chain needs at least one link")
    s = ChainSymbols.for_links(n)
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")

    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)

    bodies, loads = [], []
    joint = O  # the pin at the root of the current link
    for i in range(n):
        B = N.orientnew(f"B{i + 1}", "Axis", (q[i], N.z))
        B.set_ang_vel(N, u[i] * N.z)
        C = joint.locatenew(f"C{i + 1}", s.L[i] / 2 * B.x)
        C.v2pt_theory(joint, N, B)
        end = joint.locatenew(f"A{i + 1}", s.L[i] * B.x)
        end.v2pt_theory(joint, N, B)
        I_C = me.inertia(B, 0, 0, s.m[i] * s.L[i] ** 2 / 12)
        bodies.append(me.RigidBody(f"link{i + 1}", C, B, s.m[i], (I_C, C)))
        loads.append((C, -s.m[i] * s.g * N.y))
        joint = end
    tip = joint
    loads.append((tip, s.F_f * N.x + s.F * N.y))

    kane = me.KanesMethod(N, q_ind=q, u_ind=u,
                          kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(bodies, loads)
    return KaneSystem(kane, N, O, tip, tuple(bodies), tuple(q), tuple(u), s)


@lru_cache(maxsize=8)
def derive_chain(n: int) -> ChainEquations:
    """The n-link chain's equations (Kane's method) in plain symbols, ready for code."""
    system = kane_system(n)
    kane, N, O, tip, bodies, s = system.kane, system.N, system.O, system.tip, system.bodies, system.symbols
    plain = {**dict(zip(system.q, s.q)), **dict(zip(system.u, s.u))}

    def to_plain(expr: sm.Expr) -> sm.Expr:
        return me.msubs(expr, plain)

    r_B = tip.pos_from(O)
    v_B = tip.vel(N)
    return ChainEquations(
        n=n,
        symbols=s,
        mass_matrix=to_plain(kane.mass_matrix),
        forcing=to_plain(kane.forcing),
        tip_position=(to_plain(r_B.dot(N.x)), to_plain(r_B.dot(N.y))),
        tip_velocity=(to_plain(v_B.dot(N.x)), to_plain(v_B.dot(N.y))),
        kinetic_energy=tuple(to_plain(b.kinetic_energy(N)) for b in bodies),
        potential_energy=to_plain(sum(b.mass * s.g * b.masscenter.pos_from(O).dot(N.y)
                                      for b in bodies)),
        # joint i ends link i: its centre plus half its length along the link
        joint_y=tuple(to_plain((b.masscenter.pos_from(O) + s.L[i] / 2 * b.frame.x).dot(N.y))
                      for i, b in enumerate(bodies[:-1])),
        joint_x=tuple(to_plain((b.masscenter.pos_from(O) + s.L[i] / 2 * b.frame.x).dot(N.x))
                      for i, b in enumerate(bodies[:-1])),
    )


# Above this many links the chain's equations come from their closed form (below), which
# tests/test_mechanics_closed_form.py holds equal to Kane's method for 1 to 6 links: Kane's
# method expands every product symbolically, which for 30 links takes about 50 s and prints
# 445 kB of C, while the closed form takes milliseconds and names each term once.
KANE_MAX_LINKS = 8


@lru_cache(maxsize=8)
def closed_form_chain(n: int) -> ChainEquations:
    """The n-link chain's equations from their known structure, in the symbols Kane's method
    gives. With A_jk = L_j L_k (m_h / 2 + sum_{i>h} m_i), h = max(j, k) (and
    A_jj = L_j^2 (m_j / 3 + sum_{i>j} m_i)), the mass matrix is M_jk = A_jk cos(q_j - q_k)
    and the forcing f_j = -sum_k A_jk sin(q_j - q_k) u_k^2 - g L_j cos q_j (m_j / 2 +
    sum_{i>j} m_i) + L_j (F cos q_j - F_f sin q_j): the Lagrange equations of T = u^T M u / 2."""
    if n < 1:
        raise ValueError("a chain needs at least one link")
    s = ChainSymbols.for_links(n)
    c = [sm.cos(q) for q in s.q]
    si = [sm.sin(q) for q in s.q]
    beyond = [sm.Add(*s.m[i + 1:]) for i in range(n)]  # mass beyond link i

    def A(j: int, k: int) -> sm.Expr:
        if j == k:
            return s.L[j] ** 2 * (s.m[j] / 3 + beyond[j])
        h = max(j, k)
        return s.L[j] * s.L[k] * (s.m[h] / 2 + beyond[h])

    def cos_diff(j: int, k: int) -> sm.Expr:
        return c[j] * c[k] + si[j] * si[k]

    def sin_diff(j: int, k: int) -> sm.Expr:
        return si[j] * c[k] - c[j] * si[k]

    M = sm.Matrix(n, n, lambda j, k: A(j, j) if j == k else A(j, k) * cos_diff(j, k))
    f = sm.Matrix(n, 1, lambda j, _: (-sm.Add(*(A(j, k) * sin_diff(j, k) * s.u[k] ** 2 for k in range(n) if k != j))
                                      - s.g * s.L[j] * c[j] * (s.m[j] / 2 + beyond[j])
                                      + s.L[j] * (s.F * c[j] - s.F_f * si[j])))
    # the centre of link i and the tip: sums over the links before
    x_B = sm.Add(*(s.L[j] * c[j] for j in range(n)))
    y_B = sm.Add(*(s.L[j] * si[j] for j in range(n)))
    v_Bx = sm.Add(*(-s.L[j] * si[j] * s.u[j] for j in range(n)))
    v_By = sm.Add(*(s.L[j] * c[j] * s.u[j] for j in range(n)))
    T, V = [], []
    for i in range(n):
        arm = [s.L[j] for j in range(i)] + [s.L[i] / 2]  # lever of u_j in the centre's velocity
        v2 = sm.Add(*(arm[j] * arm[k] * (1 if j == k else cos_diff(j, k)) * s.u[j] * s.u[k]
                      for j in range(i + 1) for k in range(i + 1)))
        T.append(s.m[i] * v2 / 2 + s.m[i] * s.L[i] ** 2 / 24 * s.u[i] ** 2)
        V.append(s.m[i] * s.g * sm.Add(*(arm[j] * si[j] for j in range(i + 1))))
    return ChainEquations(n=n, symbols=s, mass_matrix=M, forcing=f, tip_position=(x_B, y_B),
                          tip_velocity=(v_Bx, v_By), kinetic_energy=tuple(T), potential_energy=sm.Add(*V),
                          joint_y=tuple(sm.Add(*(s.L[j] * si[j] for j in range(i + 1))) for i in range(n - 1)),
                          joint_x=tuple(sm.Add(*(s.L[j] * c[j] for j in range(i + 1))) for i in range(n - 1)))


def chain_equations(n: int) -> ChainEquations:
    """The chain's equations as the generator uses them: Kane's method (sympy.physics.mechanics)
    up to KANE_MAX_LINKS links, the closed form it is checked against beyond."""
    return derive_chain(n) if n <= KANE_MAX_LINKS else closed_form_chain(n)
