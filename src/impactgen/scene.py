"""Scene files: read a TOML description of a chain and a surface, check it, and freeze it.

The schema below is the single statement of the scene format (docs/scene.md mirrors it):
every key with its type, default and physical check. Every error names the key.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib  # type: ignore[no-redef]

from .errors import SceneError

NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
CONTACT_MODELS = ("three-phase", "hertz")
FRICTION_MODES = ("regularized", "coulomb")
METHODS = ("bdf", "adams")
JACOBIANS = ("auto", "analytic", "difference")
# "auto" emits the analytic Jacobian for BDF up to this many links. Above it, the Jacobian's
# symbolic and compile cost (n = 10: +10 s, n = 20: +3 min) buys no measurable speed, since
# CVODE evaluates it only ~10-15 times per impact; "analytic" still forces it.
JACOBIAN_AUTO_MAX_LINKS = 6

_MISSING = object()


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

    def replace(self, **changes: Any) -> "Scene":
        return dataclasses.replace(self, **changes)


# --------------------------------------------------------------------------- checks

Check = Callable[[Any], str | None]  # returns the reason a value is bad, or None


def _positive(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


def _non_negative(v: float) -> str | None:
    return None if v >= 0 else "must be >= 0"


def _poisson(v: float) -> str | None:
    return None if -1.0 < v < 0.5 else "Poisson ratio must lie in (-1, 0.5)"


def _tolerance(v: float) -> str | None:
    return None if 0 < v < 1 else "must lie in (0, 1)"


@dataclass(frozen=True)
class Key:
    """One scene key: its expected kind, default and check."""

    kind: str  # "float", "int", "str", "name", "bool", "floats" (one number or a list of n), "list"
    default: Any = _MISSING
    check: Check | None = None
    choices: tuple[str, ...] = ()
    doc: str = ""


SCHEMA: dict[str, dict[str, Key]] = {
    "": {"name": Key("name", doc="letters, digits, '-' and '_'")},
    "chain": {
        "links": Key("int", check=lambda v: None if 1 <= v <= 60 else "must be between 1 and 60"),
        "length": Key("floats", check=_positive, doc="m; one number or a list of n"),
        "mass": Key("floats", check=_positive, doc="kg; one number or a list of n"),
        "gravity": Key("float", 9.81, _non_negative, doc="m/s^2"),
    },
    "rod": {
        "E": Key("float", check=_positive, doc="Pa"),
        "nu": Key("float", check=_poisson),
        "yield_strength": Key("float", check=_positive, doc="Pa"),
        "tip_radius": Key("float", check=_positive, doc="m"),
    },
    "surface": {
        "E": Key("float", check=_positive, doc="Pa"),
        "nu": Key("float", check=_poisson),
        "yield_strength": Key("float", check=_positive, doc="Pa"),
        "height": Key("height", "initial", doc='"initial" or a number in m'),
    },
    "contact": {
        "model": Key("str", "three-phase", choices=CONTACT_MODELS),
        "friction": Key("float", 0.0, _non_negative, doc="mu"),
        "friction_mode": Key("str", "regularized", choices=FRICTION_MODES),
        "friction_eps": Key("float", 1e-6, _positive, doc="m/s"),
    },
    "initial": {
        "q_deg": Key("list", None, doc="degrees"),
        "q": Key("list", None, doc="radians"),
        "u": Key("list", doc="rad/s"),
    },
    "solver": {
        "method": Key("str", "bdf", choices=METHODS),
        "jacobian": Key("str", "auto", choices=JACOBIANS, doc="auto: analytic with bdf up to 6 links"),
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
        return v
    v = float(v)
    if not math.isfinite(v):
        raise SceneError(key, f"expected a finite number, got {v!r}")
    return v


def _numbers(key: str, v: Any, n: int) -> tuple[float, ...]:
    if not isinstance(v, list):
        raise SceneError(key, f"expected a list of {n} numbers, got {type(v).__name__} {v!r}")
    if len(v) != n:
        raise SceneError(key, f"expected {n} values (one per link), got {len(v)}")
    return tuple(_number(f"{key}[{i}]", x) for i, x in enumerate(v))


def _checked(key: str, value: Any, spec: Key) -> Any:
    values = value if isinstance(value, tuple) else (value,)
    if spec.check is not None:
        for i, x in enumerate(values):
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
    except tomllib.TOMLDecodeError:
        if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.-]*", raw):
            value = raw
        else:
            raise SceneError(key, f"cannot read the value {raw!r} (use TOML syntax, "
                                  "e.g. 1e-8, \"text\" or [1.0, 2.0])") from None
    return key, value


def _apply_overrides(raw: dict[str, Any], overrides: Mapping[str, Any]) -> None:
    for dotted, value in overrides.items():
        section, _, key = dotted.rpartition(".")
        if section not in SCHEMA or key not in SCHEMA[section]:
            raise SceneError(dotted, f"unknown key{_closest(dotted)}")
        target = raw.setdefault(section, {}) if section else raw
        if not isinstance(target, dict):
            raise SceneError(section, "expected a table")
        target[key] = value
        if dotted in ("initial.q", "initial.q_deg"):  # one overrides the other
            target.pop("q_deg" if key == "q" else "q", None)


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
    raw = _deep_copy(raw)
    _apply_overrides(raw, overrides or {})
    sections = _read_sections(raw)

    def get(section: str, key: str, n: int = 0) -> Any:
        spec = SCHEMA[section][key]
        dotted = f"{section}.{key}" if section else key
        if key in sections[section]:
            return _coerce(dotted, sections[section][key], spec, n)
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
                      get("contact", "friction_mode"), get("contact", "friction_eps"))
    q_deg, q_rad = get("initial", "q_deg", n), get("initial", "q", n)
    if (q_deg is None) == (q_rad is None):
        raise SceneError("initial.q", "give exactly one of initial.q (rad) and initial.q_deg")
    q0 = q_rad if q_rad is not None else tuple(math.radians(a) for a in q_deg)
    method, jacobian = get("solver", "method"), get("solver", "jacobian")
    if jacobian == "auto":
        jacobian = "analytic" if method == "bdf" and n <= JACOBIAN_AUTO_MAX_LINKS else "difference"
    solver = Solver(method, jacobian, get("solver", "rtol"), get("solver", "atol"),
                    get("solver", "t_end"), get("solver", "t_max"), get("solver", "max_steps"),
                    get("solver", "sustained_contact"))
    scene = Scene(name, chain, rod, get("rod", "tip_radius"), surface,
                  get("surface", "height"), contact, q0, get("initial", "u", n), solver,
                  source=source)
    _check_physics(scene)
    return scene


def _check_physics(scene: Scene) -> None:
    """Checks across keys: yield below modulus; the tip may touch the surface, not be in it."""
    for section, mat in (("rod", scene.rod), ("surface", scene.surface)):
        if mat.yield_strength >= mat.E:
            raise SceneError(f"{section}.yield_strength", f"must be below {section}.E (a yield "
                             f"strain S_y/E = {mat.yield_strength / mat.E:.3g} >= 1 is not physical)")
    if scene.surface_height is None:
        return
    y_tip = sum(L * math.sin(q) for L, q in zip(scene.chain.length, scene.q0))
    depth = scene.surface_height - y_tip
    if depth > 1e-12 * max(1.0, sum(scene.chain.length)):
        raise SceneError("surface.height", f"the tip starts {depth:.3g} m inside the surface "
                         f"(tip at y = {y_tip:.6g} m, surface at {scene.surface_height:.6g} m); "
                         "lower the surface or change initial.q")


def _deep_copy(raw: Mapping[str, Any]) -> dict[str, Any]:
    return {k: _deep_copy(v) if isinstance(v, Mapping) else v for k, v in raw.items()}


def load_scene(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Scene:
    """Read and check a scene file; `overrides` maps dotted keys to values."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(None, f"scene file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(None, f"cannot read scene file {path}: {exc}") from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(None, f"{path} is not valid TOML: {exc}") from None
    return scene_from_dict(raw, overrides, source=str(path))


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
