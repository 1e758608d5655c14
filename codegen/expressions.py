"""Stage 4 of the pipeline: assemble and prune the expressions one model needs.

A `ModelSpec` is the *structure* a scene asks for (number of links, contact model,
friction or not); numbers (lengths, masses, materials, mu) stay runtime parameters. From
the spec, `assemble_model` picks the chain equations, the contact laws, the event
functions and the outputs, leaving out whatever the scene cannot use: with friction off
there is no friction symbol anywhere, with the Hertz model no elasto-plastic law.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sm

from . import contact as law
from .mechanics import ChainEquations, chain_equations
from .parameters import Field, fields
from .spec import PHASES, ModelSpec

y_s = sm.Symbol("y_s")  # surface height
delta_m = sm.Symbol("delta_m", nonnegative=True)  # maximum compression so far
# Tip quantities, computed first in every C function and named as in the equations.
TIP = {name: sm.Symbol(name) for name in ("x_B", "y_B", "v_Bx", "v_By", "delta", "delta_rate")}
TIP["delta"] = law.delta


@dataclass(frozen=True)
class ForceCase:
    """The normal force in one phase: computed by `steps` (the last one is F) where
    `active` holds, else 0."""

    phase: str
    active: sm.Expr  # a relational in delta
    steps: tuple[tuple[sm.Symbol, sm.Expr], ...]
    doc: str

    @property
    def expr(self) -> sm.Expr:
        *steps, (_, force) = self.steps
        for name, value in reversed(steps):
            force = force.subs(name, value)
        return force


def _single(expr: sm.Expr) -> tuple[tuple[sm.Symbol, sm.Expr], ...]:
    return ((sm.Symbol("F"), expr),)


@dataclass(frozen=True)
class Named:
    name: str
    expr: sm.Expr
    doc: str


@dataclass(frozen=True)
class JacobianExpressions:
    """d(ydot)/dy by the chain rule through the contact force. In terms of the tip
    quantities, F, F_f, the slope dF = dF/d(delta) of the active law and the accelerations
    udot_k (solved first); G is n x 2n, the acceleration rows are M^-1 G."""

    force_slopes: tuple[tuple[str, sm.Expr], ...]  # (phase, dF/d(delta))
    G: sm.Matrix  # df/dy - (dM/dy) udot, total derivatives
    works: sm.Matrix  # rows of the work states, one per work, 2n columns


@dataclass(frozen=True)
class JointMotion:
    """Joint `joint` (the end of that link) as a contact point: its height and velocity, and
    the rows of its velocity Jacobian v = J u with the terms (dJ/dt) u. A force (F_x, F_y) on
    it enters Kane's equations as J^T (F_x, F_y), as the tip's does."""

    joint: int  # 1 to n - 1
    motion: tuple[Named, ...]  # y, v_x, v_y, Jx[i], Jy[i], Jdot_u[0] (x), Jdot_u[1] (y)


def _joint_motion(chain: ChainEquations, joint: int) -> JointMotion:
    s = chain.symbols
    x, y = chain.joint_x[joint - 1], chain.joint_y[joint - 1]
    v = [sum(r.diff(q) * u for q, u in zip(s.q, s.u)) for r in (x, y)]
    rows = [Named("y", y, f"height of joint {joint}, m"),
            Named("v_x", v[0], "its velocity x, m/s"), Named("v_y", v[1], "its velocity y, m/s")]
    for axis, vel in zip("xy", v):
        rows += [Named(f"J{axis}[{i}]", vel.diff(u), f"dv_{axis}/du{i + 1}") for i, u in enumerate(s.u)]
    rows += [Named(f"Jdot_u[{k}]", sum(vel.diff(q) * u for q, u in zip(s.q, s.u)), f"(dJ_{axis}/dt) u")
             for k, (axis, vel) in enumerate(zip("xy", v))]
    return JointMotion(joint, tuple(rows))


@dataclass(frozen=True)
class ModelExpressions:
    """Everything the templates print, in sympy form, already pruned to the spec."""

    spec: ModelSpec
    chain: ChainEquations
    forcing: sm.Matrix  # the chain's forcing, with F_f = 0 when friction is pruned
    tip: tuple[Named, ...]  # x_B, y_B, v_Bx, v_By, delta, delta_rate
    force_cases: tuple[ForceCase, ...]
    friction_force: sm.Expr | None  # F_f in terms of F and v_Bx (and slip, for exact Coulomb)
    friction_sign: sm.Expr | None  # s of F_f = -mu F s: regularized sign of v_Bx, or slip
    tip_jacobian: tuple[Named, ...]  # v_B = J_B u: rows Jx, Jy and the terms Jdot u
    events: tuple[Named, ...]
    outputs: tuple[Named, ...]
    works: tuple[Named, ...]  # power of each contact force: integrated as extra states
    params: tuple[Field, ...]  # the parameter struct, in order (codegen/parameters.py)
    jacobian: JacobianExpressions | None = None
    # each contact force itself, integrated as states after the works: the impulses
    # P_normal[, P_friction] that the impact coefficients are made of (docs/model.md section 9)
    impulses: tuple[Named, ...] = ()
    heights: tuple[Named, ...] = ()  # joints 1..n-1, then the tip: height above the surface (floor net)
    rate_gradient: tuple[sm.Expr, ...] = ()  # d(delta_rate)/d(q, u): the tip's normal acceleration
    joints: tuple[JointMotion, ...] = ()  # the joints that can touch the surface (spec.joints)

    @property
    def point_integrals(self) -> tuple[str, ...]:
        """The states after the impulses: each joint's own works and impulses, W_normal_J<k>[,
        W_friction_J<k>], P_normal_J<k>[, P_friction_J<k>] (W_normal and W_friction are every
        point's together, the budget's terms; P_normal and P_friction are the tip's own)."""
        kinds = ("normal", "friction") if self.spec.has_friction else ("normal",)
        return tuple(f"{integral}_{kind}_J{jm.joint}" for jm in self.joints for integral in ("W", "P")
                     for kind in kinds)

    @property
    def integrals(self) -> tuple[Named, ...]:
        """What is integrated beside q and u, in the state's order: the works, the impulses."""
        return self.works + self.impulses

    @property
    def phases(self) -> tuple[str, ...]:
        left_out = ({"elastoplastic"} if not self.spec.plastic else set()) | (
            {"sustained"} if not self.spec.sustained else set())
        return tuple(p for p in PHASES if p not in left_out)

    @property
    def state_names(self) -> tuple[str, ...]:
        s = self.chain.symbols
        return tuple(map(str, s.q + s.u)) + tuple(f"W_{w.name}" for w in self.works) + tuple(
            p.name for p in self.impulses) + self.point_integrals


@lru_cache(maxsize=32)
def assemble_model(spec: ModelSpec) -> ModelExpressions:
    """Pick and prune the expressions `spec` needs."""
    chain = chain_equations(spec.links)
    s = chain.symbols
    x_B, y_B = chain.tip_position
    v_Bx, v_By = chain.tip_velocity
    delta = law.delta
    tip = (
        Named("x_B", x_B, "tip position x, m"),
        Named("y_B", y_B, "tip position y, m"),
        Named("v_Bx", v_Bx, "tip velocity x, m/s"),
        Named("v_By", v_By, "tip velocity y, m/s"),
        Named("delta", y_s - y_B, "penetration, m"),
        Named("delta_rate", -v_By, "d(delta)/dt, m/s"),
    )

    cases = [ForceCase("elastic", sm.StrictGreaterThan(delta, 0), _single(law.hertz_force()),
                       "Hertz elastic compression (Eq. 9)")]
    if spec.plastic:
        cases.append(ForceCase("elastoplastic", sm.StrictGreaterThan(delta, 0),
                               law.jackson_green_steps(),
                               "Jackson-Green elasto-plastic compression (Eq. 10)"))
        cases.append(ForceCase("restitution", sm.StrictGreaterThan(delta, law.delta_r),
                               _single(law.restitution_force()),
                               "elastic restitution about the permanent deformation (Eq. 11)"))
    else:  # Hertz only: unloading follows the loading curve
        cases.append(ForceCase("restitution", sm.StrictGreaterThan(delta, 0), _single(law.hertz_force()),
                               "Hertz elastic restitution (Eq. 9 unloading)"))

    sign = None
    if spec.has_friction:
        sign = law.slip if spec.coulomb else law.s_frozen if spec.frozen else law.friction_sign(TIP["v_Bx"])
    friction_force = law.friction_force(s.F, sign) if sign is not None else None

    d, d_rate = TIP["delta"], TIP["delta_rate"]
    events = [
        Named("contact", d, "delta = 0: the tip reaches the undeformed surface"),
        Named("max_compression", d_rate, "d(delta)/dt = 0: maximum compression, or reloading"),
    ]
    if spec.plastic:
        events += [
            Named("yield", d - law.YIELD_ONSET * law.delta_c, "delta = 1.9 delta_c: onset of phase II"),
            Named("separation", d - law.delta_r, "delta = delta_r: the tip leaves the dented surface"),
        ]
    events.append(Named("passes_delta_m", d - delta_m, "delta = delta_m: reloading passes the maximum"))
    if spec.coulomb:
        events += [
            Named("slip_stops", TIP["v_Bx"], "v_Bx = 0: the slipping tip stops"),
            Named("slip_backward", law.mu * s.F - s.F_f, "F_f = mu F: the stuck tip starts to slip along -x"),
            Named("slip_forward", law.mu * s.F + s.F_f, "F_f = -mu F: the stuck tip starts to slip along +x"),
        ]
    if spec.sustained:
        events.append(Named("lift_off", s.F, "F = 0: the resting tip lifts off"))

    T = chain.kinetic_energy
    outputs = [Named(t.name, TIP[t.name], t.doc) for t in tip]
    outputs.append(Named("F", s.F, "normal contact force, N"))
    if spec.has_friction:
        outputs.append(Named("F_f", s.F_f, "friction force along x, N"))
    outputs += [Named(f"T{i + 1}", Ti, f"kinetic energy of link {i + 1}, J") for i, Ti in enumerate(T)]
    outputs.append(Named("T", sum(T), "kinetic energy, J"))
    outputs.append(Named("V", chain.potential_energy, "potential energy, J"))

    works = [Named("normal", s.F * TIP["v_By"], "power of the normal force, W")]
    if spec.has_friction:
        works.append(Named("friction", s.F_f * TIP["v_Bx"], "power of the friction force, W"))
    impulses = [Named("P_normal", s.F, "normal force: its integral is the normal impulse, N")]
    if spec.has_friction:
        impulses.append(Named("P_friction", s.F_f, "friction force: its integral is the tangential impulse, N"))

    used: set[sm.Symbol] = set(machine_symbols(spec))
    for e in [c.expr for c in cases] + [c.active for c in cases] + [e.expr for e in events] + [friction_force or 0]:
        used |= sm.sympify(e).free_symbols
    params = fields(spec.links, spec.friction_law, {str(x) for x in used}, spec.joints)

    forcing = chain.forcing if spec.has_friction else chain.forcing.subs(s.F_f, 0)
    jacobian = _jacobian(chain, forcing, tuple(cases), friction_force, tuple(works + impulses)) if spec.jacobian else None
    return ModelExpressions(spec, chain, forcing, tip, tuple(cases), friction_force, sign,
                            _tip_jacobian(chain) if spec.constrained else (), tuple(events),
                            tuple(outputs), tuple(works), params, jacobian, tuple(impulses), _heights(chain),
                            tuple(-v_By.diff(x) for x in s.q + s.u),
                            tuple(_joint_motion(chain, j) for j in spec.joints))


def _heights(chain: ChainEquations) -> tuple[Named, ...]:
    """The height above the surface of every point that can go under it: each joint between
    two links, then the tip (what the floor net of the run checks after every step)."""
    joints = [Named(f"joint{i + 1}", y - y_s, f"height of joint {i + 1} above the surface, m")
              for i, y in enumerate(chain.joint_y)]
    return tuple(joints) + (Named("tip", chain.tip_position[1] - y_s, "height of the tip above the surface, m"),)


def machine_symbols(spec: ModelSpec) -> tuple[sm.Symbol, ...]:
    """What the phase machine's switch laws read besides the force laws: E* and R for the
    contact scales and the unloading radius, delta_c for Eq. 12 and the yield onset."""
    return (law.E_star, law.R) + ((law.delta_c, law.delta_r, law.R_res) if spec.plastic else ())


def _tip_jacobian(chain: ChainEquations) -> tuple[Named, ...]:
    """v_B = J_B u and dv_B/dt = J_B du/dt + (dJ_B/dt) u: what a constraint on v_B needs.
    A tip force (F_x, F_y) enters Kane's equations as J_B^T (F_x, F_y)."""
    s = chain.symbols
    rows = []
    for k, (axis, v) in enumerate(zip("xy", chain.tip_velocity)):
        rows += [Named(f"J{axis}[{i}]", v.diff(u), f"dv_B{axis}/du{i + 1}") for i, u in enumerate(s.u)]
        rows.append(Named(f"Jdot_u[{k}]", sum(v.diff(q) * u for q, u in zip(s.q, s.u)),
                          f"(dJ_B{axis}/dt) u"))
    return tuple(rows)


def _jacobian(chain: ChainEquations, forcing: sm.Matrix, cases: tuple[ForceCase, ...],
              friction_force: sm.Expr | None, works: tuple[Named, ...]) -> JacobianExpressions:
    s = chain.symbols
    n = chain.n
    y = list(s.q) + list(s.u)
    udot = sm.symbols(f"udot1:{n + 1}")
    dF = sm.Symbol("dF")  # slope of the active normal-force law
    _, y_B = chain.tip_position
    v_Bx, v_By = chain.tip_velocity
    d_delta = [-y_B.diff(v) for v in y]
    dF_dy = [dF * d for d in d_delta]
    if friction_force is not None:
        dFf_dF, dFf_dv = friction_force.diff(s.F), friction_force.diff(TIP["v_Bx"])
        dFf_dy = [dFf_dF * a + dFf_dv * v_Bx.diff(v) for a, v in zip(dF_dy, y)]
    else:
        dFf_dy = [0] * len(y)
    M = chain.mass_matrix
    G = sm.zeros(n, 2 * n)
    for i in range(n):
        df_dF, df_dFf = forcing[i].diff(s.F), forcing[i].diff(s.F_f)
        for j, v in enumerate(y):
            dM_udot = sum(M[i, k].diff(v) * udot[k] for k in range(n)) if j < n else 0
            G[i, j] = forcing[i].diff(v) + df_dF * dF_dy[j] + df_dFf * dFf_dy[j] - dM_udot
    rows = []
    for w in works:  # power of each contact force: F v_By, F_f v_Bx; the forces themselves (impulses)
        if w.name == "P_normal":
            rows.append(list(dF_dy))
        elif w.name == "P_friction":
            rows.append(list(dFf_dy))
        elif w.name == "normal":
            rows.append([a * TIP["v_By"] + s.F * v_By.diff(v) for a, v in zip(dF_dy, y)])
        else:
            rows.append([a * TIP["v_Bx"] + s.F_f * v_Bx.diff(v) for a, v in zip(dFf_dy, y)])
    slopes = tuple((c.phase, sm.diff(c.expr, law.delta)) for c in cases)
    return JacobianExpressions(slopes, G, sm.Matrix(rows))
