"""Fill a compiled model's parameter struct from a scene, through the one parameter table.

The inputs are read from the scene as codegen/parameters.py says; the derived contact
constants (E*, R, delta_c, P_c, C_j, B) are filled by the generated C (`model_derive`) from
the same sympy expressions the force laws are printed from. The phase machine sets the rest.
"""
from __future__ import annotations

from functools import lru_cache

from .build import CompiledModel
from .codegen.parameters import PARAMETERS
from .errors import SceneError
from .scene import Scene


@lru_cache(maxsize=64)
def _readers(param_names: tuple[str, ...], links: int) -> tuple[tuple[str, object, int], ...]:
    """(field, reader, link) of each field of a model's struct that a scene sets, in struct
    order: the loop of `fill_params`, made once per model."""
    inputs = {name: (p.read, link) for p in PARAMETERS if p.kind == "input" for name, _, link in p.names(links)}
    return tuple((name, *inputs[name]) for name in param_names if name in inputs)


def fill_params(model: CompiledModel, scene: Scene):
    """A new `model_params` for `scene`: its inputs, then the derived constants."""
    params = model.ffi.new("model_params *")
    for name, read, link in _readers(model.param_names, model.spec.links):
        setattr(params, name, read(scene, link))
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
