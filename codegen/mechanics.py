"""Stage 2 of the pipeline: the equations of motion of an n-link chain, by Kane's method.

The chain of MODEL.md section 1: homogeneous bars joined by pins, link 1 pinned at O,
absolute angles q_i from +x, generalized speeds u_i = dq_i/dt. The tip B carries a normal
contact force F (along +y) and a friction force F_f (along +x), kept as symbols here so
that the contact laws (contact.py) stay separate and prunable.

A free chain (nothing holds it) adds its base point O's coordinates (x_0, y_0) after the
angles, and their rates (u_x0, u_y0) after the angular speeds. Over an inclined surface
(angle alpha, descending towards +x) the coordinates stay in the surface's frame and gravity
is g (sin alpha, -cos alpha). A pinned chain over a level surface is built exactly as before.

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
    base_q: tuple[sm.Symbol, ...] = ()  # a free chain's (x_0, y_0), m; () for a pinned one
    base_u: tuple[sm.Symbol, ...] = ()  # their rates (u_x0, u_y0), m/s
    alpha: sm.Symbol | None = None  # the surface's angle in degrees (surface.angle_deg) when inclined, else None

    @classmethod
    def for_links(cls, n: int, free: bool = False, inclined: bool = False) -> "ChainSymbols":
        idx = range(1, n + 1)
        return cls(
            q=tuple(sm.Symbol(f"q{i}") for i in idx),
            u=tuple(sm.Symbol(f"u{i}") for i in idx),
            L=tuple(sm.Symbol(f"L{i}", positive=True) for i in idx),
            m=tuple(sm.Symbol(f"m{i}", positive=True) for i in idx),
            g=sm.Symbol("g", nonnegative=True),
            F=sm.Symbol("F"),
            F_f=sm.Symbol("F_f"),
            base_q=(sm.Symbol("x_0"), sm.Symbol("y_0")) if free else (),
            base_u=(sm.Symbol("u_x0"), sm.Symbol("u_y0")) if free else (),
            alpha=sm.Symbol("angle_deg") if inclined else None,
        )

    @property
    def coordinates(self) -> tuple[sm.Symbol, ...]:
        """The generalized coordinates: the angles, then a free chain's base point."""
        return self.q + self.base_q

    @property
    def speeds(self) -> tuple[sm.Symbol, ...]:
        """The generalized speeds, in the coordinates' order."""
        return self.u + self.base_u

    @property
    def gravity(self) -> tuple[sm.Expr, sm.Expr]:
        """Gravity's acceleration (x, y) in the surface's frame."""
        if self.alpha is None:
            return sm.S.Zero, -self.g
        angle = sm.pi * self.alpha / 180
        return self.g * sm.sin(angle), -self.g * sm.cos(angle)


@dataclass(frozen=True)
class ChainEquations:
    """Kane's equations and the kinematic outputs of the chain, in plain symbols."""

    n: int
    symbols: ChainSymbols
    mass_matrix: sm.Matrix  # M(q), dof x dof, symmetric positive definite
    forcing: sm.Matrix  # f(q, u, g, F, F_f), dof x 1
    tip_position: tuple[sm.Expr, sm.Expr]  # x_B, y_B
    tip_velocity: tuple[sm.Expr, sm.Expr]  # v_Bx, v_By
    kinetic_energy: tuple[sm.Expr, ...]  # T_i per link
    potential_energy: sm.Expr  # V
    joint_y: tuple[sm.Expr, ...] = ()  # y of the joints between the links (1 to n - 1): the floor net
    joint_x: tuple[sm.Expr, ...] = ()  # and their x: contact at the joints

    @property
    def free(self) -> bool:
        return bool(self.symbols.base_q)

    @property
    def dof(self) -> int:
        """The number of generalized coordinates: the angles, and a free chain's base point's two."""
        return len(self.symbols.coordinates)


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
def kane_system(n: int, free: bool = False, inclined: bool = False) -> KaneSystem:
    """Form Kane's equations of the n-link chain with sympy.physics.mechanics.KanesMethod:
    pinned at the origin O, or `free` (its base point A0 at (x_0, y_0) from O, the two added
    to the coordinates), under gravity normal to a level surface or along an `inclined` one."""
    if n < 1:
        raise ValueError("a chain needs at least one link")
    s = ChainSymbols.for_links(n, free, inclined)
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")

    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    root = O
    if free:  # the base point moves: two more coordinates and speeds, after the angles
        x0, y0, ux0, uy0 = me.dynamicsymbols("x_0 y_0 u_x0 u_y0")
        root = O.locatenew("A0", x0 * N.x + y0 * N.y)
        root.set_vel(N, ux0 * N.x + uy0 * N.y)
        q, u = [*q, x0, y0], [*u, ux0, uy0]
    g_x, g_y = s.gravity
    weight = -s.g * N.y if not inclined else g_x * N.x + g_y * N.y  # per unit mass

    bodies, loads = [], []
    joint = root  # the pin at the root of the current link
    for i in range(n):
        B = N.orientnew(f"B{i + 1}", "Axis", (q[i], N.z))
        B.set_ang_vel(N, u[i] * N.z)
        C = joint.locatenew(f"C{i + 1}", s.L[i] / 2 * B.x)
        C.v2pt_theory(joint, N, B)
        end = joint.locatenew(f"A{i + 1}", s.L[i] * B.x)
        end.v2pt_theory(joint, N, B)
        I_C = me.inertia(B, 0, 0, s.m[i] * s.L[i] ** 2 / 12)
        bodies.append(me.RigidBody(f"link{i + 1}", C, B, s.m[i], (I_C, C)))
        loads.append((C, s.m[i] * weight))
        joint = end
    tip = joint
    loads.append((tip, s.F_f * N.x + s.F * N.y))

    kane = me.KanesMethod(N, q_ind=q, u_ind=u,
                          kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(bodies, loads)
    return KaneSystem(kane, N, O, tip, tuple(bodies), tuple(q), tuple(u), s)


@lru_cache(maxsize=8)
def derive_chain(n: int, free: bool = False, inclined: bool = False) -> ChainEquations:
    """The n-link chain's equations (Kane's method) in plain symbols, ready for code."""
    system = kane_system(n, free, inclined)
    kane, N, O, tip, bodies, s = system.kane, system.N, system.O, system.tip, system.bodies, system.symbols
    plain = {**dict(zip(system.q, s.coordinates)), **dict(zip(system.u, s.speeds))}
    g_x, g_y = s.gravity

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
        # V = -m g . r over the links: m g y_C on a level surface
        potential_energy=to_plain(sum(b.mass * s.g * b.masscenter.pos_from(O).dot(N.y)
                                      for b in bodies) if not inclined else
                                  sum(-b.mass * (g_x * b.masscenter.pos_from(O).dot(N.x)
                                                 + g_y * b.masscenter.pos_from(O).dot(N.y)) for b in bodies)),
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
def closed_form_chain(n: int, free: bool = False, inclined: bool = False) -> ChainEquations:
    """The n-link chain's equations from their known structure, in the symbols Kane's method
    gives. With A_jk = L_j L_k (m_h / 2 + sum_{i>h} m_i), h = max(j, k) (and
    A_jj = L_j^2 (m_j / 3 + sum_{i>j} m_i)), the mass matrix is M_jk = A_jk cos(q_j - q_k)
    and the forcing f_j = -sum_k A_jk sin(q_j - q_k) u_k^2 - g L_j cos q_j (m_j / 2 +
    sum_{i>j} m_i) + L_j (F cos q_j - F_f sin q_j): the Lagrange equations of T = u^T M u / 2.

    A free chain adds its base point (x_0, y_0): with b_j = L_j (m_j / 2 + sum_{i>j} m_i) and
    m the chain's mass, M couples it to the angles by M_(x0, j) = -b_j sin q_j and
    M_(y0, j) = b_j cos q_j, its own block is m I, and its rows' forcing is
    (sum_j b_j cos q_j u_j^2 + m g_x + F_f, sum_j b_j sin q_j u_j^2 + m g_y + F). On an
    inclined surface gravity (g_x, g_y) = g (sin alpha, -cos alpha) gives the angles'
    forcing b_j (-g_x sin q_j + g_y cos q_j)."""
    if n < 1:
        raise ValueError("a chain needs at least one link")
    s = ChainSymbols.for_links(n, free, inclined)
    g_x, g_y = s.gravity
    c = [sm.cos(q) for q in s.q]
    si = [sm.sin(q) for q in s.q]
    beyond = [sm.Add(*s.m[i + 1:]) for i in range(n)]  # mass beyond link i
    b = [s.L[j] * (s.m[j] / 2 + beyond[j]) for j in range(n)]  # first moment of the links from j on about joint j - 1

    def A(j: int, k: int) -> sm.Expr:
        if j == k:
            return s.L[j] ** 2 * (s.m[j] / 3 + beyond[j])
        h = max(j, k)
        return s.L[j] * s.L[k] * (s.m[h] / 2 + beyond[h])

    def cos_diff(j: int, k: int) -> sm.Expr:
        return c[j] * c[k] + si[j] * si[k]

    def sin_diff(j: int, k: int) -> sm.Expr:
        return si[j] * c[k] - c[j] * si[k]

    def weight(j: int) -> sm.Expr:  # gravity's generalized force on angle j
        if not inclined:
            return - s.g * s.L[j] * c[j] * (s.m[j] / 2 + beyond[j])
        return b[j] * (-g_x * si[j] + g_y * c[j])

    M = sm.Matrix(n, n, lambda j, k: A(j, j) if j == k else A(j, k) * cos_diff(j, k))
    f = sm.Matrix(n, 1, lambda j, _: (-sm.Add(*(A(j, k) * sin_diff(j, k) * s.u[k] ** 2 for k in range(n) if k != j))
                                      + weight(j) + s.L[j] * (s.F * c[j] - s.F_f * si[j])))
    x0, y0 = s.base_q if free else (sm.S.Zero, sm.S.Zero)
    ux0, uy0 = s.base_u if free else (sm.S.Zero, sm.S.Zero)
    if free:
        mass = sm.Add(*s.m)
        cross = sm.Matrix(2, n, lambda r, j: -b[j] * si[j] if r == 0 else b[j] * c[j])
        M = sm.Matrix(sm.BlockMatrix([[M, cross.T], [cross, mass * sm.eye(2)]]))
        f = f.col_join(sm.Matrix([sm.Add(*(b[j] * c[j] * s.u[j] ** 2 for j in range(n))) + mass * g_x + s.F_f,
                                  sm.Add(*(b[j] * si[j] * s.u[j] ** 2 for j in range(n))) + mass * g_y + s.F]))
    # the centre of link i and the tip: sums over the links before
    x_B = x0 + sm.Add(*(s.L[j] * c[j] for j in range(n)))
    y_B = y0 + sm.Add(*(s.L[j] * si[j] for j in range(n)))
    v_Bx = ux0 + sm.Add(*(-s.L[j] * si[j] * s.u[j] for j in range(n)))
    v_By = uy0 + sm.Add(*(s.L[j] * c[j] * s.u[j] for j in range(n)))
    T, V = [], []
    for i in range(n):
        arm = [s.L[j] for j in range(i)] + [s.L[i] / 2]  # lever of u_j in the centre's velocity
        v2 = sm.Add(*(arm[j] * arm[k] * (1 if j == k else cos_diff(j, k)) * s.u[j] * s.u[k]
                      for j in range(i + 1) for k in range(i + 1)))
        if free:  # the base point's velocity, and its product with the links' own
            v2 += ux0 ** 2 + uy0 ** 2 + 2 * sm.Add(*(arm[j] * (-ux0 * si[j] + uy0 * c[j]) * s.u[j]
                                                     for j in range(i + 1)))
        T.append(s.m[i] * v2 / 2 + s.m[i] * s.L[i] ** 2 / 24 * s.u[i] ** 2)
        y_C = y0 + sm.Add(*(arm[j] * si[j] for j in range(i + 1)))
        if not inclined:
            V.append(s.m[i] * s.g * y_C)
        else:
            V.append(-s.m[i] * (g_x * (x0 + sm.Add(*(arm[j] * c[j] for j in range(i + 1)))) + g_y * y_C))
    return ChainEquations(n=n, symbols=s, mass_matrix=M, forcing=f, tip_position=(x_B, y_B),
                          tip_velocity=(v_Bx, v_By), kinetic_energy=tuple(T), potential_energy=sm.Add(*V),
                          joint_y=tuple(y0 + sm.Add(*(s.L[j] * si[j] for j in range(i + 1))) for i in range(n - 1)),
                          joint_x=tuple(x0 + sm.Add(*(s.L[j] * c[j] for j in range(i + 1))) for i in range(n - 1)))


def chain_equations(n: int, free: bool = False, inclined: bool = False) -> ChainEquations:
    """The chain's equations as the generator uses them: Kane's method (sympy.physics.mechanics)
    up to KANE_MAX_LINKS links, the closed form it is checked against beyond."""
    return derive_chain(n, free, inclined) if n <= KANE_MAX_LINKS else closed_form_chain(n, free, inclined)
