"""Scene files: read a TOML description of a chain and a surface, check it, and freeze it.

The package holds one job per module: `schema` (every key, its kind, default and check),
`values` (a value coerced and checked for its key), `overrides` (``KEY=VALUE`` and dotted
keys applied to a scene before it is checked), `derived` (the keys a named material or a
cross-section gives), `physics` (the checks across keys), `model`
(the frozen Scene, read by the same dotted keys), `loading` (files, text, dicts) and
`updates` (a checked scene with some keys changed). Every error names the key.

>>> import impactgen
>>> scene = impactgen.load_scene("paper", overrides={"surface.height": -2.0})
>>> scene["surface.height"], scene.get("chain.links")
(-2.0, 2)
"""
from __future__ import annotations

from .loading import MAX_SCENE_BYTES, load_scene, scene_from_dict, scene_from_text, steel_chain_scene
from .model import Chain, Contact, Material, Scene, Solver
from .overrides import checked_overrides, parse_override
from .physics import TOUCH_TOLERANCE, initial_surface_height, joint_heights
from .schema import (BASES, CONTACT_MODELS, EXPLICIT_METHODS, FRICTION_MODES, JACOBIAN_AUTO_MAX_LINKS, JACOBIANS,
                     METHODS, NAME_PATTERN, SCHEMA, Key, split_key)
from .updates import replace_solver, scene_with, solver_with, with_solver
from .values import check_value, check_values, plain

__all__ = ["BASES", "CONTACT_MODELS", "EXPLICIT_METHODS", "FRICTION_MODES", "JACOBIAN_AUTO_MAX_LINKS", "JACOBIANS",
           "MAX_SCENE_BYTES", "METHODS", "NAME_PATTERN", "SCHEMA", "TOUCH_TOLERANCE", "Chain", "Contact", "Key",
           "Material", "Scene", "Solver", "check_value", "check_values", "checked_overrides", "initial_surface_height", "joint_heights",
           "load_scene", "parse_override", "plain", "replace_solver", "scene_from_dict", "scene_from_text",
           "scene_with", "solver_with", "split_key", "steel_chain_scene", "with_solver"]
