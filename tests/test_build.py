"""The compiled-model cache: reuse, rebuild of broken entries, concurrency, clear failures."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from impactgen import build
from impactgen.build import compile_model
from impactgen.codegen.spec import ModelSpec
from impactgen.errors import BuildError

SPEC = ModelSpec(1, "hertz", "none")


def _compile_in_subprocess(cache: Path) -> subprocess.Popen:
    code = ("from impactgen.build import compile_model; from impactgen.codegen.spec import ModelSpec;"
            "m = compile_model(ModelSpec(1, 'hertz', 'none')); print(m.path)")
    env = {**os.environ, "IMPACTGEN_CACHE_DIR": str(cache)}
    return subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def test_same_structure_reuses_the_loaded_model():
    assert compile_model(SPEC) is compile_model(SPEC)


@pytest.fixture(scope="module")
def built_cache(tmp_path_factory) -> Path:
    """A cache folder that a process of its own built SPEC into (never changed: copy it to
    change it)."""
    cache = tmp_path_factory.mktemp("built-cache")
    first = _compile_in_subprocess(cache)
    out, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    assert Path(out.strip()).parent == cache
    return cache


def _entry(cache: Path) -> Path:
    """The one model entry (beside it, the runtime archive's entry that every model links)."""
    (entry,) = [p for p in cache.iterdir() if p.is_dir() and not p.name.startswith("runtime-")]
    return entry


def test_a_new_process_loads_the_cache_without_rebuilding(built_cache):
    entry = _entry(built_cache)
    library = entry / json.loads((entry / "manifest.json").read_text())["library"]
    stamp = library.stat().st_mtime_ns
    second = _compile_in_subprocess(built_cache)
    out2, err2 = second.communicate(timeout=300)
    assert second.returncode == 0, err2
    assert Path(out2.strip()) == entry and library.stat().st_mtime_ns == stamp


def test_a_built_model_runs_sweeps_and_warns_without_importing_the_generator():
    """sympy (about 0.6 s to import) is for generating models: a process whose model is in the
    cache simulates, reads the validity warnings and sweeps without it."""
    import impactgen
    impactgen.simulate(impactgen.load_scene("paper"))  # built into this session's cache
    code = ("import sys, impactgen; scene = impactgen.load_scene('paper');"
            "assert impactgen.simulate(scene).warnings == [];"
            "table = impactgen.sweep(scene, vary={'rod.tip_radius': [1e-6]}, workers=1);"
            "assert 'contact radius' in table['warnings'][0], table['warnings'][0];"
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'sympy' or m.endswith('codegen.emit')))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "[]"


def test_concurrent_builds_of_one_model_all_succeed(tmp_path):
    procs = [_compile_in_subprocess(tmp_path) for _ in range(8)]
    paths = set()
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
        paths.add(out.strip())
    assert len(paths) == 1
    assert not list(tmp_path.glob("*.tmp-*"))  # no half-built folder left behind


def test_corrupted_library_is_rebuilt(built_cache, tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    shutil.copytree(built_cache, cache)  # a process's build, to corrupt
    monkeypatch.setenv("IMPACTGEN_CACHE_DIR", str(cache))
    entry = _entry(cache)
    assert build._valid(entry) is not None
    manifest = json.loads((entry / "manifest.json").read_text())
    (entry / manifest["library"]).write_bytes(b"not a shared library")
    assert build._valid(entry) is None
    proc = _compile_in_subprocess(cache)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert Path(out.strip()) == entry and build._valid(entry) is not None


def test_missing_sundials_says_how_to_install(monkeypatch):
    from impactgen import sundials
    sundials.find_sundials.cache_clear()
    monkeypatch.setattr(sundials, "find_sundials", sundials.find_sundials.__wrapped__)
    monkeypatch.setattr(sundials, "_prefixes", lambda: [Path("/nonexistent")])
    monkeypatch.setattr(sundials, "_pkg_config_include", lambda: [])
    with pytest.raises(BuildError, match="apt-get install libsundials-dev"):
        sundials.find_sundials()


def test_compiler_failure_is_a_build_error_with_the_first_error(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTGEN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(build, "build_flags", lambda: (("-include", "/nonexistent/header.h"), ()))
    with pytest.raises(BuildError, match="compiling the .* model failed"):
        build._build_entry(SPEC, build.find_sundials(), "broken" + "0" * 26, tmp_path)
