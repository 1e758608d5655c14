"""Stage 2 of the pipeline: the equations of motion of an n-link chain, by Kane's method.

The chain of MODEL.md section 1: homogeneous bars joined by pins, link 1 pinned at O,
absolute angles q_i from +x, generalized speeds u_i = dq_i/dt. The tip B carries a normal
contact force F (along +y) and a friction force F_f (along +x), kept as symbols here so
that the contact laws (contact.py) stay separate and prunable.

Kane's equations come out as M(q) du/dt = f(q, u, F, F_f); M is kept as a matrix and
solved numerically in the generated C, never inverted symbolically.
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
    )
