"""Reading a scene: from a TOML file or a shipped example, from TOML text, from nested dicts;
and the paper's steel chain for n links."""
from __future__ import annotations

import math
import os
from collections import abc
from pathlib import Path
from typing import Any, Mapping

from ..errors import SceneError
from .derived import fill_from_material, link_masses
from .model import LAW_FIELDS, Chain, Contact, Material, Scene, Solver
from .overrides import apply_overrides, checked_overrides, tables_copied, tomllib
from .physics import check_physics
from .schema import FREE_KEYS, MISSING, SCHEMA, did_you_mean, resolve_jacobian
from .values import coerce, plain

MAX_SCENE_BYTES = 16 * 2**20  # a scene file is a few hundred bytes; /dev/zero would never end


def _read_sections(raw: dict[str, Any]) -> dict[str, dict[str, Any]]:
    for top, value in raw.items():
        if top in SCHEMA and top:
            if not isinstance(value, dict):
                raise SceneError(top, f"expected a table [{top}], got {type(value).__name__}")
        elif top not in SCHEMA[""]:
            raise SceneError(top, f"unknown key{did_you_mean(top)}")
    out: dict[str, dict[str, Any]] = {"": {k: raw[k] for k in SCHEMA[""] if k in raw}}
    for section, keys in SCHEMA.items():
        if not section:
            continue
        given = raw.get(section, {})
        for k in given:
            if k not in keys:
                raise SceneError(f"{section}.{k}", f"unknown key{did_you_mean(f'{section}.{k}')}")
        out[section] = dict(given)
    return out


def scene_from_dict(raw: Mapping[str, Any], overrides: Mapping[str, Any] | None = None,
                    source: str = "<memory>") -> Scene:
    """Check a scene given as nested dicts (as TOML parses it) and build a `Scene`."""
    if not isinstance(raw, abc.Mapping):
        raise SceneError(None, f"a scene is a mapping of tables (as TOML gives it), got {type(raw).__name__} "
                               f"{raw!r:.60}")
    raw = tables_copied(raw)
    apply_overrides(raw, checked_overrides(overrides))
    sections = _read_sections(raw)

    def get(section: str, key: str, n: int = 0) -> Any:
        spec = SCHEMA[section][key]
        dotted = f"{section}.{key}" if section else key
        if key in sections[section]:
            return coerce(dotted, plain(sections[section][key]), spec, n)
        if spec.default is MISSING:
            raise SceneError(dotted, f"missing required key ({spec.doc or spec.kind})"
                             if spec.doc else "missing required key")
        return coerce(dotted, spec.default, spec, n) if spec.default is not None else None

    name = get("", "name")
    n = get("chain", "links")
    for section in ("rod", "surface"):
        fill_from_material(section, sections[section])
    rod = Material(get("rod", "E"), get("rod", "nu"), get("rod", "yield_strength"), get("rod", "material"),
                   get("rod", "density"))
    surface = Material(get("surface", "E"), get("surface", "nu"), get("surface", "yield_strength"),
                       get("surface", "material"))
    length = get("chain", "length", n)
    mass, diameter, area = link_masses(get, "mass" in sections["chain"], n, length, rod.density)
    base = get("chain", "base")
    chain = Chain(n, length, mass, get("chain", "gravity"), diameter, area, base)
    base0, base_u0 = _base_start(get, sections, base == "free")
    contact = Contact(get("contact", "model"), get("contact", "friction"),
                      get("contact", "friction_mode"), get("contact", "friction_eps"),
                      get("contact", "joint_radius", n), get("contact", "base_radius"),
                      *(get("contact", key) for key in LAW_FIELDS))
    q_deg, q_rad = get("initial", "q_deg", n), get("initial", "q", n)
    if (q_deg is None) == (q_rad is None):
        raise SceneError("initial.q", "give exactly one of initial.q (rad) and initial.q_deg")
    q0 = q_rad if q_rad is not None else tuple(math.radians(a) for a in q_deg)
    method, jacobian_setting = get("solver", "method"), get("solver", "jacobian")
    solver = Solver(method, resolve_jacobian(method, jacobian_setting, n), get("solver", "rtol"), get("solver", "atol"),
                    get("solver", "t_end"), get("solver", "t_max"), get("solver", "max_steps"),
                    get("solver", "sustained_contact"), jacobian_setting)
    # surface.height not given: "initial" (None) under a pinned chain, 0 under a free one
    height = get("surface", "height") if "height" in sections["surface"] or base != "free" else 0.0
    scene = Scene(name, chain, rod, get("rod", "tip_radius"), surface,
                  height, contact, q0, get("initial", "u", n), solver,
                  source=source, surface_angle_deg=get("surface", "angle_deg"), base0=base0, base_u0=base_u0)
    check_physics(scene)
    return scene


def _base_start(get: Any, sections: dict[str, dict[str, Any]], free: bool
                ) -> tuple[tuple[float, float] | None, tuple[float, float] | None]:
    """(initial.base, initial.base_velocity) of a free chain (the velocity zero where not
    given); (None, None) for a pinned one, which may give neither key nor contact.base_radius."""
    if not free:
        for dotted in FREE_KEYS:
            section, _, key = dotted.partition(".")
            if key in sections[section]:
                raise SceneError(dotted, f"{dotted} is a free chain's key: a pinned chain's base is its pivot, "
                                         'fixed at the origin; set chain.base = "free" or leave the key out')
        return None, None
    base0 = get("initial", "base")
    if base0 is None:
        raise SceneError("initial.base", "a free chain (chain.base = \"free\") needs its base point's start: "
                                         "initial.base = [x, y] in m, in the surface's frame")
    velocity = get("initial", "base_velocity")
    return base0, velocity if velocity is not None else (0.0, 0.0)


def load_scene(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Scene:
    """Read and check a scene file.

    Parameters
    ----------
    path : str or Path
        A TOML scene file (docs/scene.md), or the name of a shipped example ("paper",
        "bouncing", ...; see `impactgen examples`) when no file of that name exists.
    overrides : mapping, optional
        Dotted keys to values that replace the file's, e.g. ``{"initial.u": [-0.1, -0.3]}``
        or one element, counted from 1 as the links are: ``{"initial.u[2]": -0.3}``.
        numpy scalars and arrays are taken as plain numbers and lists.

    Returns
    -------
    Scene
        The checked, frozen scene (angles in radians).

    Raises
    ------
    SceneError
        The file cannot be read or is not TOML, or a key is unknown, missing, of the wrong
        type or not physical; the message names the key.

    Examples
    --------
    >>> import impactgen
    >>> scene = impactgen.load_scene("paper", overrides={"initial.u[2]": -0.3})
    >>> scene.n, scene.u0
    (2, (-0.1, -0.3))
    """
    from ..examples import example_text, find_example
    if not isinstance(path, (str, os.PathLike)):
        raise SceneError(None, f"load_scene takes a scene file (str or Path) or an example's name "
                               f"such as 'paper', got {type(path).__name__} {path!r:.60}")
    path = Path(path)
    example = find_example(path)
    if example is not None:
        return scene_from_text(example_text(example), overrides, source=f"<example {example}>")
    try:
        if path.exists() and (not path.is_file() or path.stat().st_size > MAX_SCENE_BYTES):
            raise SceneError(None, f"{path} is not a scene file: {'too large' if path.is_file() else 'not a file'} "
                                   f"(a scene is a TOML file of at most {MAX_SCENE_BYTES // 2**20} MiB)")
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(None, f"scene file not found: {path} (a shipped example is named without "
                               "a folder: see 'impactgen examples')") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(None, f"cannot read scene file {path}: {exc}") from None
    return scene_from_text(text, overrides, source=str(path))


def scene_from_text(text: str, overrides: Mapping[str, Any] | None = None, source: str = "<memory>") -> Scene:
    """Check a scene given as TOML text."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(None, f"{source} is not valid TOML: {exc}") from None
    except RecursionError:  # tomllib recurses once per nested array or table
        raise SceneError(None, f"{source} is not a scene: its arrays or tables are nested too deeply") from None
    return scene_from_dict(raw, overrides, source=source)


def steel_chain_scene(n: int) -> Scene:
    """The paper's steel chain and initial state (MODEL.md section 7), for n links."""
    q_deg = [-70.0, -60.0] + [-60.0] * (n - 2) if n >= 2 else [-70.0]
    u = [-0.1, -0.2] + [-0.2] * (n - 2) if n >= 2 else [-0.1]
    raw = {
        "name": f"steel-chain-{n}",
        "chain": {"links": n, "length": 1.0, "mass": 1.0, "gravity": 9.81},
        "rod": {"E": 210e9, "nu": 0.29, "yield_strength": 1.12e9, "tip_radius": 0.005},
        "surface": {"E": 210e9, "nu": 0.29, "yield_strength": 1.12e9, "height": "initial"},
        "contact": {"model": "three-phase", "friction": 0.2, "friction_mode": "regularized",
                    "friction_eps": 1e-6},
        "initial": {"q_deg": q_deg[:n], "u": u[:n]},
    }
    return scene_from_dict(raw, source=f"<steel chain, {n} links>")
