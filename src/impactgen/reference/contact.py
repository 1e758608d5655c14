"""The contact laws of one point, written again from the model documentation (docs/model.md
sections 2 to 5): Hertz, Jackson-Green, restitution and reloading, friction, and the state a
point fixes at its switches."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import SceneError
from ..scene import Scene

YIELD_ONSET = 1.9  # the elastic phase yields at delta = 1.9 delta_c (Jackson-Green's onset)
# chi(e) of the Hertz laws with hysteresis damping, F = K delta^1.5 (1 + chi v/v0) (docs/contact-laws.md)
DAMPING = {"hunt-crossley": lambda e: 1.5 * (1 - e), "lankarani-nikravesh": lambda e: 0.75 * (1 - e * e),
           "flores": lambda e: 1.6 * (1 - e) / e, "gonthier": lambda e: (1 - e * e) / e}


@dataclass
class Contact:
    """Material constants (docs/model.md section 3) and the state fixed at the switches."""

    E_star: float
    R: float
    delta_c: float
    P_c: float
    C_j: float
    B: float
    mu: float
    eps: float
    y_s: float
    plastic: bool
    exact_coulomb: bool = False
    slip: float = 1.0  # exact Coulomb: +1 / -1 slipping along +x / -x, 0 stuck
    frozen: bool = False  # friction keeps the direction it had at contact start
    frozen_sign: float = 0.0  # frozen: the sign of v_x when the contact began
    delta_m: float = 0.0
    delta_r: float = 0.0
    R_res: float = 0.0
    law: str = "three-phase"  # contact.model
    chi: float = 0.0  # a damped Hertz law's damping factor
    k: float = 0.0  # kelvin-voigt's spring, N/m
    c: float = 0.0  # and dashpot, N s/m
    v0: float = math.inf  # the normal speed at the start of the impact (inf: none, so undamped)
    p_y: float = 0.0  # thornton's limiting contact pressure, Pa

    @property
    def rate_law(self) -> bool:
        """Whether the force depends on d(delta)/dt (and may fall to 0 while penetrating)."""
        return self.law in DAMPING or self.law == "kelvin-voigt"

    @classmethod
    def from_scene(cls, scene: Scene, y_s: float, radius: float | None = None) -> "Contact":
        """The contact of a point of contact radius `radius` (rod.tip_radius, the radius of
        every point that contact.joint_radius does not set, by default) on the surface y = y_s."""
        Er, Es = scene.rod.E, scene.surface.E
        E_star = 1.0 / ((1 - scene.rod.nu ** 2) / Er + (1 - scene.surface.nu ** 2) / Es)
        weak = min((scene.rod, scene.surface), key=lambda mat: mat.yield_strength)
        C_j = 1.295 * math.exp(0.736 * weak.nu)
        R = scene.tip_radius if radius is None else radius
        p0 = math.pi * C_j * weak.yield_strength / 2  # the pressure scale pi C_j S_y / 2
        delta_c, P_c = R * (p0 / E_star) ** 2, 4.0 / 3.0 * (R / E_star) ** 2 * p0 ** 3
        if not all(0 < v < math.inf for v in (E_star, delta_c, P_c)):  # the laws divide by them
            key, value = ("rod.E", Er) if Er >= Es else ("surface.E", Es)
            raise SceneError(key, f"{value!r} is outside its physical range (the contact constants E*, delta_c "
                                  "and P_c it gives leave double precision's range)")
        return cls(E_star=E_star, R=R, delta_c=delta_c, P_c=P_c, C_j=C_j,
                   B=0.14 * math.exp(23 * weak.yield_strength / E_star),
                   mu=scene.contact.friction, eps=scene.contact.friction_eps, y_s=y_s,
                   plastic=scene.contact.model in ("three-phase", "thornton"), R_res=R,
                   exact_coulomb=scene.contact.friction_mode == "coulomb" and scene.contact.friction > 0,
                   frozen=scene.contact.friction_mode == "frozen", law=scene.contact.model,
                   chi=DAMPING[scene.contact.model](scene.contact.restitution) if scene.contact.model in DAMPING else 0.0,
                   k=scene.contact.stiffness or 0.0, c=scene.contact.damping or 0.0,
                   p_y=scene.contact.limiting_pressure or 0.0)

    @property
    def yield_depth(self) -> float:
        """The penetration where loading leaves Hertz: 1.9 delta_c (Jackson-Green), or
        Thornton's delta_y = (pi p_y / (2 E*))^2 R, where Hertz's peak pressure reaches p_y."""
        if self.law == "thornton":
            return (math.pi * self.p_y / (2 * self.E_star)) ** 2 * self.R
        return YIELD_ONSET * self.delta_c

    def thornton(self, delta: float) -> float:
        """Thornton's plastic loading: F = F_y + pi p_y R (delta - delta_y)."""
        d_y = self.yield_depth
        return self.hertz(d_y, self.R) + math.pi * self.p_y * self.R * (delta - d_y) if delta > 0 else 0.0

    def hertz(self, delta: float, radius: float) -> float:
        return 4.0 / 3.0 * self.E_star * math.sqrt(radius) * delta ** 1.5 if delta > 0 else 0.0

    def jackson_green(self, delta: float) -> float:
        if delta <= 0:
            return 0.0
        w = delta / self.delta_c
        a = math.sqrt(self.R * delta * (delta / (YIELD_ONSET * self.delta_c)) ** self.B)
        H_Sy = 2.84 - 0.92 * (1 - math.cos(math.pi * a / self.R))
        return self.P_c * (math.exp(-0.17 * w ** (5 / 12)) * w ** 1.5
                           + 4 * H_Sy / self.C_j * (1 - math.exp(-(w ** (5 / 9)) / 78)) * w ** 1.1)

    def normal_force(self, phase: str, delta: float, rate: float = 0.0) -> float:
        """The force in `phase` at penetration delta, moving into the surface at `rate`."""
        if self.rate_law:
            return self.damped(delta, rate) if phase != "free" else 0.0
        if phase == "elastic":
            return self.hertz(delta, self.R)
        if phase == "elastoplastic":
            return self.thornton(delta) if self.law == "thornton" else self.jackson_green(delta)
        if phase in ("restitution", "reloading"):
            return self.hertz(delta - self.delta_r, self.R_res) if self.plastic else self.hertz(delta, self.R)
        return 0.0

    def damped(self, delta: float, rate: float) -> float:
        """A damped law's force while the point penetrates (0 outside; the dashpot's from the
        instant of contact, delta = 0)."""
        if self.law == "kelvin-voigt":
            return self.k * delta + self.c * rate if delta >= 0 else 0.0
        if delta <= 0:
            return 0.0
        return self.hertz(delta, self.R) * (1 + self.chi * rate / self.v0)

    def force_sign(self, delta: float, rate: float) -> float:
        """What a damped force has the sign of while penetrating: its zero ends the impact."""
        if self.law == "kelvin-voigt":
            return self.k * delta + self.c * rate
        return 1 + self.chi * rate / self.v0

    def friction(self, F: float, v_x: float) -> float:
        """Sliding friction: the regularized sign of v_x, or exact Coulomb's fixed slip sign."""
        if self.mu == 0:
            return 0.0
        if self.exact_coulomb:
            return -self.mu * F * self.slip
        if self.frozen:
            return -self.mu * F * self.frozen_sign
        return -self.mu * F * v_x / math.sqrt(v_x ** 2 + self.eps ** 2)

    def at_maximum_compression(self, delta_m: float, P_m: float) -> None:
        """Fix delta_m, delta_r (Eq. 12, clamped; Thornton's delta_p) and R_res (continuity
        at delta_m)."""
        self.delta_m = delta_m
        if not self.plastic:
            self.delta_r, self.R_res = 0.0, self.R
            return
        if self.law == "thornton":
            self.delta_r = self.thornton_set(delta_m, P_m)
        else:
            self.delta_r = max(0.0, delta_m * (1 - math.sqrt(6.5 / (delta_m / self.delta_c + 5.5))))
        self.R_res = (3 * P_m / (4 * self.E_star)) ** 2 / (delta_m - self.delta_r) ** 3

    def thornton_set(self, delta_m: float, P_m: float) -> float:
        """Thornton's permanent set after a maximum (delta_m, P_m): unloading is Hertzian
        about R_p = (4 E* / (3 P_m)) ((2 P_m + F_y) / (2 pi p_y))^(3/2) (Thornton 1997, Eq. 9)
        from the maximum down to delta_p (0 below yield)."""
        d_y = self.yield_depth
        if delta_m <= d_y:
            return 0.0
        F_y = self.hertz(d_y, self.R)
        R_p = 4 * self.E_star / (3 * P_m) * ((2 * P_m + F_y) / (2 * math.pi * self.p_y)) ** 1.5
        return delta_m - (3 * P_m / (4 * self.E_star * math.sqrt(R_p))) ** (2 / 3)

    def reset(self) -> None:
        self.delta_m, self.delta_r, self.R_res = 0.0, 0.0, self.R
        self.v0 = math.inf
