"""Numbers from the contact laws' sympy expressions (codegen/contact.py) for Python code.

The C model and its phase machine are printed from these expressions; the benchmarks, the
crosscheck and the tests evaluate the very same expressions here (lambdified once, on first
use: sympy is imported then, not when impactgen is), so no law is written twice. The
reference engine keeps its own, independent statement of them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

from .codegen.thresholds import THRESHOLD
from .scene import Scene

YIELD_ONSET = THRESHOLD["YIELD_ONSET"]  # phase I ends at delta = 1.9 delta_c


@dataclass(frozen=True)
class ContactConstants:
    E_star: float  # reduced modulus, Pa (Eq. 7)
    R: float  # reduced radius, m (Eq. 8)
    S_y: float  # yield strength of the weaker material, Pa
    nu: float  # its Poisson ratio
    C_j: float  # critical yield coefficient
    delta_c: float  # critical deformation, m
    P_c: float  # critical load, N
    B: float  # Jackson-Green exponent


@lru_cache(maxsize=None)
def _lambdified(name: str) -> Callable[..., float]:
    """One law as a Python function of plain floats."""
    import sympy as sm

    from .codegen import contact as law
    steps = law.material_constants()
    if name == "constants":
        values = {}
        for symbol, expr in steps:
            values[symbol] = expr.xreplace(values)
        fields = [law.E_star, law.R, law.S_y, law.nu, law.C_j, law.delta_c, law.P_c, law.B]
        return sm.lambdify(law.MATERIAL_INPUTS, [values[f] for f in fields], modules="math")
    if name == "residual":
        return sm.lambdify((law.delta_max, law.delta_c), law.residual_deformation(), modules="math")
    if name == "unloading":
        return sm.lambdify((law.delta_max, law.P_m, law.delta_r, law.E_star), law.unloading_radius(),
                           modules="math")
    if name == "hertz":
        return sm.lambdify((law.delta, law.E_star, law.R), law.hertz_force(), modules="math")
    raise KeyError(name)


def contact_constants(scene: Scene, radius: float | None = None) -> ContactConstants:
    """E*, R, S_y, nu, C_j, delta_c, P_c and B of a scene's materials (MODEL section 3), at
    its tip, or at a contact point of this `radius` (a joint's)."""
    rod, flat = scene.rod, scene.surface
    return _constants_of(rod.E, rod.nu, rod.yield_strength, scene.tip_radius if radius is None else radius,
                         flat.E, flat.nu, flat.yield_strength)


@lru_cache(maxsize=1024)  # a sweep over angles and speeds asks for the same materials each case
def _constants_of(*materials: float) -> ContactConstants:
    return ContactConstants(*map(float, _lambdified("constants")(*materials)))


def residual_deformation(delta_max: float, delta_c: float) -> float:
    """Eq. 12 as this project reads it: the permanent deformation after delta_max."""
    return float(_lambdified("residual")(delta_max, delta_c))


def unloading_radius(P_m: float, delta_m: float, delta_r: float, E_star: float) -> float:
    """R_res such that the restitution force equals P_m at delta_m (continuity)."""
    return float(_lambdified("unloading")(delta_m, P_m, delta_r, E_star))


def hertz_force(delta: float, E_star: float, R: float) -> float:
    """Eq. 9: F = 4/3 E* sqrt(R) delta^(3/2) (zero out of contact)."""
    return float(_lambdified("hertz")(max(delta, 0.0), E_star, R))


def contact_radius(delta: float, c: ContactConstants) -> float:
    """The contact radius a of the Jackson-Green law (Eq. 10) at penetration delta."""
    return math.sqrt(c.R * delta * (delta / (YIELD_ONSET * c.delta_c)) ** c.B)
