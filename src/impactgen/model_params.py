"""Fill a compiled model's parameter struct from a scene, through the one parameter table.

The inputs are read from the scene as codegen/parameters.py says; the derived contact
constants (E*, R, delta_c, P_c, C_j, B, and the elasto-plastic law's 1/delta_c and theta_c)
are filled by the generated C (`model_derive`) from the same sympy expressions the force laws
are printed from. The phase machine sets the rest.
"""
from __future__ import annotations

import struct
from collections.abc import Callable
from functools import lru_cache

from .build import CompiledModel
from .codegen.parameters import PARAMETERS, scene_reader
from .errors import SceneError
from .scene import Scene


@lru_cache(maxsize=64)
def _readers(ffi, links: int) -> tuple[struct.Struct, Callable[[Scene], tuple]]:
    """The fields of a model's struct (its ffi) that a scene sets: the function that reads
    their values from a scene in struct order, and the layout that writes them into the
    struct in one call. Made once per model: `fill_params` runs for every simulation, and a
    field at a time would cost a C crossing each."""
    inputs = {name: p.source(link) for p in PARAMETERS if p.kind == "input" for name, _, link in p.names(links)}
    layout, at, sources = "=", 0, []
    for name, field in sorted(ffi.typeof("model_params").fields, key=lambda item: item[1].offset):
        if name in inputs:
            assert field.type.cname == "double", f"the scene input {name} is not a double in model_params"
            layout += "x" * (field.offset - at) + "d"
            at = field.offset + 8
            sources.append(inputs[name])
    return struct.Struct(layout), scene_reader(tuple(sources))


def fill_params(model: CompiledModel, scene: Scene):
    """A new `model_params` for `scene`: its inputs, then the derived constants."""
    ffi = model.ffi
    params = ffi.new("model_params *")  # zeroed: the struct's other fields stay 0 under the layout's pad bytes
    layout, read = _readers(ffi, model.spec.links)
    ffi.memmove(params, layout.pack(*read(scene)), layout.size)  # (pack_into through ffi.buffer: 0.15 us more)
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
        raise SceneError(key, f"{value!r} is outside its physical range "
                              f"{ffi.string(range_text[0]).decode()}")


def params_at_start(model: CompiledModel, scene: Scene):
    """Parameters as the phase machine starts the scene (the surface level set, free-flight
    law): for code that evaluates the model's functions outside a run."""
    ffi = model.ffi
    params = fill_params(model, scene)
    y0 = ffi.new("double[]", list(scene.q0) + list(scene.u0) + [0.0] * (model.nstate - 2 * scene.n))
    model.lib.model_machine_start(ffi.new("model_machine *"), params, 0.0, y0, 1)
    params.phase = model.lib.MODEL_PHASE_FREE
    return params
