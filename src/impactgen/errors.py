"""One exception family for everything impactgen reports to a user.

Each class carries the process exit code the command line uses for it, so that the CLI
maps an error to its code in one place and a caller of the Python API can catch
`ImpactgenError` for all of them.

A message quotes what it refuses through `excerpt`, which bounds the quote: a 2 MB scene
name or a list of a million times is shown by its start and its size. As a last guard every
message of the family is bounded too (`_bounded`): a quote that did not pass through
`excerpt` is cut to an excerpt of its own, so no error ever repeats megabytes of input.
"""
from __future__ import annotations

import re
import reprlib
import sys
import warnings
from typing import Any

EXCERPT_CHARS = 80  # characters of a refused value a message quotes
MESSAGE_CHARS = 2000  # a whole message beyond this is cut in its middle (the start and the advice kept)
_WORD_CHARS = 2 * EXCERPT_CHARS  # a run of characters without a space beyond this is a quote to cut
_LONG_WORD = re.compile(r"\S{%d,}" % (_WORD_CHARS + 1))


def _repr_bounded(value: Any, limit: int) -> str:
    """repr(value) made without building a huge one first (reprlib limits each level)."""
    shorter = reprlib.Repr()
    shorter.maxstring = shorter.maxother = shorter.maxlong = limit
    shorter.maxlist = shorter.maxtuple = shorter.maxset = shorter.maxdict = shorter.maxarray = 6
    shorter.maxlevel = 3
    return shorter.repr(value)


def excerpt(value: Any, limit: int = EXCERPT_CHARS) -> str:
    """`value` as a message quotes it: its repr, or for a long one the start of it and its size.

    Every message that shows a user's value goes through here, so that no message grows
    with its input (a scene name of 2 MB, a t_eval of 10^8 times, a key of any length).
    """
    if getattr(value, "ndim", None) == 0 and hasattr(value, "item"):  # a numpy scalar: as a plain number
        value = value.item()
    if isinstance(value, (str, bytes)):
        if len(value) <= limit:
            return repr(value)
        unit = "characters" if isinstance(value, str) else "bytes"
        return f"{value[:limit]!r}... ({len(value)} {unit})"
    try:
        size = len(value)
    except Exception:  # noqa: BLE001 - an object without a length, or one whose len() fails
        size = None
    text = _repr_bounded(value, limit)
    if len(text) > limit:
        text = text[:limit] + "..."
    if size is not None and size > 6 and "..." in text:
        text += f" ({size} items)"
    return text


def _bounded(message: str) -> str:
    """`message` with every overlong run of characters without a space (a quoted value)
    cut to an excerpt, and then, if still too long, its middle cut."""
    if len(message) <= _WORD_CHARS:
        return message
    message = _LONG_WORD.sub(lambda m: f"{m.group()[:EXCERPT_CHARS]}...({len(m.group())} characters)", message)
    if len(message) > MESSAGE_CHARS:
        cut = len(message) - MESSAGE_CHARS
        half = MESSAGE_CHARS // 2
        message = f"{message[:half]} ...({cut} characters)... {message[-half:]}"
    return message


class ImpactgenError(Exception):
    """Base of all impactgen errors; the message says what is wrong and what to do."""

    exit_code = 1

    def __init__(self, *args: Any):
        if len(args) == 1 and isinstance(args[0], str):
            args = (_bounded(args[0]),)
        super().__init__(*args)


class SceneError(ImpactgenError, ValueError):
    """A scene file, an override or an argument is invalid (exit code 2)."""

    exit_code = 2

    def __init__(self, key: str | None, message: str):
        self.key = key
        shown = key
        if key is not None and (not key.isprintable() or len(key) > EXCERPT_CHARS):  # keys come from users
            shown = excerpt(key)
        super().__init__(f"{shown}: {message}" if key else message)


class BuildError(ImpactgenError, RuntimeError):
    """Generating or compiling the model failed, or SUNDIALS is missing (exit code 3)."""

    exit_code = 3


class SolverError(ImpactgenError, RuntimeError):
    """CVODE (or the reference integrator) could not finish a phase (exit code 4)."""

    exit_code = 4

    def __init__(self, message: str, phase: str | None = None, t: float | None = None):
        self.phase = phase
        self.t = t
        where = ""
        if phase is not None:
            where = f" in phase '{phase}'" + (f" at t = {t:.6g} s" if t is not None else "")
        super().__init__(f"solver failed{where}: {message}")


class ImpactgenWarning(UserWarning):
    """Something asked for was not done as asked, and what was done instead (the work goes on)."""


class ValidityWarning(ImpactgenWarning):
    """A result computed outside what the contact law's fits cover (the run is kept, its
    figures are to be read with care): the warnings a run lists in `warnings`."""


def warn(message: str, category: type[ImpactgenWarning] = ImpactgenWarning) -> None:
    """Warn with `category`, attributed to the first caller outside impactgen (the user's
    line, not the library's)."""
    level, frame = 2, sys._getframe(1)
    while frame is not None and frame.f_globals.get("__name__", "").startswith("impactgen."):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)
