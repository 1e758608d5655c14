"""The FMU's variables, in the scene's own vocabulary, from the parameter table and the model.

One list drives the C variable table (model_fmu.h) and modelDescription.xml, so a value
reference means the same thing on both sides. Parameters are the scene's inputs
(`chain.length[1]`, `rod.E`, `contact.friction`, `initial.u[2]`, ...); the continuous states
are `q[i]`, `u[i]`, the works `W_normal`, `W_friction` and the impulses `P_normal`,
`P_friction`; the outputs are the tip's
penetration, forces and speeds and the energies, and the machine's discrete outputs. A model
with contact at joints (ModelSpec.joints) has the same per point, in FMI 2.0's structured
naming: `contact[2].delta`, `contact[2].F`, ... and `contact[2].phase`, `contact[2].impacts`,
`contact[2].delta_max`, ... for joint 2 (the end of link 2); the tip's keep their names.
Last come the run's two summaries, as `impactgen run` and the sweep name their fields:
`first_impact.delta_r`, `first_impact.coefficients.e_N`, `run.impacts`, `run.u_final[2]`, ...
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import get_type_hints

from ..codegen.emit import POINT_OUTPUTS
from ..codegen.expressions import ModelExpressions
from ..codegen.parameters import Field
from ..codegen.spec import point_name
from ..impacts import COEFFICIENTS
from ..records import Tallied
from ..summaries import ENERGY_TERMS, PER_POINT, SUMMARY_LATER, SUMMARY_LEADING, chain_points, summary_unit

# kinds the C glue reads and writes (native/fmi2: enum var_kind in model_fmu.h)
KINDS = ("param", "q0", "u0", "state", "der", "output", "phase", "impacts", "delta_max", "delta_r", "P_max",
         "run", "first_impact")


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
    index: int  # struct field, state, output or link index, by kind; a discrete output's point
    # (0 the tip, k + 1 the joint in slot k of the machine's joints)
    derivative_of: int | None = None  # vr of the state, for a derivative
    member: str | None = None  # a summary's field of ig_summary (tally.h); index: the entry of an array field

    @property
    def c_index(self) -> str:
        """The index in the C table: a summary field's byte offset in ig_summary, else `index`."""
        if self.member is None:
            return str(self.index)
        entry = f"[{self.index}]" if self.member in ARRAY_MEMBERS else ""
        return f"(int)offsetof(ig_summary, {self.member}{entry})"


DISCRETE = (("delta_max", "m", "maximum compression of {of} last impact"),
            ("delta_r", "m", "permanent deformation of {of} last impact (Eq. 12)"),
            ("P_max", "N", "normal force at {of} last maximum compression"))


def _state(k: int, name: str, n: int, dof: int) -> dict:
    """The name, unit and description of state k (`name` as the model calls it) of a model of
    n links and dof coordinates: the angles, a free chain's base point (x_0, y_0, as
    base[1], base[2]), their rates, then the works and impulses (a joint's own as contact[j].*)."""
    if k < 2 * dof:
        rate = k >= dof
        i = k - dof if rate else k
        if i < n:
            return {"name": f"{name[0]}[{name[1:]}]", "unit": "rad/s" if rate else "rad",
                    "description": f"angular speed of link {i + 1}" if rate else f"absolute angle of link {i + 1}"}
        axis = "xy"[i - n]
        return {"name": f"base_velocity[{i - n + 1}]" if rate else f"base[{i - n + 1}]", "unit": "m/s" if rate else "m",
                "description": f"the base point's {'velocity ' if rate else ''}{axis}"}
    impulse = name.startswith("P_")
    if "_J" in name:  # a joint's own work or impulse, W_normal_J2: contact[2].W_normal
        kind, joint = name.rsplit("_J", 1)
        where = "the base point" if joint == "0" else f"joint {joint}"
        return {"name": f"contact[{joint}].{kind}", "unit": "N.s" if impulse else "J",
                "description": f"{'impulse' if impulse else 'work'} of the {kind[2:]} force at {where}"}
    return {"name": name, "unit": "N.s" if impulse else "J",
            "description": f"impulse of the {name[2:]} force" if impulse else f"work of the {name[2:]} force"}


def variables(model: ModelExpressions, scene, output_names: tuple[str, ...] = ()) -> list[Variable]:
    """Every FMU variable of `model`, with start values from `scene`. `output_names`: the
    generated model's outputs in C order (GeneratedModel.output_names), the joints' after
    the tip's; without it, only the tip's are shown."""
    n = model.spec.links
    joints = model.spec.joints
    out: list[Variable] = []

    def add(**kw) -> Variable:
        v = Variable(vr=len(out), **kw)
        out.append(v)
        return v

    states = []
    dof = model.spec.dof
    for k, name in enumerate(model.state_names):
        states.append(add(**_state(k, name, n, dof), type="Real", causality="local", variability="continuous",
                          initial="calculated" if k < 2 * dof else "exact", start=None if k < 2 * dof else 0.0,
                          kind="state", index=k))
    for k, s in enumerate(states):
        unit = {"rad": "rad/s", "rad/s": "rad/s2", "m": "m/s", "m/s": "m/s2", "J": "W", "N.s": "N"}[s.unit]
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
    c_index = {name: k for k, name in enumerate(output_names)}
    for j in joints:
        for point, doc in POINT_OUTPUTS:
            if f"{point}_J{j}" in c_index:
                text, _, unit = doc.rpartition(", ")
                add(name=f"contact[{j}].{point}", type="Real", causality="output", variability="continuous",
                    initial="calculated", start=None, unit=unit, description=f"{point_name(j, n)}: {text}", kind="output",
                    index=c_index[f"{point}_J{j}"])
    # the machine's discrete outputs, per point: the tip's (index 0), then each joint's (its slot + 1)
    points = [(0, "", "the tip's" if joints else "the")] + [
        (slot + 1, f"contact[{j}].", f"{point_name(j, n)}'s") for slot, j in enumerate(joints) if f"delta_J{j}" in c_index]
    for point, prefix, of in points:
        whose = "" if of == "the" else f"{of} "
        add(name=f"{prefix}phase", type="Integer", causality="output", variability="discrete",
            initial="calculated", start=None, unit="", description=f"{whose}machine state: 0 free, 1 elastic, "
            "2 elastoplastic, 3 restitution, 4 reloading, 5 sustained", kind="phase", index=point)
        add(name=f"{prefix}impacts", type="Integer", causality="output", variability="discrete",
            initial="calculated", start=None, unit="", description=f"{whose}impacts begun so far", kind="impacts",
            index=point)
        for name, unit, doc in DISCRETE:
            add(name=f"{prefix}{name}", type="Real", causality="output", variability="discrete",
                initial="calculated", start=None, unit=unit, description=doc.format(of=of), kind=name, index=point)
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
    if model.spec.free:  # the base point's start: after the angles in q0, after their rates in u0
        for i, axis in enumerate("xy"):
            add(name=f"initial.base[{i + 1}]", type="Real", causality="parameter", variability="fixed",
                initial="exact", start=float(scene.base_start[i]), unit="m",
                description=f"the base point's {axis} at the start", kind="q0", index=n + i)
        for i, axis in enumerate("xy"):
            add(name=f"initial.base_velocity[{i + 1}]", type="Real", causality="parameter", variability="fixed",
                initial="exact", start=float(scene.base_velocity[i]), unit="m/s",
                description=f"the base point's velocity {axis} at the start", kind="u0", index=n + i)
    for kind, of in SUMMARIES:  # last, so that the value references above stay as they were
        for name, member, index, unit, doc in summary_fields(n, dof):
            integer = TYPES[member] in (int, tuple[int, ...])  # an int, or an entry of an array of them
            add(name=f"{kind}.{name}", type="Integer" if integer else "Real", causality="output",
                variability="discrete" if integer else "continuous", initial="calculated", start=None, unit=unit,
                description=f"{of}: {doc}", kind=kind, index=index, member=member)
    return out


TYPES = get_type_hints(Tallied)  # int or float, per ig_summary member
# the two summaries of the run from its start to the current time, as impactgen run's (tally.c)
SUMMARIES = (("first_impact", "the first impact's summary (final once it ended; the run's while it had none)"),
             ("run", "the run's summary from its start to now"))
SUMMARY_DOCS = {  # what each field is (summaries.py, MODEL section 6); units: summaries.summary_unit
    "T0": "kinetic energy at its start", "Tf": "kinetic energy at its end",
    "delta_T": "kinetic energy lost, T0 - Tf", "delta_max": "largest maximum compression",
    "delta_r": "permanent deformation of the deepest dent (Eq. 12)",
    "P_max": "largest normal force at maximum compression", "R_res": "the deepest dent's radius",
    "t_contact": "contact time of the ended impacts", "t_impact": "start of the first impact (NaN: none)",
    "n_switches": "phase switches within the first impact",
    "n_stick_slip": "stick-slip changes within the first impact",
    "impacts": "impacts at every contact point", "point_impacts": "impacts at {point}",
    "first_point": "point of the first impact: n the tip, k joint k, 0 a free chain's base; none: 0 "
                   "(pinned) or -1 (free)",
    "t_sustained": "start of sustained contact (NaN: none)", "t_final": "time at its end",
    "W_normal": "work of the normal forces", "W_friction": "work of the friction forces",
    "W_gravity": "work of gravity", "residual": "energy balance residual, delta T - sum of works",
    "v_n0": "first impact: normal speed at its start",
    "P_c": "first impact: normal impulse of compression",
    "P_r": "first impact: normal impulse of restitution", "P_t": "first impact: tangential impulse",
    "e_N": "first impact: kinematic coefficient of restitution (Newton)",
    "e_P": "first impact: kinetic coefficient of restitution (Poisson)",
    "e_E": "first impact: energetic coefficient of restitution (Stronge)",
    "friction_share": "first impact: friction's share of the contact forces' work",
}


ARRAY_MEMBERS = ("y_final", "point_impacts")  # ig_summary's arrays: a variable reads one entry


def _summary_unit(name: str) -> str:
    """A summary field's unit (summaries.SUMMARY_UNITS) as the modelDescription writes it."""
    unit = summary_unit(name) or ""
    return "" if unit == "1" else unit.replace(" ", ".")


def summary_fields(n: int, dof: int | None = None) -> list[tuple[str, str, int, str, str]]:
    """A summary's fields as `impactgen run --json` and the sweep's columns name them (name,
    ig_summary member, entry of an array member, unit, what), in the sweep's order; `dof` the
    model's coordinates (n, and a free chain's base point's two), where its speeds begin. The
    impacts per point are point_impacts[k], k the point's number (as contact[k]: 0 a free
    chain's base, k joint k, n the tip); the sweep's columns name them point_impacts.tip, ..."""
    def field(name: str, member: str | None = None) -> tuple[str, str, int, str, str]:
        return name, member or name, 0, _summary_unit(member or name), SUMMARY_DOCS[member or name]

    def later(name: str) -> list[tuple[str, str, int, str, str]]:
        if name not in PER_POINT:
            return [field(name)]
        return [(f"{name}[{k}]", name, k, _summary_unit(name), SUMMARY_DOCS[name].format(point=point_name(k, n)))
                for k in chain_points(n, dof is not None and dof > n)]

    final = [(f"{which}_final[{i + 1}]", "y_final", i + offset, _summary_unit(f"{which}_final"),
              f"{what} of link {i + 1} at its end")
             for which, offset, what in (("u", n if dof is None else dof, "angular speed"), ("q", 0, "angle"))
             for i in range(n)]
    return [*(field(name) for name in (*SUMMARY_LEADING, "n_switches", "n_stick_slip")), *final,
            *(entry for name in SUMMARY_LATER for entry in later(name)),
            *(field(f"energy.{name}", name) for name in ENERGY_TERMS),
            *(field(f"coefficients.{name}", name) for name in COEFFICIENTS)]


def _unit(f: Field) -> str:
    return "" if f.row.unit in ("", "1") else f.row.unit


# SI base-unit exponents of every unit a variable can carry (modelDescription's UnitDefinitions)
UNITS = {"rad": {"rad": 1}, "deg": {"rad": 1, "factor": 0.017453292519943295}, "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2},
         "J": {"kg": 1, "m": 2, "s": -2}, "W": {"kg": 1, "m": 2, "s": -3}, "m": {"m": 1},
         "m/s": {"m": 1, "s": -1}, "m/s2": {"m": 1, "s": -2}, "N": {"kg": 1, "m": 1, "s": -2},
         "kg": {"kg": 1}, "Pa": {"kg": 1, "m": -1, "s": -2}, "N.s": {"kg": 1, "m": 1, "s": -1}, "s": {"s": 1},
         "N/m": {"kg": 1, "s": -2}, "N.s/m": {"kg": 1, "s": -1}}  # (the Kelvin-Voigt spring and dashpot)
