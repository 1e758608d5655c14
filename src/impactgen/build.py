"""Stage 6 of the pipeline: compile a generated model and the CVODE glue with cffi, cached.

A cache entry is a folder named by a hash of every input of the build: the model spec, the
generator's own source and templates, the glue, the compiler flags, the SUNDIALS version
and the Python ABI. Entries are built in a temporary folder and renamed into place (atomic),
under a per-entry lock so that concurrent processes build once; an entry whose manifest
does not match its files is moved aside and rebuilt, never trusted.

The part of the runtime that knows no model (the steppers, the explicit pair, the small
kernels) is compiled once per cache into a static archive, an entry of its own keyed by its
sources, the flags, the compiler and SUNDIALS; each model's extension links it.
"""
from __future__ import annotations

import contextlib
import functools
import fcntl
import hashlib
import importlib.machinery
import importlib.metadata
import importlib.resources
import importlib.util
import json
import os
import re
import shutil
import sys
import sysconfig
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Callable

import cffi

from .codegen.spec import ModelSpec
from .errors import BuildError
from .sundials import Sundials, find_sundials

# -O3 unrolls and vectorizes the small fixed loops of the explicit pair; -fno-math-errno lets sqrt be
# one instruction (nothing here reads errno). The paper's impact gives the same numbers to the last
# digit as at -O2, in about 10 % fewer instructions (callgrind, when the flags were chosen).
COMPILE_ARGS = ("-O3", "-fno-math-errno")
SANITIZE_ARGS = ("-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
                 "-fno-sanitize-recover=undefined")
# The runtime written once for every model. The phase machine, the solver, the run loop and the
# tallies include the generated model's header and are compiled with each model; the steppers
# under them, the explicit pair and the small kernels include no model header and name no
# MODEL_* macro, so they are compiled
# once per cache into a static archive (RUNTIME_ARCHIVE) that every model links.
MODEL_GLUE_FILES = ("model_machine.h", "model_machine_points.h", "model_machine.c", "model_stick_slip.c", "solver.h",
                    "solver_state.h", "solver.c", "run.c", "tally.h", "tally.c")
RUNTIME_FILES = ("roots.h", "stepper.h", "stepper.c", "step_cvode.c", "step_erk.c", "step_sundials.h", "step_sundials.c",
                 "step_pair.c", "step_auto.c", "dopri5.h", "dopri5.c", "small_kernels.h", "small_kernels.c")
GLUE_FILES = MODEL_GLUE_FILES + RUNTIME_FILES
# The batch entry (many cases in one C call: sweeps, run_batch): compiled into each model's Python
# extension only (an FMU or the C driver has no use for it).
BATCH_FILES = ("batch.h", "batch.c")
RUNTIME_ARCHIVE = "impactgen_runtime"  # built as libimpactgen_runtime.a
CDEF_HEADERS = ("model_machine.h", "stepper.h", "tally.h", "solver.h", "batch.h")  # the runtime's declarations cffi reads, in this order
MANIFEST = "manifest.json"

if TYPE_CHECKING:  # the generator (sympy) is imported only to build a model, not to load one
    from .codegen.emit import GeneratedModel


@dataclass(frozen=True)
class CompiledModel:
    """A loaded extension with what the runtime needs to drive it."""

    spec: ModelSpec
    ffi: cffi.FFI
    lib: object
    path: Path  # the cache entry
    state_names: tuple[str, ...]
    output_names: tuple[str, ...]
    event_names: tuple[str, ...]
    param_names: tuple[str, ...]
    phases: tuple[str, ...]

    @property
    def nstate(self) -> int:
        return len(self.state_names)


def cache_root() -> Path:
    """The cache folder, always an absolute path: IMPACTGEN_CACHE_DIR (a relative one, or one
    starting with ~, taken from the working folder or the home folder), else
    $XDG_CACHE_HOME/impactgen, else ~/.cache/impactgen. cffi compiles from inside the
    entry's temporary folder, where a relative path names nothing (cc1: No such file)."""
    root = os.environ.get("IMPACTGEN_CACHE_DIR")
    if root:
        return Path(os.path.abspath(os.path.expanduser(root)))
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):  # unset, or relative: the XDG spec says to ignore a relative one
        base = str(Path.home() / ".cache")
    return Path(os.path.abspath(base)) / "impactgen"


def _native(name: str) -> str:
    return (importlib.resources.files("impactgen") / "native" / name).read_text(encoding="utf-8")


@functools.lru_cache(maxsize=1)
def _generator_fingerprint() -> str:
    """Hash of the generator's code and templates: a change there changes every key."""
    h = hashlib.sha256()
    for package, pattern in (("impactgen.codegen", ".py"), ("impactgen.templates", ".j2")):
        root = importlib.resources.files(package)
        for entry in sorted(root.iterdir(), key=lambda e: e.name):
            if entry.name.endswith(pattern):
                h.update(entry.name.encode())
                h.update(entry.read_bytes())
    h.update(importlib.metadata.version("sympy").encode())  # read, not imported: a cached model needs no sympy
    return h.hexdigest()


def build_flags() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Compile and link flags: optimized, or instrumented with AddressSanitizer and
    UndefinedBehaviorSanitizer when IMPACTGEN_SANITIZE is set (see scripts/sanitize.sh)."""
    if os.environ.get("IMPACTGEN_SANITIZE"):
        return SANITIZE_ARGS, ("-fsanitize=address,undefined",)
    return COMPILE_ARGS, ()


def _compiler() -> list[str]:
    """What chooses the compiler and its base flags besides ours (distutils reads these)."""
    return [os.environ.get(v, "") for v in ("CC", "CFLAGS", "LDFLAGS", "LDSHARED")]


def _sundials_parts(sundials: Sundials) -> list:
    return [sundials.version, sundials.include_dirs, sundials.library_dirs, sundials.libraries]


def build_key(spec: ModelSpec, sundials: Sundials) -> str:
    parts = {
        "spec": spec.to_json(),
        "generator": _generator_fingerprint(),
        "glue": [hashlib.sha256(_native(f).encode()).hexdigest() for f in GLUE_FILES + BATCH_FILES],
        "flags": build_flags(),
        "compiler": _compiler(),
        "sundials": _sundials_parts(sundials),
        "python": [sys.implementation.cache_tag, sysconfig.get_config_var("EXT_SUFFIX"),
                   sysconfig.get_platform()],
        "cffi": cffi.__version__,
    }
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()[:32]


def runtime_key(sundials: Sundials) -> str:
    """The cache entry of the model-independent runtime: its sources, the flags, the compiler
    (the environment's and Python's build configuration, which distutils compiles with) and
    SUNDIALS; not the model, not the generator."""
    parts = {
        "runtime": {f: hashlib.sha256(_native(f).encode()).hexdigest() for f in RUNTIME_FILES},
        "flags": build_flags(),
        "compiler": [*_compiler(), *(os.environ.get(v, "") for v in ("CPPFLAGS", "AR", "ARFLAGS")),
                     *(str(sysconfig.get_config_var(v)) for v in ("CC", "CFLAGS", "CCSHARED", "AR", "ARFLAGS"))],
        "sundials": _sundials_parts(sundials),
    }
    return "runtime-" + hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()[:32]


def _glue_cdef() -> str:
    blocks = []
    for name in CDEF_HEADERS:
        match = re.search(r"/\* cdef-begin.*?\*/(.*)/\* cdef-end \*/", _native(name), re.S)
        assert match, f"{name} lacks its cdef markers"
        blocks.append(match.group(1))
    return "".join(blocks)


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@contextlib.contextmanager
def _captured_fds():
    """Send fds 1 and 2 (where the compiler writes) to a file; yield a reader for it."""
    sys.stdout.flush()
    sys.stderr.flush()
    with tempfile.TemporaryFile(mode="w+b") as sink:
        saved = [os.dup(1), os.dup(2)]
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            yield lambda: (sink.seek(0), sink.read().decode(errors="replace"))[1]
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)


def _first_error(log: str) -> str:
    for line in log.splitlines():
        if re.search(r"\berror\b", line, re.I):
            return line.strip()
    lines = [ln for ln in log.splitlines() if ln.strip()]
    return lines[-1].strip() if lines else "no compiler output"


def _failed(what: str, log: str, exc: Exception, workdir: Path) -> BuildError:
    return BuildError(f"compiling {what} failed: {_first_error(log)} ({type(exc).__name__}); "
                      f"build folder kept in {workdir}")


def _compile(gen: GeneratedModel, sundials: Sundials, module_name: str, workdir: Path, runtime: Path) -> Path:
    """The model's extension: its generated C and the model-dependent glue, linked with the
    runtime archive `runtime`."""
    for name, text in gen.files().items():
        (workdir / name).write_text(text)
    runtime_headers = [name for name in RUNTIME_FILES if name.endswith(".h")]  # solver.h includes stepper.h
    for name in (*MODEL_GLUE_FILES, *BATCH_FILES, *runtime_headers):
        (workdir / name).write_text(_native(name))
    ffi = cffi.FFI()
    ffi.cdef(gen.cdef + _glue_cdef())
    ffi.set_source(
        module_name,
        '#include "model.h"\n#include "model_machine.h"\n#include "solver.h"\n#include "batch.h"\n',
        sources=[str(workdir / name) for name in (*gen.files(), *MODEL_GLUE_FILES, *BATCH_FILES)
                 if name.endswith(".c")],
        include_dirs=[str(workdir), *sundials.include_dirs],
        extra_objects=[str(runtime)],  # before the SUNDIALS libraries on the link line, as an archive must be
        library_dirs=list(sundials.library_dirs),
        runtime_library_dirs=list(sundials.library_dirs),
        libraries=list(sundials.libraries) + ["m"],
        extra_compile_args=list(build_flags()[0]),
        extra_link_args=list(build_flags()[1]),
    )
    with _captured_fds() as log:
        try:
            so = ffi.compile(tmpdir=str(workdir), verbose=False)
        except Exception as exc:  # cffi raises distutils/setuptools errors of several kinds
            raise _failed(f"the {gen.spec.slug} model", log(), exc, workdir) from None
    return Path(so)


def _compile_runtime(sundials: Sundials, workdir: Path, for_what: str) -> dict:
    """The model-independent runtime as a static archive of position-independent objects,
    compiled by the compiler and with the flags cffi uses for the models; its manifest."""
    import setuptools  # noqa: F401  (first: its distutils is the one cffi compiles with)
    from distutils.ccompiler import new_compiler
    from distutils.sysconfig import customize_compiler

    for name in RUNTIME_FILES:
        text = _native(name)
        # a runtime file that came to depend on the model would be compiled here without it
        assert not re.search(r'\bMODEL_[A-Z]|#\s*include\s*"model', text), \
            f"{name} depends on the generated model: move it to MODEL_GLUE_FILES"
        (workdir / name).write_text(text)
    compiler = new_compiler()
    customize_compiler(compiler)  # CC, CFLAGS and -fPIC (CCSHARED) as build_ext sets them
    with _captured_fds() as log:
        try:
            objects = compiler.compile([str(workdir / n) for n in RUNTIME_FILES if n.endswith(".c")],
                                       output_dir=str(workdir), include_dirs=[str(workdir), *sundials.include_dirs],
                                       extra_postargs=list(build_flags()[0]))
            compiler.create_static_lib(objects, RUNTIME_ARCHIVE, output_dir=str(workdir))
        except Exception as exc:  # distutils' CompileError, LibError
            raise _failed(f"the C runtime for {for_what}", log(), exc, workdir) from None
    return {"library": compiler.library_filename(RUNTIME_ARCHIVE), "sundials": sundials.version,
            "sources": list(RUNTIME_FILES)}


def _valid(entry: Path) -> dict | None:
    try:
        manifest = json.loads((entry / MANIFEST).read_text())
        so = entry / manifest["library"]
        if _file_digest(so) != manifest["sha256"]:
            return None
        return manifest
    except (OSError, ValueError, KeyError, TypeError):
        return None


@contextlib.contextmanager
def _lock(path: Path):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def _built_entry(root: Path, key: str, build: Callable[[Path], dict]) -> Path:
    """The valid cache entry `key`, built once across processes: under its lock, `build`
    fills a fresh temporary folder and returns the manifest (naming the "library" file), and
    the folder is renamed into place. A broken or partial entry is moved aside first."""
    entry = root / key
    with _lock(root / f"{key}.lock"):
        if _valid(entry):
            return entry
        if entry.exists():  # broken or partial: move it aside, then rebuild
            shutil.rmtree(entry.with_name(entry.name + ".broken"), ignore_errors=True)
            with contextlib.suppress(OSError):
                entry.rename(entry.with_name(entry.name + ".broken"))
        work = Path(tempfile.mkdtemp(prefix=f"{key}.tmp-", dir=root))
        try:
            meta = build(work)
        except BaseException:
            if not any(work.iterdir()):  # failed before writing a file: nothing to look at
                work.rmdir()
            raise
        meta["sha256"] = _file_digest(work / meta["library"])
        for junk in work.iterdir():  # keep the sources, the library and the manifest only
            if junk.is_dir():
                shutil.rmtree(junk)
            elif junk.suffix == ".o":
                junk.unlink()
        (work / MANIFEST).write_text(json.dumps(meta, indent=1))
        os.rename(work, entry)
        return entry


def _runtime_archive(sundials: Sundials, root: Path, for_what: str) -> Path:
    """The runtime archive of this cache for the current flags, built on first use."""
    key = runtime_key(sundials)
    entry = root / key
    if _valid(entry) is None:
        entry = _built_entry(root, key, lambda work: _compile_runtime(sundials, work, for_what))
    manifest = _valid(entry)
    if manifest is None:
        raise BuildError(f"the build in {entry} did not produce a valid runtime archive")
    return entry / manifest["library"]


def _build_entry(spec: ModelSpec, sundials: Sundials, key: str, root: Path) -> Path:
    module_name = f"_impactgen_{key}"

    def build(work: Path) -> dict:
        from .codegen.emit import generate_model
        gen = generate_model(spec)
        runtime = _runtime_archive(sundials, root, f"the {spec.slug} model")
        so = _compile(gen, sundials, module_name, work, runtime)
        library = so.name
        if so.parent != work:  # keep the library inside the entry it belongs to
            shutil.copy2(so, work / library)
        return {
            "spec": json.loads(spec.to_json()),
            "module": module_name,
            "library": library,
            "sundials": sundials.version,
            "runtime": runtime.parent.name,
            "state_names": gen.state_names,
            "output_names": gen.output_names,
            "event_names": gen.event_names,
            "param_names": gen.param_names,
            "phases": gen.phases,
            "structure_hash": gen.structure_hash,
        }

    return _built_entry(root, key, build)


_loaded: dict[ModelSpec, CompiledModel] = {}  # the models this process has loaded
_loaded_lock = threading.Lock()


def compile_model(spec: ModelSpec) -> CompiledModel:
    """Return the compiled model for `spec`, building it on first use (once per process).

    The cache folder and the flags (IMPACTGEN_CACHE_DIR, IMPACTGEN_SANITIZE, ...) are read
    when a spec is first asked for: a warm run looks its model up by the spec alone (once per
    run, so it reads no environment; four reads cost about 3 us, 4 % of the paper's impact)."""
    found = _loaded.get(spec)
    if found is not None:
        return found
    root = cache_root()
    with _loaded_lock:
        if spec in _loaded:
            return _loaded[spec]
        sundials = find_sundials()
        key = build_key(spec, sundials)
        try:
            root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise BuildError(f"cannot create the build cache {root}: {exc}; set "
                             "IMPACTGEN_CACHE_DIR to a writable folder") from None
        entry = root / key
        manifest = _valid(entry)
        if manifest is None:
            _check_writable(root)
            entry = _build_entry(spec, sundials, key, root)
            manifest = _valid(entry)
            if manifest is None:
                raise BuildError(f"the build in {entry} did not produce a valid library")
        module = _import(manifest["module"], entry / manifest["library"])
        compiled = CompiledModel(
            spec=spec, ffi=module.ffi, lib=module.lib, path=entry,
            state_names=tuple(manifest["state_names"]),
            output_names=tuple(manifest["output_names"]),
            event_names=tuple(manifest["event_names"]),
            param_names=tuple(manifest["param_names"]),
            phases=tuple(manifest["phases"]),
        )
        _loaded[spec] = compiled
        return compiled


def _check_writable(root: Path) -> None:
    """A cache folder that exists but cannot be written (read-only, another user's) ends in
    one line when it lacks the model, rather than in a PermissionError from the build lock."""
    try:
        with tempfile.TemporaryFile(dir=root):
            pass
    except OSError as exc:
        raise BuildError(f"the build cache {root} lacks this model and cannot be written "
                         f"({exc.strerror or exc}); set IMPACTGEN_CACHE_DIR to a writable folder") from None


def _import(name: str, path: Path) -> ModuleType:
    if name in sys.modules:
        return sys.modules[name]
    loader = importlib.machinery.ExtensionFileLoader(name, str(path))
    spec = importlib.util.spec_from_file_location(name, path, loader=loader)
    if spec is None:
        raise BuildError(f"cannot load the compiled model {path}")
    try:
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except ImportError as exc:
        raise BuildError(f"cannot load the compiled model {path}: {exc}; delete the cache "
                         f"folder {path.parent} to rebuild") from None
    sys.modules[name] = module
    return module
