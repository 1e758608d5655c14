"""Stage 5 of the pipeline: print the pruned expressions as C99 through Jinja2 templates.

The emitted model.h / model.c are plain C99: no globals, no Python, no SUNDIALS. Every
function takes the state and a `const` parameter struct, so the model can be compiled into
any simulator. Common subexpressions are eliminated per block; sin(q_i) and cos(q_i) are
computed once per call and named `sin_q1`, `cos_q1`, ... as in the equations.
"""
from __future__ import annotations

import dataclasses
import importlib.resources
import re
from dataclasses import dataclass
from functools import lru_cache

import jinja2
import sympy as sm
from sympy.printing.c import C99CodePrinter

from . import contact as law
from . import machine
from .expressions import TIP, ModelExpressions, assemble_model
from .parameters import RULES, Field
from .spec import BASE_POINT, PHASES, STATE_LAW, STATES, ModelSpec, point_name

PHASE_CODES = {name: code for code, name in enumerate(PHASES)}


def _c_double(value: float) -> str:
    """The shortest round-trip form of a double as a C literal: 0.92, not 0.920000...04."""
    text = repr(float(value))
    return text if any(c in text for c in ".en") else text + ".0"


class ModelCPrinter(C99CodePrinter):
    """C99 printer that writes the powers of contact mechanics without pow() where it can."""

    def _print_Float(self, expr: sm.Float) -> str:  # shortest round-trip form: 0.92, not 0.920000...04
        return _c_double(float(expr))

    def _print_Piecewise(self, expr: sm.Piecewise) -> str:  # one line: (c1 ? e1 : (c2 ? e2 : e3))
        *cases, (last, _) = expr.args
        text = self._print(last)
        for value, cond in reversed(cases):
            text = f"({self._print(cond)} ? {self._print(value)} : {text})"
        return text

    def _print_Pi(self, expr: sm.Expr) -> str:  # M_PI is not C99
        return "3.14159265358979323846"

    def _print_Pow(self, expr: sm.Pow) -> str:
        base, exp = expr.base, expr.exp
        b = self.parenthesize(base, sm.printing.precedence.PRECEDENCE["Mul"])
        if exp == sm.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        if exp == sm.Rational(3, 2):
            return f"({b}*sqrt({self._print(base)}))"
        if exp == -sm.Rational(1, 2):
            return f"(1.0/sqrt({self._print(base)}))"
        if exp.is_Integer and 2 <= int(exp) <= 4:
            return "(" + "*".join([b] * int(exp)) + ")"
        if exp == -1:
            return f"(1.0/{b})"
        if exp.is_Integer and -4 <= int(exp) <= -2:
            return "(1.0/(" + "*".join([b] * -int(exp)) + "))"
        return super()._print_Pow(expr)


_printer = ModelCPrinter()
CSE_OPTIMIZATIONS = None  # sympy's "basic" pre-pass costs more time than it saves operations


def ccode(expr: sm.Expr) -> str:
    return _printer.doprint(sm.sympify(expr))


@dataclass(frozen=True)
class CBlock:
    """Straight-line C: temporaries from CSE, then named results."""

    temps: tuple[tuple[str, str], ...]
    results: tuple[tuple[str, str], ...]
    reads: frozenset[str] = frozenset()  # names of the free symbols of its expressions


def _reads(exprs) -> frozenset[str]:
    """The names an expression list reads (its free symbols): what a C function must unpack."""
    return frozenset(str(x) for e in exprs for x in sm.sympify(e).free_symbols)


def c_block(named: list[tuple[str, sm.Expr]], tmp: str) -> CBlock:
    """CSE over `named` expressions; temporaries are called tmp0, tmp1, ..."""
    exprs = [sm.sympify(e) for _, e in named]
    replacements, reduced = sm.cse(exprs, symbols=sm.numbered_symbols(tmp), optimizations=CSE_OPTIMIZATIONS)
    return CBlock(tuple((str(s), ccode(e)) for s, e in replacements),
                  tuple((name, ccode(e)) for (name, _), e in zip(named, reduced)), _reads(exprs))


def _trig_names(n: int) -> dict[sm.Expr, sm.Symbol]:
    out: dict[sm.Expr, sm.Symbol] = {}
    for i in range(1, n + 1):
        q = sm.Symbol(f"q{i}")
        out[sm.sin(q)] = sm.Symbol(f"sin_q{i}")
        out[sm.cos(q)] = sm.Symbol(f"cos_q{i}")
    return out


@dataclass(frozen=True)
class GeneratedModel:
    """The emitted sources and what the runtime needs to know about them."""

    spec: ModelSpec
    prefix: str
    header: str  # model.h
    source: str  # model.c
    params_source: str  # model_params.c
    cdef: str  # declarations for cffi
    state_names: tuple[str, ...]
    output_names: tuple[str, ...]
    event_names: tuple[str, ...]
    param_names: tuple[str, ...]
    phases: tuple[str, ...]
    structure_hash: str

    def files(self) -> dict[str, str]:
        """File name -> text of every emitted source."""
        p = self.prefix
        return {f"{p}.h": self.header, f"{p}.c": self.source, f"{p}_params.c": self.params_source}


def _c_string(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')


def _range_test(f: Field, value: str) -> str:
    """The C condition that an input lies in its table range (finite in any case)."""
    row = f.row
    tests = [f"isfinite({value})"]
    if row.low != float("-inf"):
        tests.append(f"{value} {'>' if row.low_open else '>='} {_c_double(row.low)}")
    if row.high != float("inf"):
        tests.append(f"{value} {'<' if row.high_open else '<='} {_c_double(row.high)}")
    return " && ".join(tests)


def _templates() -> jinja2.Environment:
    root = importlib.resources.files("impactgen.templates")
    loader = jinja2.FunctionLoader(lambda name: (root / name).read_text(encoding="utf-8"))
    env = jinja2.Environment(loader=loader, undefined=jinja2.StrictUndefined,
                             keep_trailing_newline=True, trim_blocks=True, lstrip_blocks=True)
    env.filters.update(c_double=_c_double, c_string=_c_string, range_test=_range_test)
    env.globals.update(rules=RULES)  # the rules across inputs, printed into the start check
    return env


@dataclass(frozen=True)
class Kernel:
    """One C function body: what it unpacks (states, parameters, sin/cos) and its blocks."""

    q: tuple[tuple[int, str], ...]  # (index into y, name)
    params: tuple[tuple[str, str], ...]  # (name, where: "p" the struct, "pc" the point's record)
    trig: tuple[tuple[str, str, str, int], ...]  # (name, "sin"|"cos", angle, its slot in trig[])
    blocks: tuple[CBlock, ...]
    trig_only: frozenset[str] = frozenset()  # angles read only through their sin and cos


def _kernel(model: ModelExpressions, blocks: list[CBlock], extra: tuple = ()) -> Kernel:
    """What straight-line `blocks` (and the sympy expressions `extra` printed beside them)
    read, from their free symbols: the states, parameters and sin/cos to unpack, in order."""
    n = model.spec.links
    reads = set().union(*(b.reads for b in blocks), _reads(extra))
    trig = [(f"{fn}_q{i}", fn, f"q{i}", 2 * (i - 1) + (fn == "cos")) for i in range(1, n + 1)
            for fn in ("sin", "cos") if f"{fn}_q{i}" in reads]
    trig_only = frozenset(angle for _, _, angle, _ in trig) - reads
    reads |= trig_only
    names = list(map(str, model.chain.symbols.coordinates + model.chain.symbols.speeds))
    states = list(enumerate(names))  # q, (x_0, y_0,) u, (u_x0, u_y0)
    used_states = tuple((i, name) for i, name in states if name in reads)
    params = tuple((f.name, "p") for f in model.params if f.name in reads) + tuple(
        (f.name, "pc") for f in model.point_params if f.name in reads)
    return Kernel(used_states, params, tuple(trig), tuple(blocks), trig_only)


@dataclass(frozen=True)
class EmitContext:
    """Everything the templates print, typed: the model's kernels and blocks, its phase
    machine's tables and laws, and the names of both."""

    prefix: str
    spec: ModelSpec
    n: int  # links
    dof: int  # generalized coordinates: the links' angles, and a free chain's base point's two
    nstate: int
    state_names: tuple[str, ...]
    params: tuple[Field, ...]  # the parameter struct, in order
    point_params: tuple[Field, ...]  # each contact point's record, point[k]
    phases: list[tuple[str, int]]  # (PHASE name, params.phase code) of each force law
    events: list[dict]  # name (upper case), doc, C expression
    outputs: list[tuple[str, str]]  # (name, doc)
    kane: Kernel  # M (lower triangle) and f of Kane's equations, without contact forces
    friction: Kernel | None  # s and F_f of a point, in its own v_x and its view of the parameters
    constrained: bool  # a phase holds a point's velocity by a constraint force
    event_forces: bool  # the event functions read forces (solved with the accelerations)
    point_events: list[dict]  # each point's events: name, C expression in pt.* (its forces) and at.* (its view)
    points: list[dict]  # the contact points, joints then the tip: k, number, motion kernel, curvature kernel
    outputs_kernel: Kernel
    out_tip: CBlock
    energies: CBlock
    force_cases: list[dict]  # per force law: phase, doc, active condition, kernels
    jac: dict | None  # the analytic Jacobian's block, kernel, works count and accelerations read
    api_version: int
    structure_hash: str
    thresholds: tuple  # machine.THRESHOLDS
    all_states: tuple[str, ...]  # machine states, every model
    state_laws: list[tuple[str, str]]  # (machine state, force law) of this model's states
    material_inputs: tuple[str, ...]  # what the derived constants are computed from
    laws: machine.SwitchLaws
    param_names: list[str]
    cdef: bool = False  # rendering declarations for cffi (no string or float #defines)
    net: dict | None = None  # the floor net's heights and the start rule's normal acceleration
    joints: dict | None = None  # contact at the joints: motion kernels, friction, events, outputs
    point_fields: tuple[str, ...] = ()  # each contact point's outputs (MODEL_POINT_*)
    contact_points: tuple[dict, ...] = ()  # name, number, radius parameter, first event and outputs of each point
    event_points: tuple[int, ...] = ()  # the point (params.point[k]) each event is of

    @property
    def PREFIX(self) -> str:  # noqa: N802 (the C macros' spelling)
        return self.prefix.upper()

    def mapping(self, **changes) -> dict:
        """The template variables: every field, and PREFIX."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["PREFIX"] = self.PREFIX
        out["kind_code"] = KIND_CODE
        out.update(changes)
        return out


KIND_CODE = {"input": 0, "derived": 1, "machine": 2}  # model_param_kind() of each table kind


def _context(model: ModelExpressions, prefix: str) -> EmitContext:
    spec, chain = model.spec, model.chain
    n, dof = spec.links, spec.dof
    trig = _trig_names(n)

    def t(e: sm.Expr) -> sm.Expr:
        return sm.sympify(e).xreplace(trig)

    tip = {v.name: t(v.expr) for v in model.tip}

    # Kane's equations M du/dt = f without contact; each contact point adds J^T (F_f, F) in C
    M = chain.mass_matrix
    kane = c_block([(f"M[{i * dof + j}]", t(M[i, j])) for i in range(dof) for j in range(i + 1)]
                   + [(f"f[{i}]", t(model.forcing[i])) for i in range(dof)], "kin")
    friction = None
    if model.friction_force is not None:  # F_f = -mu F s in the point's own v_x, s kept by name for holds
        v_x, s_f = sm.Symbol("v_x"), sm.Symbol("s")
        sign = sm.sympify(model.friction_sign).xreplace({TIP["v_Bx"]: v_x})
        friction = _kernel(model, [c_block([("s", sign), ("F_f", model.friction_force.subs(model.friction_sign, s_f))],
                                          "fr")])
    points = []
    for k, pm in enumerate(model.points):
        motion = c_block([(f"m->{r.name}", t(r.expr)) for r in pm.motion], "pm")
        entry = {"k": k, "number": pm.number, "tip": pm.number == n, "kernel": _kernel(model, [motion])}
        if spec.jacobian:
            # the Jacobian is of the motion only (the works are quadratures): dv_y is not read
            curvature = c_block([(f"c->{r.name}", t(r.expr)) for r in pm.curvature if not r.name.startswith("dv_y")
                                 and (spec.has_friction or not r.name.startswith(("Hx", "dv_x")))], "pc")
            entry["curvature"] = _kernel(model, [curvature])
        points.append(entry)

    # Events: each point's, in its own quantities (pt, from point_at) and its view of the parameters (at)
    point_names = {f.name for f in model.point_params}
    names = {f.name for f in model.params} | point_names
    own = {TIP["delta"]: sm.Symbol("pt.delta"), TIP["delta_rate"]: sm.Symbol("pt.delta_rate"),
           TIP["v_Bx"]: sm.Symbol("pt.v_x"), chain.symbols.F: sm.Symbol("pt.F"),
           chain.symbols.F_f: sm.Symbol("pt.F_f")}
    events = [{"name": e.name.upper(), "doc": e.doc, "expr": ccode(e.expr)} for e in model.events]
    point_events = []
    for e in model.events:
        expr = sm.sympify(e.expr)
        view = {x: sm.Symbol(f"{'pc' if str(x) in point_names else 'p'}->{x}") for x in expr.free_symbols
                if str(x) in names}
        point_events.append({"name": e.name.upper(), "expr": ccode(expr.xreplace({**own, **view}))})
    event_forces = bool(_reads([e.expr for e in model.events]) & {"F", "F_f"})

    # Outputs: the tip's kinematics, the forces (point_at), the energies.
    out_tip = c_block([(v.name, tip[v.name]) for v in model.tip], "tip")
    tip_names = {v.name for v in model.tip} | {"F", "F_f"}
    energies = c_block([(o.name, t(o.expr)) for o in model.outputs if o.name not in tip_names], "en")

    force_cases = []
    slopes = dict(model.jacobian.force_slopes) if model.jacobian else {}
    for case in model.force_cases:
        block = CBlock((), tuple((str(name), ccode(e)) for name, e in case.steps), _reads([e for _, e in case.steps]))
        entry = {"phase": case.phase.upper(), "doc": case.doc, "active": ccode(case.active),
                 "kernel": _kernel(model, [block], (case.active,))}
        if case.phase in slopes:
            slope = c_block([("dF", slopes[case.phase])], "s")
            entry["slope_kernel"] = _kernel(model, [slope], (case.active,))
        force_cases.append(entry)

    jac = None
    if model.jacobian is not None:
        J = model.jacobian
        entries = [(f"G[{i * 2 * dof + j}]", t(J.G[i, j])) for i in range(dof) for j in range(2 * dof)]
        jac_block = c_block(entries, "jac")
        udot_used = [i for i in range(dof) if f"udot{i + 1}" in jac_block.reads]
        jac = {"kernel": _kernel(model, [jac_block]), "udot": udot_used,
               "friction": _kernel(model, [c_block([(r.name, r.expr) for r in J.friction_slopes], "fs")])
               if J.friction_slopes else None}

    params = model.params
    joints = _joints(model) if model.joints else None
    present = set(model.phases) | ({"reloading"} if "restitution" in model.phases else set())
    outputs = [(o.name, o.doc) for o in model.outputs] + (joints["outputs"] if joints else [])
    contact_points = _contact_points(model, [name for name, _ in outputs])
    return EmitContext(
        prefix=prefix, spec=spec, n=n, dof=dof, nstate=len(model.state_names), state_names=model.state_names,
        params=model.params, point_params=model.point_params, phases=[(p.upper(), PHASE_CODES[p]) for p in model.phases], events=events,
        outputs=outputs,
        kane=_kernel(model, [kane]), friction=friction, constrained=spec.constrained,
        event_forces=event_forces, point_events=point_events, points=points,
        outputs_kernel=_kernel(model, [out_tip, energies]), out_tip=out_tip, energies=energies,
        force_cases=force_cases, jac=jac,
        api_version=machine.API_VERSION, structure_hash=machine.structure_hash(model),
        thresholds=machine.THRESHOLDS, all_states=STATES,
        state_laws=[(s, STATE_LAW[s]) for s in STATES if s in present],
        material_inputs=tuple(str(x) for x in law.MATERIAL_INPUTS), laws=machine.switch_laws(model, ccode),
        param_names=[f.name for f in params],
        net=_net(model, t),
        joints=joints,
        point_fields=tuple(o for o, _ in POINT_OUTPUTS),
        contact_points=contact_points,
        event_points=_event_points(contact_points, len(model.events)),
    )


# What a joint's contact adds to the model, per joint: its outputs (the tip's are named x_B,
# delta, F, ...).
POINT_OUTPUTS = (("delta", "penetration, m"), ("delta_rate", "d(delta)/dt, m/s"), ("v_x", "velocity x, m/s"),
                 ("v_y", "velocity y, m/s"), ("F", "normal contact force, N"), ("F_f", "friction force along x, N"))


def _joints(model: ModelExpressions) -> dict:
    """The joints that can touch the surface, as the headers and the machine name them: their
    numbers, their contact fields and constants in the parameters, and their outputs."""
    spec = model.spec
    return {"joints": [jm.number for jm in model.joints],
            "motion": [{"k": k, "joint": jm.number} for k, jm in enumerate(model.joints)],
            "outputs": [(f"{o}_J{j}", f"joint {j}: {doc}") for j in spec.joints for o, doc in POINT_OUTPUTS],
            "point_fields": [o for o, _ in POINT_OUTPUTS],
            "output_names": {f"{o}_J{j}" for j in spec.joints for o, _ in POINT_OUTPUTS}}


# The tip's outputs of the fields of POINT_OUTPUTS (a joint's are named <field>_J<joint>).
TIP_OUTPUTS = ("delta", "delta_rate", "v_Bx", "v_By", "F", "F_f")


def _contact_points(model: ModelExpressions, output_names: list[str]) -> tuple[dict, ...]:
    """Each contact point in the order of params.point[k] (the joints, then the tip): its name,
    the parameter of its contact radius, and where each of its POINT_OUTPUTS sits among the
    outputs (-1: not computed, the friction force of a model without friction)."""
    n = model.spec.links
    points = []
    for pm in model.points:
        if pm.number == n:
            name, radius, names = "tip", "R_tip", TIP_OUTPUTS
        else:
            name = point_name(pm.number, n)
            radius = "R_base" if pm.number == BASE_POINT else f"R_joint{pm.number}"
            names = tuple(f"{o}_J{pm.number}" for o, _ in POINT_OUTPUTS)
        first_event = len(model.events) * (0 if pm.number == n else 1 + model.spec.joints.index(pm.number))
        points.append({"name": name, "radius": radius, "number": pm.number, "first_event": first_event,
                       "outputs": [output_names.index(o) if o in output_names else -1 for o in names]})
    return tuple(points)


def _event_points(contact_points: tuple[dict, ...], per_point: int) -> tuple[int, ...]:
    """The point (params.point[k]) each event is of: point k's `per_point` events start at its
    first_event."""
    owner = [0] * (per_point * len(contact_points))
    for k, point in enumerate(contact_points):
        owner[point["first_event"]:point["first_event"] + per_point] = [k] * per_point
    return tuple(owner)


def _net(model: ModelExpressions, t) -> dict:
    """The heights above the surface of the joints and the tip (the floor net), as a block
    with what it unpacks."""
    heights = c_block([(f"h[{k}]", t(h.expr)) for k, h in enumerate(model.heights)], "ht")
    return {"points": [h.name for h in model.heights], "heights": heights,
            "heights_kernel": _kernel(model, [heights])}


def _tidy(text: str) -> str:
    """Strip trailing blanks and collapse runs of empty lines left by the templates."""
    lines = [line.rstrip() for line in text.splitlines()]
    out: list[str] = []
    for line in lines:
        if line or (out and out[-1]):
            out.append(line)
    return "\n".join(out).strip("\n") + "\n"


@lru_cache(maxsize=32)
def generate_model(spec: ModelSpec, prefix: str = "model") -> GeneratedModel:
    """Emit model.h, model.c and the cffi declarations for `spec`."""
    if not prefix.isidentifier() or not prefix.isascii():
        raise ValueError(f"prefix {prefix!r} is not a C identifier")
    model = assemble_model(spec)
    context = _context(model, prefix)
    ctx = context.mapping()
    env = _templates()
    return GeneratedModel(
        spec=spec,
        prefix=prefix,
        header=_tidy(env.get_template("model.h.j2").render(ctx)),
        source=_tidy(env.get_template("model.c.j2").render(ctx) + env.get_template("model_jacobian.c.j2").render(ctx)),
        params_source=_tidy(env.get_template("model_params.c.j2").render(ctx)),
        cdef=_tidy(env.get_template("cdef.h.j2").render(context.mapping(cdef=True))),
        state_names=model.state_names,
        output_names=tuple(name for name, _ in context.outputs),
        event_names=tuple(e.name for e in model.events) + tuple(
            f"{e.name}_J{j}" for j in spec.joints for e in model.events),
        param_names=tuple(f.name for f in model.params),
        phases=model.phases,
        structure_hash=context.structure_hash,
    )


def generate_scene_header(gen: GeneratedModel, scene) -> str:
    """`<prefix>_scene.h`: one scene's inputs, initial state and solver settings as C, for
    drivers built beside the model (the model's own C holds no numbers)."""
    inputs = [f for f in assemble_model(gen.spec).params if f.row.kind == "input"]
    ctx = {"prefix": gen.prefix, "PREFIX": gen.prefix.upper(), "spec": gen.spec, "scene": scene,
           "inputs": inputs, "method_name": f"IG_METHOD_{scene.solver.method.upper()}"}
    return _tidy(_templates().get_template("scene.h.j2").render(ctx))


# The runtime's phase machine, written once for every model, and the root rule it includes.
MACHINE_FILES = ("model_machine.h", "model_machine_points.h", "model_machine.c", "model_stick_slip.c", "roots.h")


def machine_files(prefix: str) -> dict[str, str]:
    """The runtime's phase machine for a model of this prefix: its files with every model_ and
    MODEL_ name given the prefix (<prefix>_machine.h, <prefix>_machine.c, ...), and roots.h as
    it is, so that a folder of generated C builds on its own."""
    native = importlib.resources.files("impactgen") / "native"
    files = {}
    for name in MACHINE_FILES:
        text = (native / name).read_text(encoding="utf-8")
        if name.startswith("model_"):
            text = re.sub(r"\bmodel_", f"{prefix}_", text)
            text = re.sub(r"\bMODEL_", f"{prefix.upper()}_", text)
            text = text.replace('#include "model.h"', f'#include "{prefix}.h"')
            name = name.replace("model_", f"{prefix}_", 1)
        files[name] = text
    return files


def driver_files(gen: GeneratedModel, scene) -> dict[str, str]:
    """File name -> text of a folder a C driver builds from: the model, its phase machine and
    `<prefix>_scene.h` with the scene's numbers (what `impactgen generate` writes)."""
    return {**gen.files(), **machine_files(gen.prefix), f"{gen.prefix}_scene.h": generate_scene_header(gen, scene)}


__all__ = ["GeneratedModel", "generate_model", "ccode", "ModelCPrinter"]
