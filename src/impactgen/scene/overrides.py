"""Overrides: `KEY=VALUE` text as --set gives it, and dotted keys applied to a scene read as
nested dicts (before it is checked), one element of a list too."""
from __future__ import annotations

import math
import re
from collections import abc
from typing import Any, Mapping

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib  # type: ignore[no-redef]

from ..errors import SceneError
from ..materials import MATERIAL_KEYS
from .schema import SCHEMA, split_key
from .values import plain

def parse_override(text: str) -> tuple[str, Any]:
    """Parse one `KEY=VALUE` override; VALUE is TOML, or a bare word taken as a string."""
    if "=" not in text:
        raise SceneError("--set", f"expected KEY=VALUE, got {text!r}")
    key, raw = (s.strip() for s in text.split("=", 1))
    if not key:
        raise SceneError("--set", f"missing key in {text!r}")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except RecursionError:
        raise SceneError(key, "the value is nested too deeply") from None
    except tomllib.TOMLDecodeError:
        if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.-]*", raw):
            value = raw
        else:
            raise SceneError(key, f"cannot read the value {raw!r} (use TOML syntax, "
                                  "e.g. 1e-8, \"text\" or [1.0, 2.0])") from None
    return key, value


def checked_overrides(overrides: Any) -> Mapping[str, Any]:
    """`overrides` if it is a mapping of dotted keys (strings) to values ({} for None);
    anything else is refused in one line that shows how to write it."""
    if overrides is None:
        return {}
    how = "overrides are a mapping of dotted scene keys to values, e.g. {'rod.E': 2.1e11, 'initial.u[2]': -0.3}"
    if not isinstance(overrides, abc.Mapping):
        raise SceneError("overrides", f"{how}; got {type(overrides).__name__} {overrides!r:.60}")
    bad = next((k for k in overrides if not isinstance(k, str)), None)
    if bad is not None:
        raise SceneError("overrides", f"{how}; got the key {bad!r}, which is not a string")
    return overrides


# The keys that give the links' masses: the masses, or the cross-section they come from
MASS_KEYS = ("chain.mass", "chain.diameter", "chain.area")
# Keys of which a scene states one, so that overriding one replaces the others: the initial
# angles in radians or in degrees; the links' masses.
ALTERNATIVES = (("initial.q", "initial.q_deg"), MASS_KEYS)


def apply_overrides(raw: dict[str, Any], overrides: Mapping[str, Any]) -> None:
    """Set each dotted key of `overrides` in the scene `raw` (nested dicts): one element of a
    list too; None unsets a key (back to its default, or missing). A key of `ALTERNATIVES`
    replaces the others of its group; of `MASS_KEYS` the same overrides give one. A material
    (``rod.material``) replaces the values the table gave, but for those the same overrides
    give: it is the material a sweep or `--set` asks for."""
    keys = {".".join(split_key(dotted)[:2]) for dotted, value in overrides.items() if value is not None}
    given = [key for key in MASS_KEYS if key in keys]
    if len(given) > 1:
        raise SceneError(given[1], f"the links' masses are given twice, by {' and '.join(given)}: give one "
                                   "(the masses, or the cross-section with rod.density)")
    for dotted, value in overrides.items():
        section, key, index = split_key(dotted)
        name = f"{section}.{key}" if section else key
        group = next((g for g in ALTERNATIVES if name in g), ())
        target = raw.setdefault(section, {}) if section else raw
        if not isinstance(target, dict):
            raise SceneError(section, "expected a table")
        value = plain(value)
        if value is None and index is None:
            target.pop(key, None)
            continue
        if index is not None:
            value = _with_element(dotted, raw, target, section, key, index, value)
        target[key] = value
        for other in group:  # one of the group replaces the others
            if other != name:
                target.pop(other.rpartition(".")[2], None)
        if key == "material":
            for value_key in MATERIAL_KEYS:
                if f"{section}.{value_key}" not in keys:
                    target.pop(value_key, None)


def _with_element(dotted: str, root: dict[str, Any], target: dict[str, Any], section: str, key: str,
                  index: int, value: Any) -> list[Any]:
    """The list of `section.key` with element `index` (from 1) set to `value`; `root` is the
    whole scene (the number of links, and the tip radius a joint radius defaults to)."""
    current = plain(target.get(key))
    if current is None and section == "initial" and key in ("q", "q_deg"):
        other = plain(target.get("q_deg" if key == "q" else "q"))  # the angles in the other unit
        if isinstance(other, list) and all(isinstance(v, (int, float)) for v in other):
            convert = math.radians if key == "q" else math.degrees
            current = [convert(v) for v in other]
    joints = SCHEMA[section][key].kind == "joint_floats"  # one element per joint, not per link
    if current is None and joints:  # not given: every joint has the tip's radius
        current = plain(root.get("rod", {}).get("tip_radius")) if isinstance(root.get("rod"), dict) else None
    if current is None:
        raise SceneError(dotted, f"the scene does not set {section}.{key}, so it has no element {index}")
    if not isinstance(current, list):  # one number for every link (chain.length, chain.mass) or joint
        chain = root.get("chain")
        links = chain.get("links") if isinstance(chain, dict) else None
        if not isinstance(links, int) or isinstance(links, bool) or links < 1:
            raise SceneError(dotted, "set chain.links before an element of a per-link list")
        current = [current] * (links - 1 if joints else links)
    if index > len(current):
        per = "joint" if joints else "link"
        raise SceneError(dotted, f"index {index} is out of range: {section}.{key} has "
                                 f"{len(current)} elements (one per {per}, numbered from 1)")
    return [value if i == index - 1 else v for i, v in enumerate(current)]


def tables_copied(raw: Mapping[str, Any]) -> dict[str, Any]:
    """The scene's top level and its tables copied, so that overrides change the copy only
    (values are replaced, never changed in place; `plain` makes them plain when read)."""
    return {k: dict(v) if isinstance(v, (dict, abc.Mapping)) else v for k, v in raw.items()}
