"""A checked scene with some keys changed, at the cost of the changed values only (a sweep
builds every case so), and its solver settings changed on their own."""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping

from ..codegen.parameters import RULES
from ..errors import SceneError
from .loading import scene_from_dict
from .model import LAW_FIELDS, Scene, Solver
from .physics import check_physics
from .schema import resolve_jacobian, split_key
from .values import check_split

# The keys whose new value re-decides other fields (the links size every list; a material
# gives E, nu, the yield strength and the density; a density and a cross-section give the
# masses): a case that changes one is read in full.
_REREAD = {"chain.links", "rod.material", "surface.material", "rod.density", "chain.diameter", "chain.area",
           "chain.base", "initial.base", "initial.base_velocity", "contact.base_radius", "surface.angle_deg"}
# ... and these too where the masses come from a cross-section (a length changes a mass; a
# mass replaces the cross-section)
_REREAD_WITH_SECTION = {"chain.length", "chain.mass"}
_JOINT_RADIUS = "contact.joint_radius"  # a per-joint list: its elements are set like a link's
_MATERIALS = {"E", "nu", "yield_strength"}  # the keys of a [rod] or [surface] Material
# The keys `check_physics` reads: a case that changes none of them (a speed, a friction
# coefficient, a solver setting) keeps the base scene's verdict, which was already checked.
_CROSS_CHECKED = {*(key for rule in RULES for key in (rule.key, rule.above_key)), "surface.height",
                  "chain.length", "initial.q", "initial.q_deg", "contact.model",
                  *(f"contact.{key}" for key in LAW_FIELDS)}


def scene_with(base: Scene, overrides: Mapping[str, Any]) -> Scene:
    """`base` with some keys changed, checked as `scene_from_dict(base.to_dict(), overrides)`
    checks it and equal to what it builds, at a fraction of the cost: only the changed values
    are coerced (by `check_value`, the scene's own coercion), then the cross-key checks run.
    A sweep builds every case this way, and `simulate` applies its options so. A refused
    case is read in full, so that its error is the one `scene_from_dict` reports."""
    try:
        return _changed(base, overrides)
    except SceneError:
        return scene_from_dict(base.to_dict(), overrides, source=base.source)


def _changed(base: Scene, overrides: Mapping[str, Any]) -> Scene:
    fields: dict[str, Any] = {}  # the scene's fields that change, by name
    n = base.chain.links
    lists: dict[str, list[float]] = {}  # q0, u0, length, mass: copied when a key changes one
    cross_checked = False
    from_section = base.chain.diameter is not None or base.chain.area is not None  # masses from a cross-section
    for dotted, value in overrides.items():
        section, key, index = split_key(dotted)
        name = f"{section}.{key}" if section else key
        if name in _REREAD or (from_section and name in _REREAD_WITH_SECTION) \
                or (index is not None and index > (n - 1 if name == _JOINT_RADIUS else n)):
            return scene_from_dict(base.to_dict(), overrides, source=base.source)
        cross_checked = cross_checked or name in _CROSS_CHECKED
        checked = check_split(dotted, section, key, index, value, n)
        if section == "chain" and key != "gravity":
            target = lists[key] if key in lists else lists.setdefault(key, list(getattr(base.chain, key)))
            if index is None:
                target[:] = checked
            else:
                target[index - 1] = checked
        elif section == "initial":
            field = "u0" if key == "u" else "q0"
            target = lists[field] if field in lists else lists.setdefault(field, list(getattr(base, field)))
            convert = math.radians if key == "q_deg" else float
            if key == "q_deg" and index is not None:  # the other angles pass through degrees too
                target[:] = [math.radians(math.degrees(v)) for v in target]
            if index is None:
                target[:] = [convert(v) for v in checked]
            else:
                target[index - 1] = convert(checked)
        elif name == _JOINT_RADIUS:  # a tuple, or one element of the radii (the tip's where none were given)
            contact = fields.get("contact", base.contact)
            radii = list(contact.joint_radius if contact.joint_radius is not None
                         else (fields.get("tip_radius", base.tip_radius),) * (n - 1))
            if index is None:
                radii[:] = checked
            else:
                radii[index - 1] = checked
            fields["contact"] = with_fields(contact, {"joint_radius": tuple(radii)})
        elif name == "solver.jacobian":  # the setting as given: `jacobian` is resolved below
            fields["solver"] = with_fields(fields.get("solver", base.solver), {"jacobian_setting": checked})
        elif section in _SECTION_FIELDS and (section not in ("rod", "surface") or key in _MATERIALS):
            # the field of the section's name: a Material, Contact, Solver or the chain's gravity
            fields[section] = with_fields(fields.get(section, getattr(base, section)), {key: checked})
        elif name == "rod.tip_radius":
            fields["tip_radius"] = checked
        elif name == "surface.height":
            fields["surface_height"] = checked
        else:  # the name
            fields[key] = checked
    if "length" in lists or "mass" in lists:
        chain = fields.get("chain", base.chain)
        fields["chain"] = with_fields(chain, {"length": tuple(lists.get("length", chain.length)),
                                        "mass": tuple(lists.get("mass", chain.mass))})
    for field in ("q0", "u0"):
        if field in lists:
            fields[field] = tuple(lists[field])
    if "solver" in fields:
        solver = fields["solver"]
        jacobian = resolve_jacobian(solver.method, solver.jacobian_setting, n)
        if jacobian != solver.jacobian:
            fields["solver"] = with_fields(solver, {"jacobian": jacobian})
    scene = with_fields(base, fields)
    if cross_checked:
        check_physics(scene)
    return scene


def with_solver(base: Scene, settings: Mapping[str, Any]) -> Scene:
    """`base` with some keys of its [solver] table changed (``{"rtol": 1e-8}``), checked as
    `solver_with` checks them."""
    return replace_solver(base, solver_with(base, settings))


def solver_with(base: Scene, settings: Mapping[str, Any]) -> Solver:
    """`base`'s solver with some keys of its [solver] table changed (``{"rtol": 1e-8}``):
    each value checked as the scene checks it, the Jacobian's "auto" resolved again when the
    method or the Jacobian setting changes; nothing else of the scene is read, since no other
    key depends on the solver's. (simulate() runs a scene under it without making a new
    scene: `replace_solver` makes one when it is asked for.)"""
    checked = {key: check_split(f"solver.{key}", "solver", key, None, value, base.n)
               for key, value in settings.items()}
    if "jacobian" in checked:  # the setting as given: `jacobian` is the resolved one
        checked["jacobian_setting"] = checked.pop("jacobian")
    solver = base.solver
    if "method" in checked or "jacobian_setting" in checked:
        checked["jacobian"] = resolve_jacobian(checked.get("method", solver.method),
                                        checked.get("jacobian_setting", solver.jacobian_setting), base.n)
    return with_fields(solver, checked)


def replace_solver(scene: Scene, solver: Solver) -> Scene:
    """`scene` with `solver` (made by `solver_with`, so checked already) as its [solver]."""
    return scene if solver is scene.solver else with_fields(scene, {"solver": solver})


_SECTION_FIELDS = {"chain", "rod", "surface", "contact", "solver"}  # sections that are a Scene field of their name


def with_fields(value: Any, changes: dict[str, Any]) -> Any:
    """A scene (or one of its sections) with some fields set to new values, checked by the
    caller: dataclasses.replace through the class's own __init__, without its per-call
    lookup of the fields (each of these dataclasses has exactly its fields in __dict__)."""
    return type(value)(**{**value.__dict__, **changes})


def check_fields(scene: Scene, fields: Mapping[str, Any]) -> None:
    """Scene.replace's keyword fields: names of the dataclass, each a value of its field's
    type (a whole section such as `solver`); a scene key is given in `overrides` instead."""
    names = [f.name for f in dataclasses.fields(Scene)]
    for name, value in fields.items():
        if name not in names:
            raise SceneError(name, f"Scene.replace takes whole fields ({', '.join(names)}) as keywords; "
                                   f"a scene key goes in overrides, e.g. scene.replace({{'rod.E': 2.1e11}})")
        current = getattr(scene, name)
        if dataclasses.is_dataclass(current) and type(value) is not type(current):
            raise SceneError(name, f"expected a {type(current).__name__} (e.g. dataclasses.replace(scene.{name}, "
                                   f"...)), got {type(value).__name__} {value!r:.60}")
