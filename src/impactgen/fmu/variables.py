"""The FMU's variables, in the scene's own vocabulary, from the parameter table and the model.

One list drives the C variable table (model_fmu.h) and modelDescription.xml, so a value
reference means the same thing on both sides. Parameters are the scene's inputs
(`chain.length[1]`, `rod.E`, `contact.friction`, `initial.u[2]`, ...); the continuous states
are `q[i]`, `u[i]`, the works `W_normal`, `W_friction` and the impulses `P_normal`,
`P_friction`; the outputs are the tip's
penetration, forces and speeds and the energies, and the machine's discrete outputs.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..codegen.expressions import ModelExpressions
from ..codegen.parameters import Field

# kinds the C glue reads and writes (fmi2_glue.c: enum var_kind)
KINDS = ("param", "q0", "u0", "state", "der", "output", "phase", "impacts", "delta_max", "delta_r", "P_max")


@dataclass(frozen=True)
class Variable:
    vr: int
    name: str
    type: str  # "Real" | "Integer" | "Boolean"
    causality: str  # "parameter" | "local" | "output"
    variability: str  # "fixed" | "continuous" | "discrete"
    initial: str | None  # "exact" | "calculated" | None (not allowed)
    start: float | None
    unit: str
    description: str
    kind: str  # one of KINDS
    index: int  # struct field, state, output or link index, by kind
    derivative_of: int | None = None  # vr of the state, for a derivative


def variables(model: ModelExpressions, scene) -> list[Variable]:
    """Every FMU variable of `model`, with start values from `scene`."""
    n = model.spec.links
    out: list[Variable] = []

    def add(**kw) -> Variable:
        v = Variable(vr=len(out), **kw)
        out.append(v)
        return v

    states = []
    for k, name in enumerate(model.state_names):
        label = f"{name[0]}[{name[1:]}]" if k < 2 * n else name
        impulse = k >= 2 * n and name.startswith("P_")
        unit = "rad" if k < n else ("rad/s" if k < 2 * n else "N.s" if impulse else "J")
        doc = (f"absolute angle of link {k + 1}" if k < n else
               f"angular speed of link {k - n + 1}" if k < 2 * n else
               f"impulse of the {name[2:]} force" if impulse else f"work of the {name[2:]} force")
        states.append(add(name=label, type="Real", causality="local", variability="continuous",
                          initial="calculated" if k < 2 * n else "exact", start=None if k < 2 * n else 0.0,
                          unit=unit, description=doc, kind="state", index=k))
    for k, s in enumerate(states):
        unit = {"rad": "rad/s", "rad/s": "rad/s2", "J": "W", "N.s": "N"}[s.unit]
        add(name=f"der({s.name})", type="Real", causality="local", variability="continuous",
            initial="calculated", start=None, unit=unit, description=f"time derivative of {s.name}",
            kind="der", index=k, derivative_of=s.vr)
    outputs = {o.name: (k, o.doc) for k, o in enumerate(model.outputs)}
    shown = [("delta", "delta"), ("F", "F"), ("F_f", "F_f"), ("v_B[1]", "v_Bx"), ("v_B[2]", "v_By")]
    shown += [(f"T[{i}]", f"T{i}") for i in range(1, n + 1)] + [("T", "T"), ("V", "V")]
    for label, name in shown:
        if name in outputs:
            k, doc = outputs[name]
            text, _, unit = doc.rpartition(", ")
            add(name=label, type="Real", causality="output", variability="continuous", initial="calculated",
                start=None, unit=unit, description=text, kind="output", index=k)
    add(name="phase", type="Integer", causality="output", variability="discrete", initial="calculated",
        start=None, unit="", description="machine state: 0 free, 1 elastic, 2 elastoplastic, 3 restitution, "
        "4 reloading, 5 sustained", kind="phase", index=0)
    add(name="impacts", type="Integer", causality="output", variability="discrete", initial="calculated",
        start=None, unit="", description="impacts begun so far", kind="impacts", index=0)
    for name, unit, doc in (("delta_max", "m", "maximum compression of the last impact"),
                            ("delta_r", "m", "permanent deformation of the last impact (Eq. 12)"),
                            ("P_max", "N", "normal force at the last maximum compression")):
        add(name=name, type="Real", causality="output", variability="discrete", initial="calculated",
            start=None, unit=unit, description=doc, kind=name, index=0)
    for k, f in enumerate(model.params):
        if f.row.kind == "input":
            add(name=f.key, type=f.row.fmi_type, causality="parameter", variability="fixed", initial="exact",
                start=f.read(scene), unit=_unit(f), description=f.doc, kind="param", index=k)
    for i in range(n):
        add(name=f"initial.q[{i + 1}]", type="Real", causality="parameter", variability="fixed",
            initial="exact", start=float(scene.q0[i]), unit="rad", description=f"q{i + 1} at the start",
            kind="q0", index=i)
    for i in range(n):
        add(name=f"initial.u[{i + 1}]", type="Real", causality="parameter", variability="fixed",
            initial="exact", start=float(scene.u0[i]), unit="rad/s", description=f"u{i + 1} at the start",
            kind="u0", index=i)
    return out


def _unit(f: Field) -> str:
    return "" if f.row.unit in ("", "1") else f.row.unit


# SI base-unit exponents of every unit a variable can carry (modelDescription's UnitDefinitions)
UNITS = {"rad": {"rad": 1}, "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2},
         "J": {"kg": 1, "m": 2, "s": -2}, "W": {"kg": 1, "m": 2, "s": -3}, "m": {"m": 1},
         "m/s": {"m": 1, "s": -1}, "m/s2": {"m": 1, "s": -2}, "N": {"kg": 1, "m": 1, "s": -2},
         "kg": {"kg": 1}, "Pa": {"kg": 1, "m": -1, "s": -2}, "N.s": {"kg": 1, "m": 1, "s": -1}}
