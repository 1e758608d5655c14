"""Stage 3 of the pipeline: the contact laws of MODEL.md sections 4 and 5, as sympy expressions.

Each law is a function of the penetration `delta` and of named material parameters, so that
the emitted C reads like the equations and one build serves a whole parameter sweep.
"""
from __future__ import annotations

import sympy as sm

from .thresholds import THRESHOLD

# Parameters of the contact, named as in the model documentation.
delta = sm.Symbol("delta")  # penetration, positive into the surface
E_star = sm.Symbol("E_star", positive=True)  # reduced modulus (Eq. 7)
R = sm.Symbol("R", positive=True)  # reduced tip radius (Eq. 8)
delta_c = sm.Symbol("delta_c", positive=True)  # critical (yield) deformation
P_c = sm.Symbol("P_c", positive=True)  # critical load
C_j = sm.Symbol("C_j", positive=True)  # critical yield coefficient
B = sm.Symbol("B", positive=True)  # Jackson-Green exponent B = 0.14 exp(23 S_y / E*)
inv_delta_c = sm.Symbol("inv_delta_c", positive=True)  # 1/delta_c: w = delta/delta_c as a product
theta_c = sm.Symbol("theta_c", positive=True)  # pi a/R of the Jackson-Green law at delta = delta_c
delta_r = sm.Symbol("delta_r", nonnegative=True)  # permanent deformation (set at max compression)
R_res = sm.Symbol("R_res", positive=True)  # unloading radius (set at max compression)
mu = sm.Symbol("mu", nonnegative=True)  # friction coefficient
eps = sm.Symbol("eps", positive=True)  # regularization speed of the friction sign
slip = sm.Symbol("slip")  # exact Coulomb: +1 or -1 while slipping, 0 while stuck (phase machine)
v_Bx = sm.Symbol("v_Bx")  # tangential tip velocity
s_frozen = sm.Symbol("s_frozen")  # frozen friction: the sign of v_Bx at contact start (phase machine)

YIELD_ONSET = sm.nsimplify(THRESHOLD["YIELD_ONSET"])  # phase I ends at delta = 19/10 delta_c, exactly


def hertz_force(d: sm.Expr = delta, radius: sm.Expr = R) -> sm.Expr:
    """Phase I (Eq. 9): F = 4/3 E* R^(1/2) delta^(3/2)."""
    return sm.Rational(4, 3) * E_star * sm.sqrt(radius) * d ** sm.Rational(3, 2)


w = sm.Symbol("w", positive=True)  # delta / delta_c
ln_w = sm.Symbol("ln_w", real=True)  # log(w)
sqrt_w = sm.Symbol("sqrt_w", positive=True)
# The law's three fractional powers share one exponential: with r = w^(1/180),
# w^(5/12) = w^(1/2) / r^15, w^(5/9) = w^(1/2) r^10 and w^(11/10) = w r^18. The products
# are exact to 3.3e-15 relative on 1.9 <= w <= 1e5 (exp(k ln w): 2.8e-15), and save two
# exponentials per call of the costliest right-hand side.
r, r2, r4, r8, r10 = sm.symbols("r r2 r4 r8 r10", positive=True)
w_5_12, w_5_9, w_11_10 = sm.symbols("w_5_12 w_5_9 w_11_10", positive=True)
theta = sm.Symbol("theta", positive=True)  # pi a / R, a the contact radius
H_over_S_y = sm.Symbol("H_over_S_y", positive=True)  # hardness over yield strength


def jackson_green_steps(d: sm.Expr = delta) -> tuple[tuple[sm.Symbol, sm.Expr], ...]:
    """Phase II (Eq. 10), the modified Jackson-Green law, as named steps ending in F.

    The contact radius enters as theta = pi a / R, with a = (R delta (w / 1.9)^B)^(1/2):
    theta = theta_c w^((1 + B) / 2), theta_c = pi (delta_c / R)^(1/2) 1.9^(-B/2) derived
    once per parameter set (`material_constants`), as is 1/delta_c. Per call that leaves
    one exponential where a took two square roots, an exponential and two divisions:
    about 8 ns of this costliest right-hand side's 101 (measured when it was made: the git
    history of docs/benchmarks.md)."""
    F = sm.Symbol("F")
    return (
        (w, d * inv_delta_c),
        (ln_w, sm.log(w)),
        (sqrt_w, sm.sqrt(w)),
        (r, sm.exp(ln_w / 180)),
        (r2, r * r), (r4, r2 * r2), (r8, r4 * r4), (r10, r8 * r2),
        (w_5_12, sqrt_w / (r10 * r4 * r)),
        (w_5_9, sqrt_w * r10),
        (w_11_10, w * r10 * r8),
        (theta, theta_c * sm.exp((1 + B) / 2 * ln_w)),
        (H_over_S_y, sm.Float(2.84) - sm.Float(0.92) * (1 - sm.cos(theta))),
        (F, P_c * (sm.exp(-sm.Float(0.17) * w_5_12) * w * sqrt_w
                   + 4 * H_over_S_y / C_j * (1 - sm.exp(-w_5_9 / 78)) * w_11_10)),
    )


def restitution_force(d: sm.Expr = delta) -> sm.Expr:
    """Phase III (Eq. 11): elastic unloading about the permanent deformation delta_r."""
    return hertz_force(d - delta_r, R_res)


# Materials (the scene's inputs) and the constants of MODEL section 3 derived from them.
E_rod, E_surface = sm.symbols("E_rod E_surface", positive=True)
nu_rod, nu_surface = sm.symbols("nu_rod nu_surface", real=True)
S_y_rod, S_y_surface = sm.symbols("S_y_rod S_y_surface", positive=True)
R_tip = sm.Symbol("R_tip", positive=True)
MATERIAL_INPUTS = (E_rod, nu_rod, S_y_rod, R_tip, E_surface, nu_surface, S_y_surface)  # the scene sets these
S_y = sm.Symbol("S_y", positive=True)  # yield strength of the weaker material
nu = sm.Symbol("nu", real=True)  # its Poisson ratio


def material_constants() -> tuple[tuple[sm.Symbol, sm.Expr], ...]:
    """E*, R, C_j, delta_c, P_c and B from the two materials and the tip radius, as named
    steps: the constants every force law and switch law is written in (and two that only
    spare the elasto-plastic law work per call: 1/delta_c and theta_c)."""
    weaker_rod = S_y_rod <= S_y_surface
    return (
        # Eq. 7 as it is written: a sum of compliances, finite for any modulus a double holds
        # (the product of two moduli overflows from 1e154 on: a rigid surface of E = 1e300)
        (E_star, 1 / ((1 - nu_rod ** 2) / E_rod + (1 - nu_surface ** 2) / E_surface)),
        (R, R_tip),  # 1/R = 1/R_tip + 1/R_surface, with R_surface infinite for a flat
        (S_y, sm.Piecewise((S_y_rod, weaker_rod), (S_y_surface, True))),
        (nu, sm.Piecewise((nu_rod, weaker_rod), (nu_surface, True))),
        (C_j, sm.Float(1.295) * sm.exp(sm.Float(0.736) * nu)),
        (delta_c, (sm.pi * C_j * S_y / (2 * E_star)) ** 2 * R),
        (P_c, sm.Rational(4, 3) * (R / E_star) ** 2 * (sm.pi * C_j * S_y / 2) ** 3),
        (B, sm.Float(0.14) * sm.exp(23 * S_y / E_star)),
        (inv_delta_c, 1 / delta_c),
        (theta_c, sm.pi * sm.sqrt(delta_c / R) * sm.exp(-B / 2 * sm.log(YIELD_ONSET))),
    )


# Laws applied at the switches (MODEL section 4), emitted into the C phase machine.
P_m = sm.Symbol("P_m", positive=True)  # force at maximum compression
delta_max = sm.Symbol("delta_max", positive=True)  # penetration at maximum compression


def residual_deformation(d_m: sm.Expr = delta_max) -> sm.Expr:
    """Eq. 12 as this project reads it (the paper's print is garbled; docs/model.md):
    delta_r = delta_m [1 - ((delta_m/delta_c + 5.5)/6.5)^(-1/2)], never negative."""
    return sm.Max(d_m * (1 - ((d_m / delta_c + sm.Float(5.5)) / sm.Float(6.5)) ** -sm.Rational(1, 2)), 0)


def unloading_radius(d_m: sm.Expr = delta_max, force: sm.Expr = P_m, d_r: sm.Expr = delta_r) -> sm.Expr:
    """R_res such that the restitution force (Eq. 11) equals P_m at delta_m: continuity."""
    return (3 * force / (4 * E_star)) ** 2 / (d_m - d_r) ** 3


def friction_sign(v: sm.Expr = v_Bx) -> sm.Expr:
    """The regularized sign of MODEL.md section 5: v / sqrt(v^2 + eps^2)."""
    return v / sm.sqrt(v ** 2 + eps ** 2)


def friction_force(normal_force: sm.Expr, sign: sm.Expr) -> sm.Expr:
    """Eq. 14: F_f = -mu |F| s, along x, with s the (regularized or exact) sign of v_Bx."""
    return -mu * normal_force * sign


# ---- the field's other laws (docs/contact-laws.md), chosen by contact.model ----
delta_rate = sm.Symbol("delta_rate")  # d(delta)/dt, positive into the surface
restitution = sm.Symbol("restitution", positive=True)  # e, the damped law's design coefficient
chi = sm.Symbol("chi", nonnegative=True)  # the damping factor the law gives e
v_0 = sm.Symbol("v_0", positive=True)  # the point's normal speed at the start of its impact (phase machine)
stiffness = sm.Symbol("stiffness", positive=True)  # Kelvin-Voigt spring, N/m
damping = sm.Symbol("damping", nonnegative=True)  # Kelvin-Voigt dashpot, N s/m
p_y = sm.Symbol("p_y", positive=True)  # Thornton's limiting contact pressure, Pa
delta_y = sm.Symbol("delta_y", positive=True)  # Thornton: the penetration where p_y is reached
F_y = sm.Symbol("F_y", positive=True)  # Thornton: the force there
k_y = sm.Symbol("k_y", positive=True)  # Thornton: the slope pi p_y R of the plastic loading

# chi(e) of F = K delta^1.5 (1 + chi v/v0), each law's own (Machado et al. 2012, Table 1)
DAMPING_FACTOR = {
    "hunt-crossley": sm.Rational(3, 2) * (1 - restitution),
    "lankarani-nikravesh": sm.Rational(3, 4) * (1 - restitution ** 2),
    "flores": sm.Rational(8, 5) * (1 - restitution) / restitution,
    "gonthier": (1 - restitution ** 2) / restitution,
}


def damped_hertz_force() -> sm.Expr:
    """The Hertz law with hysteresis damping: F = K delta^1.5 (1 + chi v/v0)."""
    return hertz_force() * (1 + chi * delta_rate / v_0)


def kelvin_voigt_force() -> sm.Expr:
    """The linear spring-dashpot: F = k delta + c v."""
    return stiffness * delta + damping * delta_rate


def force_zero(model: str) -> sm.Expr:
    """What a damped law's force has the sign of while the point penetrates: the force's zero,
    where the point leaves the surface (the force never pulls)."""
    if model == "kelvin-voigt":
        return kelvin_voigt_force()
    return 1 + chi * delta_rate / v_0


def thornton_loading(d: sm.Expr = delta) -> sm.Expr:
    """Thornton (1997) Eq. 6: past the limiting pressure, F = F_y + pi p_y R (delta - delta_y)."""
    return F_y + k_y * (d - delta_y)


def thornton_residual(d_m: sm.Expr = delta_max) -> sm.Expr:
    """Thornton's permanent set delta_p after a maximum delta_m (0 below yield): unloading is
    Hertzian about R_p = (4 E*/(3 F*)) ((2 F* + F_y)/(2 pi p_y))^(3/2) (Eq. 9), through the
    maximum F* = F_y + pi p_y R (delta_m - delta_y), so delta_m - delta_p =
    (3 F*/(4 E* R_p^(1/2)))^(2/3). Written in the point's own constants: 4 E*/3 =
    F_y/(R^(1/2) delta_y^(3/2)) and 2 pi p_y = 2 k_y/R."""
    F_m = thornton_loading(d_m)
    K_R = F_y / (sm.sqrt(R) * delta_y ** sm.Rational(3, 2))  # 4/3 E*
    R_p = K_R / F_m * (R * (2 * F_m + F_y) / (2 * k_y)) ** sm.Rational(3, 2)
    return sm.Piecewise((0, d_m <= delta_y), (d_m - (F_m / (K_R * sm.sqrt(R_p))) ** sm.Rational(2, 3), True))


def law_constants(model: str) -> tuple[tuple[sm.Symbol, sm.Expr], ...]:
    """The constants a law derives from its scene keys, after the materials' (material_constants)."""
    if model in DAMPING_FACTOR:
        return ((chi, DAMPING_FACTOR[model]),)
    if model == "thornton":
        return ((delta_y, (sm.pi * p_y / (2 * E_star)) ** 2 * R),
                (F_y, hertz_force(delta_y)),
                (k_y, sm.pi * p_y * R))
    return ()


LAW_INPUTS = {**{name: (restitution,) for name in DAMPING_FACTOR}, "kelvin-voigt": (stiffness, damping),
              "thornton": (p_y,)}  # the scene's inputs each law reads (codegen/parameters.py)
