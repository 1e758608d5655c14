"""Scene files: read a TOML description of a chain and a surface, check it, and freeze it.

The schema below is the single statement of the scene format (docs/scene.md mirrors it):
every key with its type, default and physical check. Every error names the key. Elements of
a list-valued key are named from 1, as the links are numbered: `initial.u[2]` is omega20.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
import os
import re
from collections import abc
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib  # type: ignore[no-redef]

from .codegen.parameters import PARAMETERS
from .codegen.thresholds import THRESHOLD
from .errors import SceneError

NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
CONTACT_MODELS = ("three-phase", "hertz")
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

_MISSING = object()
MAX_SCENE_BYTES = 16 * 2**20  # a scene file is a few hundred bytes; /dev/zero would never end
# A tip (or joint) this far below the surface, relative to the chain's length (at least
# 1 m), still counts as touching it: the rounding of a height summed over the links (the
# phase machine's own start test uses the same number).
TOUCH_TOLERANCE = THRESHOLD["TOUCH_TOLERANCE"]


@dataclass(frozen=True)
class Material:
    """Elastic and yield properties of one body in contact."""

    E: float
    nu: float
    yield_strength: float


@dataclass(frozen=True)
class Chain:
    links: int
    length: tuple[float, ...]
    mass: tuple[float, ...]
    gravity: float


@dataclass(frozen=True)
class Contact:
    model: str
    friction: float
    friction_mode: str
    friction_eps: float
    # contact.joint_radius as given, one per joint (n - 1); None: every joint has the tip's radius
    joint_radius: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Solver:
    method: str
    jacobian: str  # "analytic" | "difference" (auto resolved by the method)
    rtol: float
    atol: float
    t_end: float | None  # None: stop at the first separation
    t_max: float  # longest free flight to wait for a first contact when t_end is None
    max_steps: int
    sustained_contact: bool = True  # with t_end a time: hold the tip once impacts chatter
    jacobian_setting: str = "auto"  # the key as given, before "auto" was resolved into `jacobian`


@dataclass(frozen=True)
class Scene:
    """A checked scene. Angles are radians; `surface_height` None means 'initial'."""

    name: str
    chain: Chain
    rod: Material
    tip_radius: float
    surface: Material
    surface_height: float | None
    contact: Contact
    q0: tuple[float, ...]
    u0: tuple[float, ...]
    solver: Solver
    source: str = field(default="<memory>", compare=False)

    @property
    def n(self) -> int:
        return self.chain.links

    @property
    def joint_radii(self) -> tuple[float, ...]:
        """The contact radius of every joint (the end of link k, k = 1..n-1), in m: n - 1
        values, the tip radius where `contact.joint_radius` is not given (empty for one link)."""
        given = self.contact.joint_radius
        return given if given is not None else (self.tip_radius,) * (self.n - 1)

    def replace(self, overrides: Mapping[str, Any] | None = None, **fields: Any) -> "Scene":
        """A new scene with some values changed, checked like `load_scene`.

        Parameters
        ----------
        overrides : mapping, optional
            Dotted scene keys to new values, as in `load_scene` (``{"initial.u[2]": -0.3}``).
        **fields
            Whole fields of the dataclass (``solver=dataclasses.replace(scene.solver, ...)``).

        Returns
        -------
        Scene
            The checked scene. A change that leaves it inconsistent (three links with two
            initial angles, a tip inside the surface) raises `SceneError` naming the key.
        """
        overrides = checked_overrides(overrides)
        if fields:  # whole fields: the scene they make is read in full
            _check_fields(self, fields)
            changed = dataclasses.replace(self, **fields)
            return scene_from_dict(changed.to_dict(), overrides, source=self.source)
        return scene_with(self, overrides)

    def to_dict(self) -> dict[str, Any]:
        """The scene as nested dicts of plain values, as a TOML file states it (angles in
        radians): `scene_from_dict(scene.to_dict())` gives the same scene."""
        s = self.solver
        return {
            "name": self.name,
            "chain": {"links": self.chain.links, "length": list(self.chain.length),
                      "mass": list(self.chain.mass), "gravity": self.chain.gravity},
            "rod": {"E": self.rod.E, "nu": self.rod.nu, "yield_strength": self.rod.yield_strength,
                    "tip_radius": self.tip_radius},
            "surface": {"E": self.surface.E, "nu": self.surface.nu,
                        "yield_strength": self.surface.yield_strength,
                        "height": "initial" if self.surface_height is None else self.surface_height},
            "contact": {"model": self.contact.model, "friction": self.contact.friction,
                        "friction_mode": self.contact.friction_mode,
                        "friction_eps": self.contact.friction_eps,
                        # left out when not given: the joints then follow rod.tip_radius
                        **({} if self.contact.joint_radius is None
                           else {"joint_radius": list(self.contact.joint_radius)})},
            "initial": {"q": list(self.q0), "u": list(self.u0)},
            "solver": {"method": s.method, "jacobian": s.jacobian_setting, "rtol": s.rtol,
                       "atol": s.atol, "t_end": "separation" if s.t_end is None else s.t_end,
                       "t_max": s.t_max, "max_steps": s.max_steps,
                       "sustained_contact": s.sustained_contact},
        }

    def to_toml(self) -> str:
        """The scene as a TOML file that `load_scene` reads back to the same scene."""
        lines = [f"name = {_toml_value(self.name)}"]
        for section, values in self.to_dict().items():
            if isinstance(values, dict):
                lines += ["", f"[{section}]"] + [f"{k} = {_toml_value(v)}" for k, v in values.items()]
        return "\n".join(lines) + "\n"


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        return repr(v)  # shortest repr that reads back to the same double
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return str(v)


# --------------------------------------------------------------------------- checks

Check = Callable[[Any], str | None]  # returns the reason a value is bad, or None


def _positive(v: float) -> str | None:
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


def _tolerance(v: float) -> str | None:
    return None if 0 < v < 1 else "must lie in (0, 1)"


@dataclass(frozen=True)
class Key:
    """One scene key: its expected kind, default and check."""

    # "float", "int", "str", "name", "bool", "floats" (one number or a list of n), "list",
    # "joint_floats" (one number or a list of n - 1: one per joint)
    kind: str
    default: Any = _MISSING
    check: Check | None = None
    choices: tuple[str, ...] = ()
    doc: str = ""


SCHEMA: dict[str, dict[str, Key]] = {
    "": {"name": Key("name", doc="letters, digits, '-' and '_'")},
    "chain": {
        "links": Key("int", check=lambda v: None if 1 <= v <= 60 else "must be between 1 and 60"),
        "length": Key("floats", check=_physical("chain.length"), doc="m; one number or a list of n"),
        "mass": Key("floats", check=_physical("chain.mass"), doc="kg; one number or a list of n"),
        "gravity": Key("float", 9.81, _physical("chain.gravity"), doc="m/s^2"),
    },
    "rod": {
        "E": Key("float", check=_physical("rod.E"), doc="Pa"),
        "nu": Key("float", check=_physical("rod.nu")),
        "yield_strength": Key("float", check=_physical("rod.yield_strength"), doc="Pa"),
        "tip_radius": Key("float", check=_physical("rod.tip_radius"), doc="m"),
    },
    "surface": {
        "E": Key("float", check=_physical("surface.E"), doc="Pa"),
        "nu": Key("float", check=_physical("surface.nu")),
        "yield_strength": Key("float", check=_physical("surface.yield_strength"), doc="Pa"),
        "height": Key("height", "initial", doc='"initial" or a number in m'),
    },
    "contact": {
        "model": Key("str", "three-phase", choices=CONTACT_MODELS),
        "friction": Key("float", check=_physical("contact.friction"),
                        doc="mu, the Coulomb coefficient; 0 for a frictionless surface"),
        "friction_mode": Key("str", "regularized", choices=FRICTION_MODES),
        "friction_eps": Key("float", 1e-6, _physical("contact.friction_eps"), doc="m/s"),
        # a joint's contact radius has the tip radius's range
        "joint_radius": Key("joint_floats", None, _physical("rod.tip_radius"),
                            doc="m; one number or a list of n - 1 (one per joint); default rod.tip_radius"),
    },
    "initial": {
        "q_deg": Key("list", None, doc="degrees"),
        "q": Key("list", None, doc="radians"),
        "u": Key("list", doc="rad/s"),
    },
    "solver": {
        "method": Key("str", "auto", choices=METHODS),
        "jacobian": Key("str", "auto", choices=JACOBIANS, doc="auto: analytic with bdf (or auto) up to 6 links"),
        "rtol": Key("float", 1e-10, _tolerance),
        "atol": Key("float", 1e-12, _tolerance),
        "t_end": Key("t_end", "separation", doc='"separation" or a time in s'),
        "t_max": Key("float", 10.0, _positive, doc="s; longest wait for a first contact"),
        "max_steps": Key("int", 500_000, lambda v: None if 0 < v <= 10**9 else "must lie in [1, 1e9]"),
        "sustained_contact": Key("bool", True, doc="with t_end a time: rest the tip on the surface "
                                                   "once impacts chatter"),
    },
}


def _all_keys() -> list[str]:
    return [f"{s}.{k}" if s else k for s, keys in SCHEMA.items() for k in keys]


def _closest(key: str) -> str:
    match = difflib.get_close_matches(key, _all_keys(), n=1, cutoff=0.5)
    return f" (did you mean '{match[0]}'?)" if match else ""


# --------------------------------------------------------------------------- coercion


def _number(key: str, v: Any, integer: bool = False) -> float | int:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        kind = "an integer" if integer else "a number"
        raise SceneError(key, f"expected {kind}, got {type(v).__name__} {v!r}")
    if integer:
        if isinstance(v, float):
            if not v.is_integer():
                raise SceneError(key, f"expected an integer, got {v!r}")
            v = int(v)
        if abs(v) >= 2**63:  # no count is this large; its digits would fill the message
            raise SceneError(key, f"expected an integer, got one of about {v.bit_length() * 0.30103:.0f} digits")
        return v
    try:
        v = float(v)
    except OverflowError:  # an integer beyond any float (10**400)
        raise SceneError(key, f"expected a finite number, got an integer of about {v.bit_length() * 0.30103:.0f} "
                              "digits, beyond what a float holds") from None
    if not math.isfinite(v):
        raise SceneError(key, f"expected a finite number, got {v!r}")
    return v


def _numbers(key: str, v: Any, n: int, per: str = "link") -> tuple[float, ...]:
    if not isinstance(v, list):
        raise SceneError(key, f"expected a list of {n} numbers, got {type(v).__name__} {v!r}")
    if len(v) != n:
        raise SceneError(key, f"expected {n} values (one per {per}), got {len(v)}")
    return tuple(_number(f"{key}[{i}]", x) for i, x in enumerate(v, start=1))


def _checked(key: str, value: Any, spec: Key) -> Any:
    values = value if isinstance(value, tuple) else (value,)
    if spec.check is not None:
        for i, x in enumerate(values, start=1):
            reason = spec.check(x)
            if reason:
                where = f"{key}[{i}]" if isinstance(value, tuple) else key
                raise SceneError(where, f"{reason}, got {x!r}")
    return value


def _coerce(key: str, v: Any, spec: Key, n: int) -> Any:
    if spec.kind == "float":
        return _checked(key, _number(key, v), spec)
    if spec.kind == "int":
        return _checked(key, _number(key, v, integer=True), spec)
    if spec.kind in ("str", "name"):
        if not isinstance(v, str):
            raise SceneError(key, f"expected a string, got {type(v).__name__} {v!r}")
        if spec.kind == "name" and not NAME_PATTERN.match(v):
            raise SceneError(key, f"{v!r} is not a valid name: use 1 to 64 letters, digits, "
                                  "'-' and '_', starting with a letter or digit")
        if spec.choices and v not in spec.choices:
            raise SceneError(key, f"{v!r} is not one of {', '.join(spec.choices)}")
        return v
    if spec.kind == "floats":  # one number for every link, or a list of n
        if isinstance(v, list):
            return _checked(key, _numbers(key, v, n), spec)
        return (_checked(key, _number(key, v), spec),) * n
    if spec.kind == "joint_floats":  # one number for every joint, or a list of n - 1
        if isinstance(v, list):
            return _checked(key, _numbers(key, v, n - 1, "joint"), spec)
        return (_checked(key, _number(key, v), spec),) * (n - 1)
    if spec.kind == "list":
        return _numbers(key, v, n)
    if spec.kind == "height":
        if v == "initial":
            return None
        if isinstance(v, str):
            raise SceneError(key, f'expected "initial" or a number in m, got {v!r}')
        return _number(key, v)
    if spec.kind == "bool":
        if not isinstance(v, bool):
            raise SceneError(key, f"expected true or false, got {v!r}")
        return v
    if spec.kind == "t_end":
        if v == "separation":
            return None
        if isinstance(v, str):
            raise SceneError(key, f'expected "separation" or a time in s, got {v!r}')
        return _checked(key, _number(key, v), Key("float", check=_positive))
    raise AssertionError(spec.kind)  # pragma: no cover


# --------------------------------------------------------------------------- loading


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


LIST_KINDS = ("floats", "list", "joint_floats")  # the kinds of key whose elements an index names
INDEXED_KEY = re.compile(r"^(?P<key>[A-Za-z0-9_.]+)\[(?P<index>[^\]]*)\]$")


def split_key(dotted: str) -> tuple[str, str, int | None]:
    """(section, key, 1-based element or None) of a dotted key such as `initial.u[2]`;
    raise SceneError for a key the schema does not have."""
    index = None
    match = INDEXED_KEY.match(dotted)
    name = match["key"] if match else dotted
    section, _, key = name.rpartition(".")
    if section not in SCHEMA or key not in SCHEMA[section]:
        raise SceneError(dotted, f"unknown key{_closest(name)}")
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


def check_value(dotted: str, value: Any, links: int) -> Any:
    """`value` for key `dotted` (an element too) checked on its own, as the scene checks it
    for a chain of `links` links: SceneError naming the key if no scene could take it."""
    return _checked_value(dotted, *split_key(dotted), value, links)


def _checked_value(dotted: str, section: str, key: str, index: int | None, value: Any, links: int) -> Any:
    """check_value of a key split already."""
    spec = SCHEMA[section][key]
    value = plain(value)
    if index is not None:
        return _checked(dotted, _number(dotted, value), spec)
    return _coerce(dotted, value, spec, links)


def check_values(dotted: str, values: Iterable[Any], links: int) -> None:
    """Every value for key `dotted` checked as `check_value` checks it (a sweep checks every
    value it will run before its first case)."""
    section, key, index = split_key(dotted)
    for value in values:
        _checked_value(dotted, section, key, index, value, links)


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


def _apply_overrides(raw: dict[str, Any], overrides: Mapping[str, Any]) -> None:
    for dotted, value in overrides.items():
        section, key, index = split_key(dotted)
        target = raw.setdefault(section, {}) if section else raw
        if not isinstance(target, dict):
            raise SceneError(section, "expected a table")
        value = plain(value)
        if index is not None:
            value = _with_element(dotted, raw, target, section, key, index, value)
        target[key] = value
        if key in ("q", "q_deg") and section == "initial":  # one overrides the other
            target.pop("q_deg" if key == "q" else "q", None)


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


def plain(value: Any) -> Any:
    """numpy scalars and arrays, and tuples, as the plain Python values TOML gives."""
    if type(value) in _PLAIN:  # the common case, checked first: scenes are read per sweep case
        return value
    if hasattr(value, "tolist") and callable(value.tolist):  # numpy array or scalar
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, abc.Mapping):
        return {k: plain(v) for k, v in value.items()}
    return value


_PLAIN = {float, int, str, bool, type(None)}


def _read_sections(raw: dict[str, Any]) -> dict[str, dict[str, Any]]:
    for top, value in raw.items():
        if top in SCHEMA and top:
            if not isinstance(value, dict):
                raise SceneError(top, f"expected a table [{top}], got {type(value).__name__}")
        elif top not in SCHEMA[""]:
            raise SceneError(top, f"unknown key{_closest(top)}")
    out: dict[str, dict[str, Any]] = {"": {k: raw[k] for k in SCHEMA[""] if k in raw}}
    for section, keys in SCHEMA.items():
        if not section:
            continue
        given = raw.get(section, {})
        for k in given:
            if k not in keys:
                raise SceneError(f"{section}.{k}", f"unknown key{_closest(f'{section}.{k}')}")
        out[section] = dict(given)
    return out


def scene_from_dict(raw: Mapping[str, Any], overrides: Mapping[str, Any] | None = None,
                    source: str = "<memory>") -> Scene:
    """Check a scene given as nested dicts (as TOML parses it) and build a `Scene`."""
    if not isinstance(raw, abc.Mapping):
        raise SceneError(None, f"a scene is a mapping of tables (as TOML gives it), got {type(raw).__name__} "
                               f"{raw!r:.60}")
    raw = _tables_copied(raw)
    _apply_overrides(raw, checked_overrides(overrides))
    sections = _read_sections(raw)

    def get(section: str, key: str, n: int = 0) -> Any:
        spec = SCHEMA[section][key]
        dotted = f"{section}.{key}" if section else key
        if key in sections[section]:
            return _coerce(dotted, plain(sections[section][key]), spec, n)
        if spec.default is _MISSING:
            raise SceneError(dotted, f"missing required key ({spec.doc or spec.kind})"
                             if spec.doc else "missing required key")
        return _coerce(dotted, spec.default, spec, n) if spec.default is not None else None

    name = get("", "name")
    n = get("chain", "links")
    chain = Chain(n, get("chain", "length", n), get("chain", "mass", n), get("chain", "gravity"))
    rod = Material(get("rod", "E"), get("rod", "nu"), get("rod", "yield_strength"))
    surface = Material(get("surface", "E"), get("surface", "nu"), get("surface", "yield_strength"))
    contact = Contact(get("contact", "model"), get("contact", "friction"),
                      get("contact", "friction_mode"), get("contact", "friction_eps"),
                      get("contact", "joint_radius", n))
    q_deg, q_rad = get("initial", "q_deg", n), get("initial", "q", n)
    if (q_deg is None) == (q_rad is None):
        raise SceneError("initial.q", "give exactly one of initial.q (rad) and initial.q_deg")
    q0 = q_rad if q_rad is not None else tuple(math.radians(a) for a in q_deg)
    method, jacobian_setting = get("solver", "method"), get("solver", "jacobian")
    solver = Solver(method, _jacobian(method, jacobian_setting, n), get("solver", "rtol"), get("solver", "atol"),
                    get("solver", "t_end"), get("solver", "t_max"), get("solver", "max_steps"),
                    get("solver", "sustained_contact"), jacobian_setting)
    scene = Scene(name, chain, rod, get("rod", "tip_radius"), surface,
                  get("surface", "height"), contact, q0, get("initial", "u", n), solver,
                  source=source)
    _check_physics(scene)
    return scene


def _jacobian(method: str, setting: str, links: int) -> str:
    """The Jacobian a solver uses: `setting`, its "auto" resolved by the method and the links."""
    if setting != "auto":
        return setting
    return "analytic" if method in ("bdf", "auto") and links <= JACOBIAN_AUTO_MAX_LINKS else "difference"


# The key whose new value re-decides other fields (the links size every list): a case that
# changes it is read in full.
_REREAD = {"chain.links"}
_JOINT_RADIUS = "contact.joint_radius"  # a per-joint list: its elements are set like a link's
_MATERIALS = {"E", "nu", "yield_strength"}  # the keys of a [rod] or [surface] Material
# The keys `_check_physics` reads: a case that changes none of them (a speed, a friction
# coefficient, a solver setting) keeps the base scene's verdict, which was already checked.
_CROSS_CHECKED = {"rod.E", "rod.yield_strength", "surface.E", "surface.yield_strength", "surface.height",
                  "chain.length", "initial.q", "initial.q_deg"}


def scene_with(base: Scene, overrides: Mapping[str, Any]) -> Scene:
    """`base` with some keys changed, checked as `scene_from_dict(base.to_dict(), overrides)`
    checks it and equal to what it builds, at a fraction of the cost: only the changed values
    are coerced (by `check_value`, the scene's own coercion), then the cross-key checks run.
    A sweep builds every case this way, and `simulate` applies its options so. A refused
    case is read in full, so that its error is the one `scene_from_dict` reports."""
    try:
        return _changed(base, overrides)
    except SceneError:
        return scene_from_dict(base.to_dict(), overrides, source=base.source)


def _changed(base: Scene, overrides: Mapping[str, Any]) -> Scene:
    fields: dict[str, Any] = {}  # the scene's fields that change, by name
    n = base.chain.links
    lists: dict[str, list[float]] = {}  # q0, u0, length, mass: copied when a key changes one
    cross_checked = False
    for dotted, value in overrides.items():
        section, key, index = split_key(dotted)
        name = f"{section}.{key}" if section else key
        if name in _REREAD or (index is not None and index > (n - 1 if name == _JOINT_RADIUS else n)):
            return scene_from_dict(base.to_dict(), overrides, source=base.source)
        cross_checked = cross_checked or name in _CROSS_CHECKED
        checked = _checked_value(dotted, section, key, index, value, n)
        if section == "chain" and key != "gravity":
            target = lists[key] if key in lists else lists.setdefault(key, list(getattr(base.chain, key)))
            if index is None:
                target[:] = checked
            else:
                target[index - 1] = checked
        elif section == "initial":
            field = "u0" if key == "u" else "q0"
            target = lists[field] if field in lists else lists.setdefault(field, list(getattr(base, field)))
            convert = math.radians if key == "q_deg" else float
            if key == "q_deg" and index is not None:  # the other angles pass through degrees too
                target[:] = [math.radians(math.degrees(v)) for v in target]
            if index is None:
                target[:] = [convert(v) for v in checked]
            else:
                target[index - 1] = convert(checked)
        elif name == _JOINT_RADIUS:  # a tuple, or one element of the radii (the tip's where none were given)
            contact = fields.get("contact", base.contact)
            radii = list(contact.joint_radius if contact.joint_radius is not None
                         else (fields.get("tip_radius", base.tip_radius),) * (n - 1))
            if index is None:
                radii[:] = checked
            else:
                radii[index - 1] = checked
            fields["contact"] = _with(contact, {"joint_radius": tuple(radii)})
        elif name == "solver.jacobian":  # the setting as given: `jacobian` is resolved below
            fields["solver"] = _with(fields.get("solver", base.solver), {"jacobian_setting": checked})
        elif section in _SECTION_FIELDS and (section not in ("rod", "surface") or key in _MATERIALS):
            # the field of the section's name: a Material, Contact, Solver or the chain's gravity
            fields[section] = _with(fields.get(section, getattr(base, section)), {key: checked})
        elif name == "rod.tip_radius":
            fields["tip_radius"] = checked
        elif name == "surface.height":
            fields["surface_height"] = checked
        else:  # the name
            fields[key] = checked
    if "length" in lists or "mass" in lists:
        chain = fields.get("chain", base.chain)
        fields["chain"] = _with(chain, {"length": tuple(lists.get("length", chain.length)),
                                        "mass": tuple(lists.get("mass", chain.mass))})
    for field in ("q0", "u0"):
        if field in lists:
            fields[field] = tuple(lists[field])
    if "solver" in fields:
        solver = fields["solver"]
        jacobian = _jacobian(solver.method, solver.jacobian_setting, n)
        if jacobian != solver.jacobian:
            fields["solver"] = _with(solver, {"jacobian": jacobian})
    scene = _with(base, fields)
    if cross_checked:
        _check_physics(scene)
    return scene


def with_solver(base: Scene, settings: Mapping[str, Any]) -> Scene:
    """`base` with some keys of its [solver] table changed (``{"rtol": 1e-8}``), checked as
    `solver_with` checks them."""
    return replace_solver(base, solver_with(base, settings))


def solver_with(base: Scene, settings: Mapping[str, Any]) -> Solver:
    """`base`'s solver with some keys of its [solver] table changed (``{"rtol": 1e-8}``):
    each value checked as the scene checks it, the Jacobian's "auto" resolved again when the
    method or the Jacobian setting changes; nothing else of the scene is read, since no other
    key depends on the solver's. (simulate() runs a scene under it without making a new
    scene: `replace_solver` makes one when it is asked for.)"""
    checked = {key: _checked_value(f"solver.{key}", "solver", key, None, value, base.n)
               for key, value in settings.items()}
    if "jacobian" in checked:  # the setting as given: `jacobian` is the resolved one
        checked["jacobian_setting"] = checked.pop("jacobian")
    solver = base.solver
    if "method" in checked or "jacobian_setting" in checked:
        checked["jacobian"] = _jacobian(checked.get("method", solver.method),
                                        checked.get("jacobian_setting", solver.jacobian_setting), base.n)
    return _with(solver, checked)


def replace_solver(scene: Scene, solver: Solver) -> Scene:
    """`scene` with `solver` (made by `solver_with`, so checked already) as its [solver]."""
    return scene if solver is scene.solver else _with(scene, {"solver": solver})


_SECTION_FIELDS = {"chain", "rod", "surface", "contact", "solver"}  # sections that are a Scene field of their name


def _with(value: Any, changes: dict[str, Any]) -> Any:
    """A scene (or one of its sections) with some fields set to new values, checked by the
    caller: dataclasses.replace through the class's own __init__, without its per-call
    lookup of the fields (each of these dataclasses has exactly its fields in __dict__)."""
    return type(value)(**{**value.__dict__, **changes})


def _check_fields(scene: Scene, fields: Mapping[str, Any]) -> None:
    """Scene.replace's keyword fields: names of the dataclass, each a value of its field's
    type (a whole section such as `solver`); a scene key is given in `overrides` instead."""
    names = [f.name for f in dataclasses.fields(Scene)]
    for name, value in fields.items():
        if name not in names:
            raise SceneError(name, f"Scene.replace takes whole fields ({', '.join(names)}) as keywords; "
                                   f"a scene key goes in overrides, e.g. scene.replace({{'rod.E': 2.1e11}})")
        current = getattr(scene, name)
        if dataclasses.is_dataclass(current) and type(value) is not type(current):
            raise SceneError(name, f"expected a {type(current).__name__} (e.g. dataclasses.replace(scene.{name}, "
                                   f"...)), got {type(value).__name__} {value!r:.60}")


def joint_heights(scene: Scene) -> list[float]:
    """Heights of the pivot (0), of every joint and of the tip (last), in m, at the start."""
    heights = [0.0]
    for L, q in zip(scene.chain.length, scene.q0):
        heights.append(heights[-1] + L * math.sin(q))
    return heights


def _check_physics(scene: Scene) -> None:
    """Checks across keys: yield below modulus; every point of the chain (the joints and the
    tip, each a contact point) may start on the surface, none in it; nor may the pivot."""
    for section, mat in (("rod", scene.rod), ("surface", scene.surface)):
        if mat.yield_strength >= mat.E:
            raise SceneError(f"{section}.yield_strength", f"must be below {section}.E (a yield "
                             f"strain S_y/E = {mat.yield_strength / mat.E:.3g} >= 1 is not physical)")
    heights = joint_heights(scene)
    y_tip = heights[-1]
    slack = TOUCH_TOLERANCE * max(1.0, sum(scene.chain.length))
    if scene.surface_height is not None and scene.surface_height - y_tip > slack:
        raise SceneError("surface.height", f"the tip starts {scene.surface_height - y_tip:.3g} m inside "
                         f"the surface (tip at y = {y_tip:.6g} m, surface at {scene.surface_height:.6g} m); "
                         "lower the surface or change initial.q")
    y_s = y_tip if scene.surface_height is None else scene.surface_height
    for link, (upper, lower) in enumerate(zip(heights[:-1], heights[1:]), start=1):
        low = min(upper, lower)  # a straight bar is lowest at one of its ends
        if y_s - low > slack:
            if low == upper:
                where = "its pivot end" if link == 1 else f"its pivot end (joint {link - 1})"
            else:
                where = "its lower end" + (" (the tip)" if link == scene.n else f" (joint {link})")
            height = ' (surface.height = "initial" puts the surface at the tip)' \
                if scene.surface_height is None else ""
            raise SceneError("initial.q", f"link {link} starts below the surface: {where} is at "
                             f"y = {low:.6g} m, the surface at y = {y_s:.6g} m{height}; every point "
                             "of the chain must start on or above the surface (the joints and the tip "
                             "may touch it)")


def _tables_copied(raw: Mapping[str, Any]) -> dict[str, Any]:
    """The scene's top level and its tables copied, so that overrides change the copy only
    (values are replaced, never changed in place; `plain` makes them plain when read)."""
    return {k: dict(v) if isinstance(v, (dict, abc.Mapping)) else v for k, v in raw.items()}


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
    from .examples import example_text, find_example
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
