"""The example scenes shipped with impactgen (package data), found by name from anywhere.

`impactgen examples` lists them and copies one out; `impactgen run NAME` and
`load_scene(NAME)` take a shipped example when no file of that name exists.
"""
from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from .errors import SceneError, excerpt

_PACKAGE = "impactgen.scenes"


def _folder():
    return files(_PACKAGE)


def example_names() -> list[str]:
    """Names of the shipped example scenes (their file names without .toml)."""
    return sorted(p.name[:-5] for p in _folder().iterdir() if p.name.endswith(".toml"))


def example_text(name: str) -> str:
    """The TOML text of a shipped example."""
    if name not in example_names():
        raise SceneError(None, f"no example scene named {excerpt(name)}; the examples are "
                               f"{', '.join(example_names())} (see 'impactgen examples')")
    return _folder().joinpath(f"{name}.toml").read_text(encoding="utf-8")


def example_description(name: str) -> str:
    """The first comment lines of an example: what it shows."""
    lines = []
    for line in example_text(name).splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("# ").strip())
    return " ".join(lines)


def find_example(path: Path) -> str | None:
    """The example named by `path` if it is a bare name (no folder, at most a .toml suffix)
    of a shipped example and no such file exists; otherwise None."""
    if path.exists() or len(path.parts) != 1:
        return None
    name = path.name[:-5] if path.name.endswith(".toml") else path.name
    return name if name in example_names() else None


def copy_example(name: str, destination: Path) -> Path:
    """Write example `name` to `destination` (a file, or a folder to put NAME.toml in)."""
    text = example_text(name)
    target = destination / f"{name}.toml" if destination.is_dir() else destination
    if target.exists():
        raise SceneError("--out", f"{target} exists already; choose another path or remove it")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise SceneError("--out", f"cannot write {target}: {exc}") from None
    return target


__all__ = ["copy_example", "example_description", "example_names", "example_text", "find_example"]
