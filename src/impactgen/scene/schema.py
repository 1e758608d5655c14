"""The scene format: every key with its kind, default and physical check (SCHEMA), and the
dotted names by which a key, or one element of a per-link list, is given.

This is the single statement of the scene format (docs/scene.md mirrors it). Elements of a
list-valued key are named from 1, as the links are numbered: `initial.u[2]` is omega20.
"""
from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from typing import Any, Callable

from ..codegen.parameters import PARAMETERS
from ..codegen.spec import CONTACT_MODELS
from ..errors import SceneError
from ..materials import MATERIAL_NAMES

NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
# "frozen": the friction keeps the direction it had at contact start (docs/model.md: the
# paper's published energy losses; not physical once the tip's tangential speed reverses)
FRICTION_MODES = ("regularized", "coulomb", "frozen")
# CVODE BDF, CVODE Adams, ARKODE's explicit Runge-Kutta pair, the same pair in plain C, and that
# pair handing a segment that turns stiff (or long) to BDF (the glue's IG_METHOD_*, in order)
METHODS = ("bdf", "adams", "erk", "dopri5", "auto")
EXPLICIT_METHODS = ("erk", "dopri5")  # no Jacobian, no Newton iteration: for the non-stiff phases
JACOBIANS = ("auto", "analytic", "difference")
# "auto" emits the analytic Jacobian for BDF up to this many links. Above it, the Jacobian's
# symbolic and compile cost (n = 10: +10 s, n = 20: +3 min) buys no measurable speed, since
# CVODE evaluates it only ~10-15 times per impact; "analytic" still forces it.
JACOBIAN_AUTO_MAX_LINKS = 6
# "pinned": the first link hangs from a fixed pivot; "free": nothing holds the chain, its base
# point (the first link's start) moves and is a contact point of its own
BASES = ("pinned", "free")
# the keys only a free chain takes (a pinned chain's base is its pivot, fixed at the origin)
FREE_KEYS = ("initial.base", "initial.base_velocity", "contact.base_radius")
MAX_SURFACE_ANGLE_DEG = 90.0  # the surface's angle lies in (-90, 90) degrees


MISSING = object()  # the default of a key the scene must give
MATERIAL_DOC = "a named material ('impactgen materials'): its values where the keys are not given"


# --------------------------------------------------------------------------- checks

Check = Callable[[Any], str | None]  # returns the reason a value is bad, or None


def positive(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


def _physical(key: str) -> Check:
    """The check of a key that sets a model parameter: the range the parameter table states,
    which the generated C checks as well (an FMU importer's fmi2SetReal)."""
    row = next(p for p in PARAMETERS if p.key.replace("[{i}]", "") == key)
    text = row.range_text()
    reason = f"must lie in {text}" if text[0] in "([" else f"must be {text}"

    def check(v: float) -> str | None:
        return None if row.admits(v) else reason
    return check


def _surface_angle(v: float) -> str | None:
    limit = MAX_SURFACE_ANGLE_DEG
    return None if -limit < v < limit else f"must lie in (-{limit:g}, {limit:g}) degrees"


def _tolerance(v: float) -> str | None:
    return None if 0 < v < 1 else "must lie in (0, 1)"


@dataclass(frozen=True)
class Key:
    """One scene key: its expected kind, default and check."""

    # "float", "int", "str", "name", "bool", "floats" (one number or a list of n), "list",
    # "joint_floats" (one number or a list of n - 1: one per joint), "pair" (a list of 2: [x, y])
    kind: str
    default: Any = MISSING
    check: Check | None = None
    choices: tuple[str, ...] = ()
    doc: str = ""
    symbols: tuple[str, ...] = ()  # how docs/model.md writes it, which a user may type for the key


SCHEMA: dict[str, dict[str, Key]] = {
    "": {"name": Key("name", doc="letters, digits, '-' and '_'")},
    "chain": {
        "links": Key("int", check=lambda v: None if 1 <= v <= 60 else "must be between 1 and 60"),
        "length": Key("floats", check=_physical("chain.length"), doc="m; one number or a list of n"),
        "mass": Key("floats", check=_physical("chain.mass"),
                    doc="kg; one number or a list of n; or give chain.diameter or chain.area"),
        "gravity": Key("float", 9.81, _physical("chain.gravity"), doc="m/s^2", symbols=("g",)),
        # the links' cross-section: their masses are then rod.density x area x length
        "diameter": Key("floats", None, positive, doc="m; a round bar's, one number or a list of n"),
        "area": Key("floats", None, positive, doc="m^2; one number or a list of n"),
        "base": Key("str", "pinned", choices=BASES,
                    doc='"pinned": the first link hangs from a fixed pivot; "free": nothing holds the chain'),
    },
    "rod": {
        "material": Key("str", None, choices=MATERIAL_NAMES, doc=MATERIAL_DOC),
        "E": Key("float", check=_physical("rod.E"), doc="Pa; or give rod.material"),
        "nu": Key("float", check=_physical("rod.nu"), doc="dimensionless; or give rod.material"),
        "yield_strength": Key("float", check=_physical("rod.yield_strength"), doc="Pa; or give rod.material",
                              symbols=("S_y",)),
        "density": Key("float", None, positive, doc="kg/m^3; default rod.material's", symbols=("rho",)),
        "tip_radius": Key("float", check=_physical("rod.tip_radius"), doc="m"),
    },
    "surface": {
        "material": Key("str", None, choices=MATERIAL_NAMES, doc=MATERIAL_DOC),
        "E": Key("float", check=_physical("surface.E"), doc="Pa; or give surface.material"),
        "nu": Key("float", check=_physical("surface.nu"), doc="dimensionless; or give surface.material"),
        "yield_strength": Key("float", check=_physical("surface.yield_strength"),
                              doc="Pa; or give surface.material", symbols=("S_y",)),
        # the default depends on the chain: "initial" for a pinned chain, 0 for a free one
        "height": Key("height", None, doc='"initial" or a number in m; default "initial" (pinned), 0 (free)'),
        "angle_deg": Key("float", 0.0, _surface_angle,
                         doc="degrees in (-90, 90): the surface descends towards +x at this angle"),
    },
    "contact": {
        "model": Key("str", "three-phase", choices=CONTACT_MODELS),
        # the keys of the other laws (docs/contact-laws.md): each law reads its own, refuses the others'
        "restitution": Key("float", None, _physical("contact.restitution"),
                           doc="e, the damped Hertz laws' design coefficient of restitution", symbols=("e",)),
        "stiffness": Key("float", None, _physical("contact.stiffness"), doc="N/m; kelvin-voigt's spring k",
                         symbols=("k",)),
        "damping": Key("float", None, _physical("contact.damping"), doc="N s/m; kelvin-voigt's dashpot c",
                       symbols=("c",)),
        "limiting_pressure": Key("float", None, _physical("contact.limiting_pressure"),
                                 doc="Pa; thornton's limiting contact pressure p_y", symbols=("p_y",)),
        "friction": Key("float", check=_physical("contact.friction"),
                        doc="mu, the Coulomb coefficient; 0 for a frictionless surface", symbols=("mu",)),
        "friction_mode": Key("str", "regularized", choices=FRICTION_MODES),
        "friction_eps": Key("float", 1e-6, _physical("contact.friction_eps"), doc="m/s"),
        # a joint's contact radius has the tip radius's range
        "joint_radius": Key("joint_floats", None, _physical("rod.tip_radius"),
                            doc="m; one number or a list of n - 1 (one per joint); default rod.tip_radius"),
        "base_radius": Key("float", None, _physical("rod.tip_radius"),
                           doc="m; a free chain's base point's contact radius; default rod.tip_radius"),
    },
    "initial": {
        "q_deg": Key("list", None, doc="degrees"),
        "q": Key("list", None, doc="radians"),
        "u": Key("list", doc="rad/s", symbols=("omega",)),
        "base": Key("pair", None, doc="m; [x, y]: a free chain's base point at the start, in the surface's frame"),
        "base_velocity": Key("pair", None, doc="m/s; [vx, vy]: a free chain's base point's velocity; default [0, 0]"),
    },
    "solver": {
        "method": Key("str", "auto", choices=METHODS),
        "jacobian": Key("str", "auto", choices=JACOBIANS, doc="auto: analytic with bdf (or auto) up to 6 links"),
        "rtol": Key("float", 1e-10, _tolerance),
        "atol": Key("float", 1e-12, _tolerance),
        "t_end": Key("t_end", "separation", doc='"separation" or a time in s'),
        "t_max": Key("float", 10.0, positive, doc="s; longest wait for a first contact"),
        "max_steps": Key("int", 500_000, lambda v: None if 0 < v <= 10**9 else "must lie in [1, 1e9]"),
        "sustained_contact": Key("bool", True, doc="with t_end a time: rest the tip on the surface "
                                                   "once impacts chatter"),
    },
}


def all_keys() -> list[str]:
    return [f"{s}.{k}" if s else k for s, keys in SCHEMA.items() for k in keys]


def did_you_mean(name: str) -> str:
    """The hint an unknown key's error ends with: the key that `name` most likely meant.

    In this order: a key docs/model.md writes by the symbol given (``contact.mu`` is
    ``contact.friction``), in the section named if it is one; for a section that exists, a
    key of it by spelling (``contact.frction``), else a key of another section by spelling
    (``rod.height`` is ``surface.height``); for a section that does not, the whole dotted key
    by spelling (``solvr.rtol``). Spelling: difflib's ratio of at least 0.5.
    """
    section, _, key = name.rpartition(".")
    named = {f"{s}.{k}" if s else k: (s, k, spec) for s, keys in SCHEMA.items() for k, spec in keys.items()}
    match = [full for full, (s, k, spec) in named.items() if key in spec.symbols and section in (s, "")][:1]
    if not match and section in SCHEMA:  # a section that exists: its own keys first, then the others'
        for within in (True, False):
            keys = {k: full for full, (s, k, _) in named.items() if (s == section) == within}
            match = [keys[k] for k in difflib.get_close_matches(key, list(keys), n=1, cutoff=0.5)]
            if match:
                break
    elif not match:
        match = difflib.get_close_matches(name, list(named), n=1, cutoff=0.5)
    return f" (did you mean '{match[0]}'?)" if match else ""


LIST_KINDS = ("floats", "list", "joint_floats", "pair")  # the kinds of key whose elements an index names
INDEXED_KEY = re.compile(r"^(?P<key>[A-Za-z0-9_.]+)\[(?P<index>[^\]]*)\]$")


def split_key(dotted: str) -> tuple[str, str, int | None]:
    """(section, key, 1-based element or None) of a dotted key such as `initial.u[2]`;
    raise SceneError for a key the schema does not have."""
    index = None
    match = INDEXED_KEY.match(dotted)
    name = match["key"] if match else dotted
    section, _, key = name.rpartition(".")
    if section not in SCHEMA or key not in SCHEMA[section]:
        raise SceneError(dotted, f"unknown key{did_you_mean(name)}")
    if match:
        if SCHEMA[section][key].kind not in LIST_KINDS:
            raise SceneError(dotted, f"{name} is not a list: give it without an index")
        try:
            index = int(match["index"])
        except ValueError:
            raise SceneError(dotted, f"the index must be a whole number from 1, got {match['index']!r}") from None
        if index < 1:
            raise SceneError(dotted, f"elements are numbered from 1 (as the links are), got {index}")
    return section, key, index


def resolve_jacobian(method: str, setting: str, links: int) -> str:
    """The Jacobian a solver uses: `setting`, its "auto" resolved by the method and the links."""
    if setting != "auto":
        return setting
    return "analytic" if method in ("bdf", "auto") and links <= JACOBIAN_AUTO_MAX_LINKS else "difference"
