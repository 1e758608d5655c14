"""The runtime parameters of a generated model: one table, read by everything that names them.

Each row says what a parameter is (C field and sympy symbol `name`, unit, description), how a
scene sets it (`key`, its dotted scene key, and `read`), who sets it (`kind`) and its FMI
causality. The C parameter struct, the filling from a scene, the FMU's modelDescription.xml,
the bounds the C checks and the parameter table of docs/embedding.md are all printed from
this table, so the names never have to agree by string. The rules across inputs (a yield
strength below its modulus) are one table too, `RULES`, which the scene checks and the C
start check both apply.

Kinds:
- "input": the scene sets it (an FMI parameter);
- "derived": computed from the inputs by `<prefix>_derive` (E*, delta_c, ...: an FMI
  calculatedParameter), with the sympy expressions of codegen/contact.py;
- "machine": set by the phase machine as the impact goes on (delta_m, delta_r, R_res, ...).

A per-link row (`per_link`) stands for n fields: `L1`, `L2`, ... and `chain.length[1]`, ...;
a per-joint row (`per_joint`) for one field per joint that can touch the surface (`R_joint2`,
`contact.joint_radius[2]`): a model without such joints has none. A per-point row (`per_point`)
is a field of every contact point's own record, `point[k]` (the joints that can touch the
surface, then the tip): the constants its radius gives and the state the machine keeps for it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from operator import attrgetter
from typing import Any, Callable

INF = math.inf


@dataclass(frozen=True)
class Parameter:
    name: str  # C field, sympy symbol; per-link rows append the link number
    key: str  # scene key; per-link rows end in "[{i}]"
    unit: str
    doc: str
    kind: str  # "input" | "derived" | "machine"
    needs: str = "always"  # "always" | "friction" | "regularized" | "coulomb" | "frozen" | "used" | "base"
    per_link: bool = False
    per_joint: bool = False
    per_point: bool = False  # a field of each contact point's record (point[k].name), not of the struct
    # the value from a scene (a per-link row: the tuple of the links'): the attribute it names
    # (attrgetter: no Python call per row and run), or what a function computes from the scene
    read: Callable[[Any], Any] | None = None
    low: float = -INF  # physical range of an input, for the C check (fmi2SetReal)
    high: float = INF
    low_open: bool = False  # the range excludes `low`
    high_open: bool = False
    fmi_type: str = "Real"  # "Real" | "Boolean"

    def value(self, scene: Any, link: int = 0) -> float:
        """This row's value (for `link`, from 0) in `scene`."""
        assert self.read is not None, f"{self.name} is not set by a scene"
        return self.read(scene)[link] if self.per_link or self.per_joint else self.read(scene)

    def names(self, links: int, joints: tuple[int, ...] = ()) -> list[tuple[str, str, int]]:
        """(C name, scene key, link or joint index from 0) of each field the row stands for."""
        if self.per_joint:  # (a free chain's base point, 0, has its own row: R_base)
            return [(f"{self.name}{j}", self.key.format(i=j), j - 1) for j in joints if j > 0]
        if not self.per_link:
            return [(self.name, self.key, 0)]
        return [(f"{self.name}{i}", self.key.format(i=i), i - 1) for i in range(1, links + 1)]

    def admits(self, value: float) -> bool:
        """Whether `value` lies in the row's physical range."""
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def range_text(self) -> str:
        if self.low == -INF and self.high == INF:
            return ""
        lo = "" if self.low == -INF else ("(" if self.low_open else "[") + f"{self.low:g}"
        hi = "" if self.high == INF else f"{self.high:g}" + (")" if self.high_open else "]")
        if not hi:
            return f"> {self.low:g}" if self.low_open else f">= {self.low:g}"
        if not lo:
            return f"< {self.high:g}" if self.high_open else f"<= {self.high:g}"
        return f"{lo}, {hi}"


POSITIVE = {"low": 0.0, "low_open": True}
POISSON = {"low": -1.0, "high": 0.5, "low_open": True, "high_open": True}

PARAMETERS: tuple[Parameter, ...] = (
    Parameter("L", "chain.length[{i}]", "m", "length of link {i}", "input", per_link=True,
              read=attrgetter("chain.length"), **POSITIVE),
    Parameter("m", "chain.mass[{i}]", "kg", "mass of link {i}", "input", per_link=True,
              read=attrgetter("chain.mass"), **POSITIVE),
    Parameter("g", "chain.gravity", "m/s2", "gravity", "input", read=attrgetter("chain.gravity"), low=0.0),
    Parameter("E_rod", "rod.E", "Pa", "Young's modulus of the rod", "input",
              read=attrgetter("rod.E"), **POSITIVE),
    Parameter("nu_rod", "rod.nu", "1", "Poisson ratio of the rod", "input",
              read=attrgetter("rod.nu"), **POISSON),
    Parameter("S_y_rod", "rod.yield_strength", "Pa", "yield strength of the rod", "input",
              read=attrgetter("rod.yield_strength"), **POSITIVE),
    Parameter("R_tip", "rod.tip_radius", "m", "radius of the rod's spherical tip", "input",
              read=attrgetter("tip_radius"), **POSITIVE),
    Parameter("E_surface", "surface.E", "Pa", "Young's modulus of the surface", "input",
              read=attrgetter("surface.E"), **POSITIVE),
    Parameter("nu_surface", "surface.nu", "1", "Poisson ratio of the surface", "input",
              read=attrgetter("surface.nu"), **POISSON),
    Parameter("S_y_surface", "surface.yield_strength", "Pa", "yield strength of the surface", "input",
              read=attrgetter("surface.yield_strength"), **POSITIVE),
    Parameter("R_joint", "contact.joint_radius[{i}]", "m", "radius of joint {i}'s contact (the end of link {i})",
              "input", per_joint=True, read=attrgetter("joint_radii"), **POSITIVE),
    Parameter("R_base", "contact.base_radius", "m", "radius of a free chain's base point's contact (the start of link 1)",
              "input", needs="base", read=attrgetter("base_radius"), **POSITIVE),
    Parameter("angle_deg", "surface.angle_deg", "deg", "the surface's inclination: it descends towards +x",
              "input", needs="used", read=attrgetter("surface_angle_deg"), low=-90.0, high=90.0, low_open=True,
              high_open=True),
    Parameter("surface_height", "surface.height", "m",
              "height of the undeformed surface (ignored when surface.height_initial is set)", "input",
              read=lambda s: 0.0 if s.surface_height is None else s.surface_height),
    Parameter("surface_initial", "surface.height_initial", "",
              "1: the surface is at the tip's initial height (surface.height = \"initial\")", "input",
              read=lambda s: 1.0 if s.surface_height is None else 0.0, low=0.0, high=1.0,
              fmi_type="Boolean"),
    Parameter("mu", "contact.friction", "1", "friction coefficient", "input", needs="friction",
              read=attrgetter("contact.friction"), low=0.0),
    Parameter("eps", "contact.friction_eps", "m/s", "regularization speed of the friction sign", "input",
              needs="regularized", read=attrgetter("contact.friction_eps"), **POSITIVE),
    # the keys of the field's other contact laws (docs/contact-laws.md): a model has the ones its law reads
    Parameter("restitution", "contact.restitution", "1",
              "the damped Hertz law's design coefficient of restitution e", "input", needs="used",
              read=attrgetter("contact.restitution"), low=0.0, high=1.0, low_open=True),
    Parameter("stiffness", "contact.stiffness", "N/m", "the Kelvin-Voigt spring k", "input", needs="used",
              read=attrgetter("contact.stiffness"), **POSITIVE),
    Parameter("damping", "contact.damping", "N.s/m", "the Kelvin-Voigt dashpot c", "input", needs="used",
              read=attrgetter("contact.damping"), low=0.0),
    Parameter("p_y", "contact.limiting_pressure", "Pa", "Thornton's limiting contact pressure p_y", "input",
              needs="used", read=attrgetter("contact.limiting_pressure"), **POSITIVE),
    Parameter("E_star", "", "Pa", "reduced modulus E* (Eq. 7)", "derived", needs="used"),
    Parameter("chi", "", "1", "the damped Hertz law's damping factor, from e", "derived", needs="used"),
    Parameter("delta_y", "", "m", "Thornton: the penetration where the contact pressure reaches p_y", "derived",
              needs="used", per_point=True),
    Parameter("F_y", "", "N", "Thornton: the force there", "derived", needs="used", per_point=True),
    Parameter("k_y", "", "N/m", "Thornton: the plastic loading's slope pi p_y R", "derived", needs="used",
              per_point=True),
    Parameter("R", "", "m", "reduced radius of the point's contact (Eq. 8)", "derived", needs="used", per_point=True),
    Parameter("C_j", "", "1", "critical yield coefficient", "derived", needs="used"),
    Parameter("delta_c", "", "m", "critical deformation", "derived", needs="used", per_point=True),
    Parameter("P_c", "", "N", "critical load", "derived", needs="used", per_point=True),
    Parameter("B", "", "1", "Jackson-Green exponent 0.14 exp(23 S_y/E*)", "derived", needs="used"),
    Parameter("inv_delta_c", "", "1/m", "1/delta_c (the elasto-plastic law multiplies by it)", "derived",
              needs="used", per_point=True),
    Parameter("theta_c", "", "1", "pi a/R of the Jackson-Green law at delta = delta_c: "
              "pi (delta_c/R)^(1/2) 1.9^(-B/2)", "derived", needs="used", per_point=True),
    Parameter("y_s", "", "m", "the surface level under the point now (moves to where a resting point lifts off)", "machine", per_point=True),
    Parameter("delta_m", "", "m", "maximum compression of the current impact", "machine", needs="used", per_point=True),
    Parameter("delta_r", "", "m", "permanent deformation (set at maximum compression)", "machine",
              needs="used", per_point=True),
    Parameter("R_res", "", "m", "unloading radius (set at maximum compression)", "machine", needs="used", per_point=True),
    Parameter("v_0", "", "m/s", "the point's normal speed at the start of its impact (the damped laws)", "machine",
              needs="used", per_point=True),
    Parameter("slip", "", "1", "exact Coulomb: +1 or -1 while the point slips that way, 0 while it sticks",
              "machine", needs="coulomb", per_point=True),
    Parameter("s_frozen", "", "1", "frozen friction: the sign of the point's tangential speed at contact start, "
              "kept for the whole contact", "machine", needs="frozen", per_point=True),
)

BY_NAME = {p.name: p for p in PARAMETERS}


@dataclass(frozen=True)
class Rule:
    """A physical rule across two inputs that their own ranges cannot state: `below` must lie
    below `above` (C fields of the table). The one list of such rules (RULES): the scene
    checks apply it (`broken_rule`, the same key and words as load_scene's refusal), and the
    generated C's start check (`<prefix>_derive`, so an FMU's fmi2ExitInitializationMode)
    prints it, naming `below`'s variable."""

    below: str  # the input named when the rule is broken (its scene key is the key of the error)
    above: str
    ratio: str  # what below/above means, e.g. "a yield strain S_y/E"

    @property
    def key(self) -> str:
        return BY_NAME[self.below].key

    @property
    def above_key(self) -> str:
        return BY_NAME[self.above].key

    def message(self, low: float, high: float) -> str:
        """Why values `low` (of `below`) and `high` (of `above`) break the rule."""
        return f"must be below {self.above_key} ({self.ratio} = {low / high:.3g} >= 1 is not physical)"

    def range_text(self) -> str:
        """The rule as the C check states it after the value (`<prefix>_derive`'s range_text)."""
        return f"< {self.above_key} ({self.ratio} >= 1 is not physical)"

    def c_test(self, struct: str = "p->") -> str:
        """The C condition that the rule holds."""
        return f"{struct}{self.below} < {struct}{self.above}"


RULES: tuple[Rule, ...] = (
    Rule("S_y_rod", "E_rod", "a yield strain S_y/E"),
    Rule("S_y_surface", "E_surface", "a yield strain S_y/E"),
)


def broken_rule(scene: Any) -> tuple[Rule, str] | None:
    """The first rule of RULES that `scene`'s values break, and why (the error's words), or None."""
    for rule in RULES:
        low, high = BY_NAME[rule.below].value(scene), BY_NAME[rule.above].value(scene)
        if not low < high:
            return rule, rule.message(low, high)
    return None


def included(p: Parameter, friction_law: str, used: set[str], base: bool = False) -> bool:
    """Whether a model with this friction law, whose expressions read `used` (and with a free
    chain's base point among its contact points if `base`), has row `p`."""
    if p.needs == "base":
        return base
    if p.needs == "always":
        return True
    if p.needs == "friction":
        return friction_law != "none"
    if p.needs in ("regularized", "coulomb", "frozen"):
        return friction_law == p.needs
    return p.name in used


@dataclass(frozen=True)
class Field:
    """One field of a model's parameter struct: a table row, for one link if per-link."""

    name: str  # C field
    key: str  # scene key ("" for derived and machine fields)
    row: Parameter
    link: int  # link index from 0 (0 for rows that are not per-link)

    @property
    def doc(self) -> str:
        text = self.row.doc.format(i=self.link + 1)
        return f"{text}, {self.row.unit}" if self.row.unit not in ("", "1") else text

    def read(self, scene: Any) -> float:
        """The field's value in `scene`."""
        return float(self.row.value(scene, self.link))


def fields(links: int, friction_law: str, used: set[str], joints: tuple[int, ...] = (),
           base: bool = False) -> tuple[Field, ...]:
    """The parameter struct of a model with `links` links, this friction law and contact at
    `joints` (and at a free chain's base point if `base`), whose expressions (force laws,
    events, switch laws) read the symbols in `used` (without the per-point fields:
    `point_fields`)."""
    return tuple(Field(name, key, p, link) for p in PARAMETERS if included(p, friction_law, used, base)
                 and not p.per_point for name, key, link in p.names(links, joints))


def point_fields(friction_law: str, used: set[str]) -> tuple[Field, ...]:
    """The fields of each contact point's record, point[k], in the same model."""
    return tuple(Field(p.name, "", p, 0) for p in PARAMETERS if p.per_point and included(p, friction_law, used))


def markdown_table() -> str:
    """The table as docs/embedding.md shows it (a test keeps the two equal)."""
    kinds = {"input": "scene", "derived": "derived", "machine": "machine"}
    rows = ["| C field | scene key / FMU variable | unit | set by | range | what |", "|---|---|---|---|---|---|"]
    for p in PARAMETERS:
        name = (f"{p.name}1..{p.name}n" if p.per_link else f"{p.name}i" if p.per_joint
                else f"point[k].{p.name}" if p.per_point else p.name)
        key = p.key.replace("{i}", "i") if p.key else ""
        when = {"always": "", "friction": " (with friction)", "regularized": " (regularized friction)",
                "coulomb": "", "frozen": "", "used": "", "base": " (free chains)"}[p.needs]
        rows.append(f"| `{name}` | {f'`{key}`' if key else ''} | {p.unit if p.unit not in ('', '1') else '-'} | "
                    f"{kinds[p.kind]} | {p.range_text()} | {p.doc.replace('{i}', 'i')}{when} |")
    return "\n".join(rows)
