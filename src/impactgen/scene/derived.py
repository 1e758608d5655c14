"""Keys that give other keys' values: a named material (``rod.material``, ``surface.material``)
its E, nu, yield strength and density where the table does not give them; a density with the
links' cross-section (``chain.diameter`` or ``chain.area``) the links' masses.

A link's mass is density x area x length; its inertia follows from the mass by the model's one
rule, I = m L^2 / 12 (a slender bar, MODEL section 1): a round bar's own m d^2 / 16 about its
centre is left out, as the model leaves out the bar's thickness everywhere.
"""
from __future__ import annotations

import math
from typing import Any, Callable

from ..errors import SceneError
from ..materials import MATERIAL_KEYS, MATERIALS
from .schema import SCHEMA, positive
from .values import coerce, plain


def fill_from_material(section: str, table: dict[str, Any]) -> None:
    """Put the values of the table's named material (if it names one) into `table` where it
    gives none: E, nu and yield_strength, and for the rod its density."""
    if table.get("material") is None:
        return
    dotted = f"{section}.material"
    named = MATERIALS[coerce(dotted, plain(table["material"]), SCHEMA[section]["material"], 0)]
    for key in MATERIAL_KEYS:
        if key in SCHEMA[section]:
            table.setdefault(key, getattr(named, key))


Get = Callable[..., Any]  # loading's reader of one key: get(section, key, n)


def link_masses(get: Get, mass_given: bool, n: int, length: tuple[float, ...], density: float | None
                ) -> tuple[tuple[float, ...], tuple[float, ...] | None, tuple[float, ...] | None]:
    """(masses, diameter, area) of the links: chain.mass as given, or density x area x length
    from chain.diameter or chain.area; SceneError naming the keys where the masses are given
    twice or the cross-section has no density."""
    diameter, area = get("chain", "diameter", n), get("chain", "area", n)
    if diameter is None and area is None:
        return get("chain", "mass", n), None, None
    if diameter is not None and area is not None:
        raise SceneError("chain.area", "the links' cross-section is given twice, by chain.diameter and "
                                       "chain.area: give one")
    given = "chain.diameter" if diameter is not None else "chain.area"
    if mass_given:
        raise SceneError("chain.mass", f"the links' masses are given twice, by chain.mass and by {given} "
                                       "(with rod.density): give one")
    if density is None:
        raise SceneError(given, f"{given} gives the links' masses with a density: give rod.density (kg/m^3) "
                                "or rod.material (see 'impactgen materials')")
    areas = area if area is not None else tuple(math.pi * d * d / 4 for d in diameter)
    masses = tuple(density * a * L for a, L in zip(areas, length))
    check = SCHEMA["chain"]["mass"].check or positive
    for i, m in enumerate(masses, start=1):  # in range, as a given mass must be
        reason = check(m) if math.isfinite(m) else "must be finite"
        if reason:
            raise SceneError(f"chain.mass[{i}]", f"{reason}, got {m!r} (rod.density x {given} x chain.length)")
    return masses, diameter, area
