"""A value for a scene key, coerced to its kind and checked as the schema says; every error
names the key (or the element) it was given for."""
from __future__ import annotations

import difflib
import math
from collections import abc
from typing import Any, Iterable

from ..errors import EXCERPT_CHARS, SceneError
from .schema import NAME_PATTERN, SCHEMA, Key, positive, split_key

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


def coerce(key: str, v: Any, spec: Key, n: int) -> Any:
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
            close = difflib.get_close_matches(v, spec.choices, n=1, cutoff=0.5) if len(v) <= EXCERPT_CHARS else []
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SceneError(key, f"{v!r} is not one of {', '.join(spec.choices)}{hint}")
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
    if spec.kind == "pair":  # a point or a velocity in the plane: [x, y]
        if not isinstance(v, list) or len(v) != 2:
            got = f"{len(v)} values" if isinstance(v, list) else f"{type(v).__name__} {v!r}"
            raise SceneError(key, f"expected a list of 2 numbers [x, y], got {got}")
        return _numbers(key, v, 2, "coordinate")
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
        return _checked(key, _number(key, v), Key("float", check=positive))
    raise AssertionError(spec.kind)  # pragma: no cover


def check_value(dotted: str, value: Any, links: int) -> Any:
    """`value` for key `dotted` (an element too) checked on its own, as the scene checks it
    for a chain of `links` links: SceneError naming the key if no scene could take it."""
    return check_split(dotted, *split_key(dotted), value, links)


def check_split(dotted: str, section: str, key: str, index: int | None, value: Any, links: int) -> Any:
    """check_value of a key split already."""
    spec = SCHEMA[section][key]
    value = plain(value)
    if index is not None:
        return _checked(dotted, _number(dotted, value), spec)
    return coerce(dotted, value, spec, links)


def check_values(dotted: str, values: Iterable[Any], links: int) -> None:
    """Every value for key `dotted` checked as `check_value` checks it (a sweep checks every
    value it will run before its first case)."""
    section, key, index = split_key(dotted)
    for value in values:
        check_split(dotted, section, key, index, value, links)


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
