"""The generated folder: what `impactgen --links N --out D` and `impactgen generate` write (the
model's C, its scene header, the scene).

The prefix and the folder are checked before anything is generated, so that a bad one is
refused in one line and leaves nothing behind; the files are then written beside their final
names and renamed into place, so that a failed write leaves neither an empty folder nor a
half-made one.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import time
from pathlib import Path

from ..errors import BuildError, SceneError

GENERATED_MANIFEST = ".impactgen-generated.json"  # what `generate` wrote into a folder, with digests
STAGED_SUFFIX = ".impactgen-tmp"  # a file being written, renamed to its name once every file is written
# C99 keeps 63 significant characters of an internal name or a macro; the generated names add
# up to 26 to the prefix (`<prefix>_joint_delta_acceleration`), and the file names stay short.
MAX_PREFIX_LENGTH = 32
C_PREFIX = re.compile(r"[A-Za-z][A-Za-z0-9_]*")  # a letter first: names from '_' are the C library's


def check_prefix(prefix: str) -> None:
    """Refuse a --prefix that is not a C identifier of at most MAX_PREFIX_LENGTH characters."""
    if not C_PREFIX.fullmatch(prefix):
        raise SceneError("--prefix", f"{prefix!r:.60} is not a C identifier: use ASCII letters, digits and '_', "
                                     "starting with a letter (e.g. chain4)")
    if len(prefix) > MAX_PREFIX_LENGTH:
        raise SceneError("--prefix", f"{prefix[:20]!r}... has {len(prefix)} characters; a prefix has at most "
                                     f"{MAX_PREFIX_LENGTH} (the generated C names add up to 26 to it)")


def check_folder(out: Path) -> None:
    """Refuse an --out that cannot become a folder of ours: a file, a path through a file, a
    folder this process may not write into, or one it cannot make (a new folder is made and
    removed again to know)."""
    missing = _missing_folders(out)
    existing = missing[-1].parent if missing else out
    try:
        if not existing.is_dir():
            where = f"{out} is a file" if existing == out else f"{existing} is a file, so {out} cannot be a folder"
            raise SceneError("--out", f"{where}; choose a folder")
        if not os.access(existing, os.W_OK | os.X_OK):
            raise SceneError("--out", f"cannot write into {existing} (permission denied); choose another folder")
        if missing:
            out.mkdir(parents=True)
            _remove_folders(missing)
    except OSError as exc:
        _remove_folders(missing)
        raise SceneError("--out", f"cannot make or use the folder {out}: {exc}") from None


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _known(out: Path) -> dict[str, str]:
    """The files the folder's manifest says impactgen wrote, with their digests ({} if none)."""
    try:
        known = json.loads((out / GENERATED_MANIFEST).read_text()).get("files", {})
    except (OSError, ValueError, AttributeError):
        return {}  # absent or unreadable: treated as absent, so nothing is replaced unasked
    return known if isinstance(known, dict) else {}


def _check_out_folder(out: Path, files: dict[str, str], force: bool) -> None:
    """`out` may take `files` if it is empty or new, or if every file they replace is one
    impactgen wrote there and nobody changed since (its manifest says); else --force."""
    if force or not out.exists():
        return
    try:
        known = _known(out)
        foreign = sorted(name for name in files if (out / name).exists()
                         and (name not in known or _digest(out / name) != known[name]))
        if not known and any(out.iterdir()):
            foreign = foreign or sorted(p.name for p in out.iterdir())[:3]
    except OSError as exc:
        raise SceneError("--out", f"cannot read {out}: {exc}") from None
    if foreign:
        raise SceneError("--out", f"{out} holds files impactgen did not write or that were changed since "
                                  f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); choose an "
                                  "empty folder, or add --force to replace them")


def _missing_folders(out: Path) -> list[Path]:
    """`out` and those of its parents that do not exist yet, deepest first."""
    missing = []
    while not out.exists() and out != out.parent:
        missing.append(out)
        out = out.parent
    return missing


def _remove_folders(folders: list[Path]) -> None:
    """Remove these folders (deepest first) as far as they are empty."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            break


def _write_generated(out: Path, files: dict[str, str]) -> None:
    """Write `files` into `out` and note them, with their digests, in its manifest: each is
    written beside its name first, and renamed into place once all are written. A write that
    fails removes what it made and raises BuildError (exit 3)."""
    made = _missing_folders(out)
    staged: dict[str, Path] = {}
    try:
        out.mkdir(parents=True, exist_ok=True)
        known = _known(out)
        for name, text in {**files, GENERATED_MANIFEST: ""}.items():
            staged[name] = out / f".{name}{STAGED_SUFFIX}"
            if name != GENERATED_MANIFEST:
                staged[name].write_text(text, encoding="utf-8")
                known[name] = _digest(staged[name])
        staged[GENERATED_MANIFEST].write_text(json.dumps({"written by": "impactgen generate", "files": known},
                                                         indent=1) + "\n", encoding="utf-8")
        for name, path in staged.items():
            os.replace(path, out / name)
    except OSError as exc:
        for path in staged.values():
            try:
                path.unlink(missing_ok=True)
            except OSError:
                pass
        _remove_folders(made)
        raise BuildError(f"cannot write the generated files into {out}: {exc}") from None


def generate(scene, out: Path, prefix: str, write_scene: bool = False, force: bool = False) -> int:
    """Generate and compile the C `scene` needs and write it, with `<prefix>_scene.h` (and the
    scene itself with `write_scene`), into the folder `out`."""
    from ..build import compile_model
    from ..codegen.emit import driver_files, generate_model
    from ..engines import model_spec
    check_prefix(prefix)
    check_folder(out)
    spec = model_spec(scene)
    started = time.perf_counter()
    gen = generate_model(spec, prefix)
    files = driver_files(gen, scene)
    if write_scene:
        files["scene.toml"] = scene.to_toml()
    _check_out_folder(out, files, force)
    compiled = compile_model(spec)
    elapsed = time.perf_counter() - started
    _write_generated(out, files)
    sources = [name for name in files if name.endswith(".c")]
    print(f"{spec.slug}: {', '.join(str(out / name) for name in sources)} "
          f"(plain C99: the model and its phase machine; link with -lm), and the scene's values "
          f"in {out / (prefix + '_scene.h')}")
    if write_scene:
        print(f"scene: {out / 'scene.toml'} (simulate it: impactgen run {out / 'scene.toml'})")
    print(f"compiled with SUNDIALS: {compiled.path} ({elapsed:.1f} s)")
    return 0
