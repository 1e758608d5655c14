"""Stage 5b of the pipeline: what the model gives the phase machine.

The phase machine of MODEL section 4 (which force law and which events with directions in
each machine state, what is recorded at each switch) is plain C written once,
src/impactgen/native/model_machine.c, compiled with each model. What it reads of a model is
printed into the model's <prefix>_params.c (templates/model_params.c.j2): the switch laws
(Eq. 12, the unloading radius, the yield onset) and the derived material constants from the
sympy expressions of contact.py, as the force laws are; the thresholds, named in
thresholds.py, are printed as #defines, so Python code that needs one (scene checks,
validity warnings) reads the same number.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass

import sympy as sm

from . import contact as law
from .expressions import ModelExpressions
from .spec import STATES
from .thresholds import THRESHOLD, THRESHOLDS  # noqa: F401 (the machine prints them)

# The C API of model.h and model_machine.h: bumped when a signature or a struct changes (2: m.tip;
# 3: every contact point's record in params.point[k] and machine.point[k], the tip's at
# MODEL_TIP_POINT; 4: the machine is the runtime's model_machine.c, the parameter table and the
# switch laws the model's model_params.c; 5: model_point_integrals replaces model_tip_works, the
# runtime's summaries are every point's, point_impacts replacing joint_impacts)
API_VERSION = 5


@dataclass(frozen=True)
class SwitchLaws:
    """The laws the machine applies at switches, printed as C expressions."""

    derive: tuple[tuple[str, str], ...]  # (name, C) steps from the materials to the constants
    residual: str | None  # delta_r from delta_max (Eq. 12; Thornton's delta_p), the plastic laws only
    unloading_radius: str | None  # R_res from delta_max, P_m, delta_r
    yielded: str | None  # reloading past delta_m returns to the elasto-plastic law
    inputs: tuple[str, ...] = ()  # the law's own scene inputs the derivation reads (p->...)
    residual_reads: tuple[str, ...] = ("delta_c",)  # the point's constants the residual law reads
    yielded_reads: tuple[str, ...] = ("delta_m", "delta_c")  # and the yield test


def switch_laws(model: ModelExpressions, ccode) -> SwitchLaws:
    spec = model.spec
    own = law.law_constants(spec.contact_model)  # after the materials' constants, which they read
    derive = tuple((str(name), ccode(expr)) for name, expr in law.material_constants() + own)
    read = set().union(*(sm.sympify(e).free_symbols for _, e in own))
    inputs = tuple(str(x) for x in law.LAW_INPUTS.get(spec.contact_model, ()) if x in read)
    if not spec.plastic:
        return SwitchLaws(derive, None, None, None, inputs)
    delta_m = sm.Symbol("delta_m")
    if spec.contact_model == "thornton":
        residual = law.thornton_residual()
        reads = tuple(sorted(str(x) for x in residual.free_symbols if x != law.delta_max))  # (R cancels out)
        return SwitchLaws(derive, residual=ccode(residual), unloading_radius=ccode(law.unloading_radius()),
                          yielded=ccode(sm.GreaterThan(delta_m, law.delta_y)), inputs=inputs,
                          residual_reads=reads, yielded_reads=("delta_m", "delta_y"))
    return SwitchLaws(
        derive,
        residual=ccode(law.residual_deformation()),
        unloading_radius=ccode(law.unloading_radius()),
        yielded=ccode(sm.GreaterThan(delta_m, law.YIELD_ONSET * law.delta_c)),
        inputs=inputs,
    )


def structure_hash(model: ModelExpressions) -> str:
    """A hash of everything an embedder's code depends on: the spec and the names and order
    of the states, parameters, events, outputs and machine states."""
    facts = {"api": API_VERSION, "spec": model.spec.to_json(), "states": model.state_names,
             "params": [f.name for f in model.params], "events": [e.name for e in model.events],
             "outputs": [o.name for o in model.outputs], "machine": STATES}
    return hashlib.sha256(json.dumps(facts, sort_keys=True).encode()).hexdigest()[:16]
