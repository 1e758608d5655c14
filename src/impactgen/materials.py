"""Named materials: the paper's steel and common engineering alloys, each with Young's
modulus, Poisson's ratio, yield strength and density, and where the values come from.

A scene names one with ``rod.material`` or ``surface.material`` (docs/scene.md); the keys
``E``, ``nu``, ``yield_strength`` and ``density`` given beside it override its values. This
table is the one statement of these values; `impactgen materials` prints it.

Room-temperature handbook values of one temper or condition each (a yield strength in
particular depends on it): for a real part, check its certificate.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class NamedMaterial:
    """One row of the table, in SI units."""

    name: str
    E: float  # Pa, Young's modulus
    nu: float  # Poisson's ratio
    yield_strength: float  # Pa, tensile yield strength (0.2 % proof)
    density: float  # kg/m^3
    description: str
    source: str


_MATWEB = "MatWeb (ASM Aerospace Specification Metals data sheet)"

MATERIALS: dict[str, NamedMaterial] = {m.name: m for m in (
    NamedMaterial("steel-paper", 210e9, 0.29, 1.12e9, 7800.0, "the steel of the paper's chain and flat",
                  "Marghitu and Zhao, Mathematics 2020, 8, 1202, Table 1"),
    NamedMaterial("steel-a36", 200e9, 0.26, 250e6, 7850.0, "structural steel ASTM A36, plate",
                  "MatWeb, ASTM A36 Steel, plate"),
    NamedMaterial("aluminium-6061-t6", 68.9e9, 0.33, 276e6, 2700.0, "aluminium alloy 6061-T6",
                  f"{_MATWEB}, Aluminum 6061-T6"),
    NamedMaterial("aluminium-7075-t6", 71.7e9, 0.33, 503e6, 2810.0, "aluminium alloy 7075-T6",
                  f"{_MATWEB}, Aluminum 7075-T6"),
    NamedMaterial("ti-6al-4v", 114e9, 0.33, 830e6, 4430.0, "titanium Ti-6Al-4V (grade 5), annealed bar",
                  "MatWeb (ASM), Titanium Ti-6Al-4V (Grade 5), Annealed Bar"),
    NamedMaterial("brass-c36000", 97e9, 0.31, 310e6, 8500.0, "free-cutting brass UNS C36000, half hard (H02)",
                  "MatWeb, Free-Cutting Brass UNS C36000 (yield 124-310 MPa by temper; 310 MPa: half-hard rod)"),
)}
MATERIAL_NAMES = tuple(MATERIALS)
# The scene keys a named material gives, in [rod] (all four) and [surface] (the first three:
# the surface's mass does not enter the model).
MATERIAL_KEYS = ("E", "nu", "yield_strength", "density")


def format_materials() -> list[str]:
    """The table as `impactgen materials` prints it."""
    lines = [f"{'name':<18} {'E (GPa)':>8} {'nu':>6} {'S_y (MPa)':>10} {'density (kg/m^3)':>17}  description; source"]
    for m in MATERIALS.values():
        lines.append(f"{m.name:<18} {m.E / 1e9:8.1f} {m.nu:6.3f} {m.yield_strength / 1e6:10.0f} "
                     f"{m.density:17.0f}  {m.description}; {m.source}")
    lines.append("use one with rod.material = \"NAME\" or surface.material = \"NAME\"; a key given beside it "
                 "(rod.E, ...) overrides its value (docs/scene.md)")
    return lines
