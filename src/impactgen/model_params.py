"""Fill a compiled model's parameter struct from a scene, through the one parameter table.

The inputs are read from the scene as codegen/parameters.py says; the derived contact
constants (E*, R, delta_c, P_c, C_j, B, and the elasto-plastic law's 1/delta_c and theta_c)
are filled by the generated C (`model_derive`) from the same sympy expressions the force laws
are printed from. The phase machine sets the rest.
"""
from __future__ import annotations

import struct
from functools import lru_cache

from .build import CompiledModel
from .codegen.parameters import PARAMETERS, Parameter
from .errors import SceneError, excerpt
from .scene import Scene


@lru_cache(maxsize=64)
def _readers(ffi, links: int, joints: tuple[int, ...] = ()) -> tuple[struct.Struct, tuple[Parameter, ...]]:
    """The rows of the parameter table that a scene sets in a model's struct (its ffi), in
    the struct's order, and the layout that writes their values into it in one call (a
    field at a time would cost a C crossing each). Made once per model."""
    fields = dict(ffi.typeof("model_params").fields)
    rows = tuple(p for p in PARAMETERS if p.kind == "input" and p.names(links, joints)
                 and p.names(links, joints)[0][0] in fields)
    layout, at = "=", 0
    for name, _, _ in (named for row in rows for named in row.names(links, joints)):
        field = fields[name]
        assert field.type.cname == "double", f"the scene input {name} is not a double in model_params"
        assert field.offset >= at, f"model_params does not keep the parameter table's order at {name}"
        layout += "x" * (field.offset - at) + "d"
        at = field.offset + 8
    return struct.Struct(layout), rows


def _inputs(scene: Scene, rows: tuple[Parameter, ...], joints: tuple[int, ...]) -> list[float]:
    """The values of these rows in `scene`, a per-link row's for every link, a per-joint row's
    for each joint of the model."""
    values: list[float] = []
    for row in rows:
        if row.per_link:
            values.extend(row.read(scene))
        elif row.per_joint:
            values.extend(row.read(scene)[j - 1] for j in joints if j > 0)  # the base point: R_base
        else:
            values.append(row.read(scene))
    return values


def fill_params(model: CompiledModel, scene: Scene):
    """A new `model_params` for `scene`: its inputs, then the derived constants."""
    ffi = model.ffi
    params = ffi.new("model_params *")  # zeroed: the struct's other fields stay 0 under the layout's pad bytes
    layout, rows = _readers(ffi, model.spec.links, model.spec.joints)
    ffi.memmove(params, layout.pack(*_inputs(scene, rows, model.spec.joints)), layout.size)
    derive(model, params)
    return params


def derive(model: CompiledModel, params) -> None:
    """Fill the derived constants; an input out of its physical range is a SceneError
    naming its scene key (a scene that passed its own checks never has one)."""
    ffi, lib = model.ffi, model.lib
    range_text = ffi.new("char *[1]")
    bad = lib.model_derive(params, range_text)
    if bad != lib.MODEL_PARAMS_OK:
        key = ffi.string(lib.model_param_key(bad)).decode()
        value = getattr(params, ffi.string(lib.model_param_name(bad)).decode())
        raise SceneError(key, f"{excerpt(value)} is outside its physical range "
                              f"{ffi.string(range_text[0]).decode()}")


def params_at_start(model: CompiledModel, scene: Scene):
    """Parameters as the phase machine starts the scene (the surface level set, free-flight
    law): for code that evaluates the model's functions outside a run."""
    ffi = model.ffi
    params = fill_params(model, scene)
    y0 = ffi.new("double[]", list(scene.motion_start) + [0.0] * (model.nstate - 2 * scene.dof))
    model.lib.model_machine_start(ffi.new("model_machine *"), params, 0.0, y0, 1)
    for point in params.point:
        point.phase = model.lib.MODEL_PHASE_FREE
    return params
