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
from .parameters import Field, fields, point_fields
from .spec import BASE_POINT, PHASES, ModelSpec, point_name

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
    """d(ydot)/dy of the chain without its contact forces, and the slopes of the force laws;
    each contact point's forces are added by the chain rule in C, from its PointMotion."""

    force_slopes: tuple[tuple[str, sm.Expr], ...]  # (phase, dF/d(delta))
    G: sm.Matrix  # d(f0)/dy - (dM/dy) udot, f0 the forcing without contact; dof x 2 dof, udot_k solved first
    friction_slopes: tuple[Named, ...] = ()  # dFf_dF, dFf_dv: F_f's derivatives over F and the point's v_x


@dataclass(frozen=True)
class PointMotion:
    """A contact point (joint k, the end of link k, or the tip as point n): its height and
    velocity, the rows of its velocity Jacobian v = J u with the terms (dJ/dt) u, and, for the
    analytic Jacobian, the derivatives of J and of v over the angles. A force (F_x, F_y) on it
    enters Kane's equations as J^T (F_x, F_y), whichever point it is."""

    number: int  # 0: a free chain's base point; 1 to n - 1: a joint; n: the tip
    motion: tuple[Named, ...]  # y, v_x, v_y, Jx[i], Jy[i], Jdot_u[0] (x), Jdot_u[1] (y)
    curvature: tuple[Named, ...] = ()  # the nonzero Hx[i n + j] = dJx_i/dq_j, Hy[..], dv_x[j] = dv_x/dq_j, dv_y[j]


def _point_position(chain: ChainEquations, number: int) -> tuple[sm.Expr, sm.Expr]:
    """Where contact point `number` is: the base point (0, a free chain's), joint k, the tip (n)."""
    if number == chain.n:
        return chain.tip_position
    if number == BASE_POINT:
        return chain.symbols.base_q
    return chain.joint_x[number - 1], chain.joint_y[number - 1]


def _point_motion(chain: ChainEquations, number: int) -> PointMotion:
    s = chain.symbols
    n = chain.n
    x, y = _point_position(chain, number)
    coordinates, speeds = s.coordinates, s.speeds
    v = [sum(r.diff(q) * u for q, u in zip(coordinates, speeds)) for r in (x, y)]
    what = point_name(number, n).replace("tip", "the tip")
    rows = [Named("y", y, f"height of {what}, m"),
            Named("v_x", v[0], "its velocity x, m/s"), Named("v_y", v[1], "its velocity y, m/s")]
    for axis, vel in zip("xy", v):
        rows += [Named(f"J{axis}[{i}]", vel.diff(u), f"dv_{axis}/d{u}") for i, u in enumerate(speeds)]
    rows += [Named(f"Jdot_u[{k}]", sum(vel.diff(q) * u for q, u in zip(coordinates, speeds)), f"(dJ_{axis}/dt) u")
             for k, (axis, vel) in enumerate(zip("xy", v))]
    curvature = []
    dof = len(coordinates)
    for axis, vel in zip("xy", v):
        curvature += [Named(f"H{axis}[{i * dof + j}]", vel.diff(u).diff(q), f"dJ{axis}_{i}/d{q}")
                      for i, u in enumerate(speeds) for j, q in enumerate(coordinates)]
        curvature += [Named(f"dv_{axis}[{j}]", vel.diff(q), f"dv_{axis}/d{q}") for j, q in enumerate(coordinates)]
    return PointMotion(number, tuple(rows), tuple(c for c in curvature if c.expr != 0))


@dataclass(frozen=True)
class ModelExpressions:
    """Everything the templates print, in sympy form, already pruned to the spec."""

    spec: ModelSpec
    chain: ChainEquations
    forcing: sm.Matrix  # the chain's forcing without contact forces (each point adds J^T F in C)
    tip: tuple[Named, ...]  # x_B, y_B, v_Bx, v_By, delta, delta_rate
    force_cases: tuple[ForceCase, ...]
    friction_force: sm.Expr | None  # F_f in terms of F and v_Bx (and slip, for exact Coulomb)
    friction_sign: sm.Expr | None  # s of F_f = -mu F s: regularized sign of v_Bx, or slip
    events: tuple[Named, ...]
    outputs: tuple[Named, ...]
    works: tuple[Named, ...]  # power of each contact force: integrated as extra states
    params: tuple[Field, ...]  # the parameter struct, in order (codegen/parameters.py)
    jacobian: JacobianExpressions | None = None
    # each contact force itself, integrated as states after the works: the impulses
    # P_normal[, P_friction] that the impact coefficients are made of (docs/model.md section 9)
    impulses: tuple[Named, ...] = ()
    heights: tuple[Named, ...] = ()  # joints 1..n-1, then the tip: height above the surface (floor net)
    points: tuple[PointMotion, ...] = ()  # the contact points: the joints that can touch the surface, then the tip
    point_params: tuple[Field, ...] = ()  # the fields of each point's record, point[k]

    @property
    def joints(self) -> tuple[PointMotion, ...]:
        """The joints with contact code (spec.joints): every contact point but the tip."""
        return self.points[:-1]

    @property
    def point_integrals(self) -> tuple[str, ...]:
        """The states after the impulses: each joint's own works and impulses, W_normal_J<k>[,
        W_friction_J<k>], P_normal_J<k>[, P_friction_J<k>] (W_normal and W_friction are every
        point's together, the budget's terms; P_normal and P_friction are the tip's own)."""
        kinds = ("normal", "friction") if self.spec.has_friction else ("normal",)
        return tuple(f"{integral}_{kind}_J{jm.number}" for jm in self.joints for integral in ("W", "P")
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
        return tuple(map(str, s.coordinates + s.speeds)) + tuple(f"W_{w.name}" for w in self.works) + tuple(
            p.name for p in self.impulses) + self.point_integrals


@lru_cache(maxsize=32)
def assemble_model(spec: ModelSpec) -> ModelExpressions:
    """Pick and prune the expressions `spec` needs."""
    chain = chain_equations(spec.links, spec.free, spec.inclined)
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

    cases = _force_cases(spec)
    sign = None
    if spec.has_friction:
        sign = law.slip if spec.coulomb else law.s_frozen if spec.frozen else law.friction_sign(TIP["v_Bx"])
    friction_force = law.friction_force(s.F, sign) if sign is not None else None

    d, d_rate = TIP["delta"], TIP["delta_rate"]
    events = [
        Named("contact", d, "delta = 0: the tip reaches the undeformed surface"),
        Named("max_compression", d_rate, "d(delta)/dt = 0: maximum compression, or reloading"),
    ]
    if spec.contact_model == "thornton":
        events.append(Named("yield", d - law.delta_y, "delta = delta_y: the contact pressure reaches p_y"))
    elif spec.plastic:
        events.append(Named("yield", d - law.YIELD_ONSET * law.delta_c, "delta = 1.9 delta_c: onset of phase II"))
    if spec.plastic:
        events.append(Named("separation", d - law.delta_r, "delta = delta_r: the tip leaves the dented surface"))
    elif spec.rate_law:  # watched in free flight: back where a damped law let go while penetrating
        events.append(Named("separation", d - law.delta_r, "delta = delta_r: where the tip let go of the surface"))
    events.append(Named("passes_delta_m", d - delta_m, "delta = delta_m: reloading passes the maximum"))
    if spec.rate_law:
        events.append(Named("force_zero", law.force_zero(spec.contact_model),
                            "the damped force falls to 0: the tip leaves the surface while penetrating"))
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

    used: set[sm.Symbol] = (set(machine_symbols(spec)) | ({s.alpha} if spec.inclined else set())
                            | set(law.LAW_INPUTS.get(spec.contact_model, ())))
    for e in [c.expr for c in cases] + [c.active for c in cases] + [e.expr for e in events] + [friction_force or 0]:
        used |= sm.sympify(e).free_symbols
    params = fields(spec.links, spec.friction_law, {str(x) for x in used}, spec.joints,
                    base=BASE_POINT in spec.joints)
    point_params = point_fields(spec.friction_law, {str(x) for x in used})

    forcing = chain.forcing.subs({s.F: 0, s.F_f: 0})  # gravity and the motion; contact enters per point
    jacobian = _jacobian(chain, forcing, tuple(cases), friction_force) if spec.jacobian else None
    return ModelExpressions(spec, chain, forcing, tip, tuple(cases), friction_force, sign, tuple(events),
                            tuple(outputs), tuple(works), params, jacobian, tuple(impulses), _heights(chain, spec),
                            tuple(_point_motion(chain, k) for k in (*spec.joints, spec.links)), point_params)


def _force_cases(spec: ModelSpec) -> list[ForceCase]:
    """The normal force in each phase of the scene's law (contact.model): only that law's."""
    positive = sm.StrictGreaterThan(law.delta, 0)
    if spec.contact_model in ("three-phase", "thornton"):
        if spec.contact_model == "thornton":
            loading = ForceCase("elastoplastic", positive, _single(law.thornton_loading()),
                                "Thornton's plastic loading at the limiting pressure p_y")
        else:
            loading = ForceCase("elastoplastic", positive, law.jackson_green_steps(),
                                "Jackson-Green elasto-plastic compression (Eq. 10)")
        return [ForceCase("elastic", positive, _single(law.hertz_force()), "Hertz elastic compression (Eq. 9)"),
                loading,
                ForceCase("restitution", sm.StrictGreaterThan(law.delta, law.delta_r),
                          _single(law.restitution_force()),
                          "elastic restitution about the permanent deformation (Eq. 11)")]
    if spec.rate_law:
        force = law.kelvin_voigt_force() if spec.contact_model == "kelvin-voigt" else law.damped_hertz_force()
        what = f"the {spec.contact_model} law"
        # the dashpot acts from the instant of contact (delta = 0): F jumps to c v0 there
        touching = sm.GreaterThan(law.delta, 0) if spec.contact_model == "kelvin-voigt" else positive
        return [ForceCase("elastic", touching, _single(force), f"{what}, compression"),
                ForceCase("restitution", touching, _single(force), f"{what}, restitution")]
    # Hertz only: unloading follows the loading curve
    return [ForceCase("elastic", positive, _single(law.hertz_force()), "Hertz elastic compression (Eq. 9)"),
            ForceCase("restitution", positive, _single(law.hertz_force()), "Hertz elastic restitution (Eq. 9 unloading)")]


def _heights(chain: ChainEquations, spec: ModelSpec) -> tuple[Named, ...]:
    """The height above the surface of every point that can go under it: each joint between
    two links, then the tip, then a free chain's base point (what the floor net of the run
    checks after every step, by the point's number: h[k - 1], the base's at h[n])."""
    joints = [Named(f"joint{i + 1}", y - y_s, f"height of joint {i + 1} above the surface, m")
              for i, y in enumerate(chain.joint_y)]
    base = (Named("base", chain.symbols.base_q[1] - y_s, "height of the base point above the surface, m"),) \
        if spec.free else ()
    return tuple(joints) + (Named("tip", chain.tip_position[1] - y_s, "height of the tip above the surface, m"),) + base


def machine_symbols(spec: ModelSpec) -> tuple[sm.Symbol, ...]:
    """What the phase machine's switch laws read besides the force laws: E* and R for the
    contact scales and the unloading radius, delta_c for Eq. 12 and the yield onset (Thornton's
    delta_y, F_y and k_y for his); a damped law's v0 and the depth it let go at."""
    if spec.contact_model == "thornton":
        return (law.E_star, law.R, law.delta_r, law.R_res, law.delta_y, law.F_y, law.k_y)
    return (law.E_star, law.R) + ((law.delta_c, law.delta_r, law.R_res) if spec.plastic else ()) + (
        (law.v_0, law.delta_r) if spec.rate_law else ())


def _jacobian(chain: ChainEquations, forcing: sm.Matrix, cases: tuple[ForceCase, ...],
              friction_force: sm.Expr | None) -> JacobianExpressions:
    """G = d(f0)/dy - (dM/dy) udot of the chain without contact, the slope of each force law
    and F_f's derivatives: what the chain rule through each point's forces needs."""
    s = chain.symbols
    dof = chain.dof  # the angles, and a free chain's base point (x_0, y_0)
    y = list(s.coordinates) + list(s.speeds)
    udot = sm.symbols(f"udot1:{dof + 1}")
    M = chain.mass_matrix
    G = sm.zeros(dof, 2 * dof)
    for i in range(dof):
        for j, v in enumerate(y):
            dM_udot = sum(M[i, k].diff(v) * udot[k] for k in range(dof)) if j < dof else 0
            G[i, j] = forcing[i].diff(v) - dM_udot
    slopes = tuple((c.phase, sm.diff(c.expr, law.delta)) for c in cases)
    friction = ()
    if friction_force is not None:  # in the point's own v_x
        v_x = sm.Symbol("v_x")
        F_f = friction_force.xreplace({TIP["v_Bx"]: v_x})
        friction = (Named("dFf_dF", F_f.diff(s.F), "dF_f/dF"), Named("dFf_dv", F_f.diff(v_x), "dF_f/dv_x"))
    return JacobianExpressions(slopes, G, friction)
