"""Material constants of the contact (MODEL section 3) and the laws applied at phase switches.

These are the numbers the generated C takes as runtime parameters, and the two laws the
phase machine evaluates at maximum compression: the permanent deformation (Eq. 12) and the
unloading radius that keeps the force continuous. The permanent-deformation law is a named,
replaceable function (`RESIDUAL_LAWS`), since the paper's printed Eq. 12 is garbled.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from .scene import Scene

YIELD_ONSET = 1.9  # phase I ends at delta = 1.9 delta_c


@dataclass(frozen=True)
class ContactConstants:
    E_star: float  # reduced modulus, Pa (Eq. 7)
    R: float  # reduced radius, m (Eq. 8; the tip radius against a flat)
    S_y: float  # yield strength of the weaker material, Pa
    nu: float  # Poisson ratio of the weaker material
    C_j: float  # critical yield coefficient
    delta_c: float  # critical deformation, m
    P_c: float  # critical load, N
    B: float  # Jackson-Green exponent


def contact_constants(scene: Scene) -> ContactConstants:
    rod, flat = scene.rod, scene.surface
    E_star = rod.E * flat.E / (flat.E * (1 - rod.nu ** 2) + rod.E * (1 - flat.nu ** 2))
    R = scene.tip_radius  # 1/R = 1/R_r + 1/R_s with R_s = infinity
    weaker = rod if rod.yield_strength <= flat.yield_strength else flat
    S_y, nu = weaker.yield_strength, weaker.nu
    C_j = 1.295 * math.exp(0.736 * nu)
    delta_c = (math.pi * C_j * S_y / (2 * E_star)) ** 2 * R
    P_c = 4.0 / 3.0 * (R / E_star) ** 2 * (math.pi * C_j * S_y / 2) ** 3
    B = 0.14 * math.exp(23 * S_y / E_star)
    return ContactConstants(E_star, R, S_y, nu, C_j, delta_c, P_c, B)


def residual_deformation_marghitu_zhao(delta_m: float, delta_c: float) -> float:
    """Eq. 12 as this project reads it (MODEL section 4, note on Eq. 12):
    delta_r = delta_m [1 - ((delta_m/delta_c + 5.5)/6.5)^(-1/2)], clamped to >= 0."""
    delta_r = delta_m * (1.0 - ((delta_m / delta_c + 5.5) / 6.5) ** -0.5)
    return max(delta_r, 0.0)


ResidualLaw = Callable[[float, float], float]
RESIDUAL_LAWS: dict[str, ResidualLaw] = {"marghitu-zhao": residual_deformation_marghitu_zhao}


def unloading_radius(P_m: float, delta_m: float, delta_r: float, E_star: float) -> float:
    """R_res such that the restitution force equals P_m at delta_m (continuity)."""
    return (3.0 * P_m / (4.0 * E_star)) ** 2 / (delta_m - delta_r) ** 3


def hertz_force(delta: float, E_star: float, R: float) -> float:
    """Eq. 9, for checks and for P_c: F = 4/3 E* sqrt(R) delta^(3/2)."""
    return 4.0 / 3.0 * E_star * math.sqrt(R) * max(delta, 0.0) ** 1.5
