"""The generated folder: what `impactgen --links N --out D` and `impactgen generate` write (the
model's C, its scene header, the scene), checked up front and written with a manifest."""
from __future__ import annotations

import json
import time
from pathlib import Path

from ..errors import SceneError

GENERATED_MANIFEST = ".impactgen-generated.json"  # what `generate` wrote into a folder, with digests


def _digest(path: Path) -> str:
    import hashlib
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _check_out_folder(out: Path, files: dict[str, str], force: bool) -> None:
    """`out` may take `files` if it is empty or new, or if every file they replace is one
    impactgen wrote there and nobody changed since (its manifest says); else --force."""
    if force or not out.exists():
        return
    if not out.is_dir():
        raise SceneError("--out", f"{out} is a file, not a folder")
    try:
        known = json.loads((out / GENERATED_MANIFEST).read_text()).get("files", {})
    except FileNotFoundError:
        known = {}
    except (OSError, ValueError, AttributeError):
        known = {}  # unreadable: treated as absent, so nothing is replaced unasked
    foreign = sorted(name for name in files if (out / name).exists()
                     and (name not in known or _digest(out / name) != known[name]))
    if not known and any(out.iterdir()):
        foreign = foreign or sorted(p.name for p in out.iterdir())[:3]
    if foreign:
        raise SceneError("--out", f"{out} holds files impactgen did not write or that were changed since "
                                  f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); choose an "
                                  "empty folder, or add --force to replace them")


def _write_generated(out: Path, files: dict[str, str]) -> None:
    """Write `files` into `out` and note them, with their digests, in its manifest."""
    out.mkdir(parents=True, exist_ok=True)
    manifest = out / GENERATED_MANIFEST
    try:
        known = json.loads(manifest.read_text()).get("files", {})
    except (OSError, ValueError, AttributeError):
        known = {}
    for name, text in files.items():
        (out / name).write_text(text)
        known[name] = _digest(out / name)
    manifest.write_text(json.dumps({"written by": "impactgen generate", "files": known}, indent=1) + "\n")


def generate(scene, out: Path, prefix: str, write_scene: bool = False, force: bool = False) -> int:
    from ..build import compile_model
    from ..codegen.emit import driver_files, generate_model
    from ..engines import model_spec
    if not prefix.isidentifier() or not prefix.isascii():
        raise SceneError("--prefix", f"{prefix!r} is not a C identifier")
    spec = model_spec(scene)
    started = time.perf_counter()
    gen = generate_model(spec, prefix)
    files = driver_files(gen, scene)
    if write_scene:
        files["scene.toml"] = scene.to_toml()
    _check_out_folder(out, files, force)
    compiled = compile_model(spec)
    elapsed = time.perf_counter() - started
    try:
        _write_generated(out, files)
    except OSError as exc:
        raise SceneError("--out", f"cannot write to {out}: {exc}") from None
    print(f"{spec.slug}: {', '.join(str(out / name) for name in gen.files())} "
          f"(plain C99: the model and its phase machine; link with -lm), and the scene's values "
          f"in {out / (prefix + '_scene.h')}")
    if write_scene:
        print(f"scene: {out / 'scene.toml'} (simulate it: impactgen run {out / 'scene.toml'})")
    print(f"compiled with CVODE: {compiled.path} ({elapsed:.1f} s)")
    return 0
