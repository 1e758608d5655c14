"""Build an FMI 2.0 FMU (Model Exchange, Co-Simulation or both) of a scene.

The FMU holds the generated model and phase machine, the scene's start values, the variable
table, the FMI interface written once (native/fmi2/fmu_*.c) and, for Co-Simulation, the CVODE glue
with SUNDIALS linked statically. Only the fmi2* functions are exported. The sources and a
buildDescription.xml travel inside, so the FMU can be rebuilt on another platform.
"""
from __future__ import annotations

import datetime
import hashlib
import importlib.resources
import json
import math
import os
import platform
import re
import shutil
import subprocess
import tempfile
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path

from .. import __version__
from ..build import COMPILE_ARGS, GLUE_FILES, _native
from ..codegen.emit import _c_double, _templates, _tidy, driver_files, generate_model
from ..codegen.expressions import assemble_model
from ..codegen.spec import ModelSpec
from ..engines import model_spec, simulate
from ..errors import BuildError, SceneError, excerpt
from ..scene import Scene
from ..sundials import find_sundials
from .variables import KINDS, UNITS, Variable, variables

FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")  # vendored, as published
# the FMI interface written once for every model (native/fmi2/; fmu_instance.h says which file does what)
FMU_FILES = ("fmu_instance.h", "fmu_api.c", "fmu_start.c", "fmu_variables.c", "fmu_events.c",
             "fmu_model_exchange.c", "fmu_cosimulation.c")
KINDS_OF_FMU = ("me", "cs", "both")
SUMMARY_FILES = ("tally.h", "tally.c")  # the run's summaries, which both kinds tally (Co-Simulation: with GLUE_FILES)
STOP_MARGIN = 0.1  # a separation scene's default stop: this share of its first impact's duration after it
EXPORTS = "{ global: fmi2*; local: *; };\n"  # linker version script: only the FMI functions


def fmu_spec(scene: Scene) -> ModelSpec:
    """An FMU always runs to a time, so it carries sustained contact when the scene allows it."""
    return replace(model_spec(scene), sustained=scene.solver.sustained_contact)


def platform_folder() -> str:
    """binaries/<platform> of FMI 2.0 for this machine."""
    bits = "64" if platform.architecture()[0] == "64bit" else "32"
    system = {"Linux": "linux", "Darwin": "darwin", "Windows": "win"}.get(platform.system(), "linux")
    return f"{system}{bits}"


def _start_text(v: Variable) -> str:
    if v.type == "Boolean":
        return "true" if v.start else "false"
    if v.type == "Integer":
        return str(int(v.start))
    return _c_double(v.start)


@dataclass(frozen=True)
class FmuSources:
    """Everything an FMU is built from: its C files and its two XML descriptions."""

    identifier: str  # modelIdentifier: the shared library's name
    files: dict[str, str]  # sources/ of the FMU: name -> text
    defines: tuple[str, ...]  # FMU_MODEL_EXCHANGE and/or FMU_CO_SIMULATION
    model_description: str
    build_description: str

    @property
    def c_files(self) -> list[str]:
        return [name for name in self.files if name.endswith(".c")]


def fmu_sources(scene: Scene, kind: str = "both") -> FmuSources:
    """The sources and descriptions of `scene`'s FMU. `kind`: "me", "cs" or "both"."""
    if kind not in KINDS_OF_FMU:
        raise SceneError("--kind", f"unknown FMU kind {excerpt(kind)}; choose one of {', '.join(KINDS_OF_FMU)}")
    me, cs = kind in ("me", "both"), kind in ("cs", "both")
    spec = fmu_spec(scene)
    gen = generate_model(spec)
    model = assemble_model(spec)
    variables_ = variables(model, scene, gen.output_names)
    identifier = re.sub(r"\W", "_", scene.name)
    if not identifier[0].isalpha():
        identifier = "m_" + identifier
    facts = {"structure": gen.structure_hash, "scene": scene.to_dict(), "kind": kind, "impactgen": __version__}
    digest = hashlib.sha256(json.dumps(facts, sort_keys=True).encode()).hexdigest()
    guid = "{" + f"{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}" + "}"
    env = _templates()
    lengths = {f.name: k for k, f in enumerate(model.params)}
    context = {"prefix": gen.prefix, "PREFIX": gen.prefix.upper(), "guid": guid, "model_name": scene.name,
               "variables": variables_, "kinds": KINDS,
               "link_lengths": [lengths[f"L{i}"] for i in range(1, spec.links + 1)]}
    sources = driver_files(gen, scene)
    sources[f"{gen.prefix}_fmu.h"] = _tidy(env.get_template("fmu.h.j2").render(context))
    for name in FMI_HEADERS + FMU_FILES:
        sources[name] = (importlib.resources.files("impactgen") / "native" / "fmi2" / name).read_text(encoding="utf-8")
    for name in GLUE_FILES if cs else SUMMARY_FILES:
        sources[name] = _native(name)
    c_files = [name for name in sources if name.endswith(".c")]
    defines = (["FMU_MODEL_EXCHANGE"] if me else []) + (["FMU_CO_SIMULATION"] if cs else [])
    units = sorted({v.unit for v in variables_ if v.unit})
    env.filters["start_text"] = _start_text
    description = env.get_template("modelDescription.xml.j2").render(
        model_name=scene.name, guid=guid, version=__version__, identifier=identifier, me=me, cs=cs,
        description=f"{scene.n}-link pendulum hitting a flat surface ({spec.contact_model} contact, "
                    f"friction {spec.friction_law}), generated by impactgen from scene {scene.name}",
        generated_at=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        n_events=len(gen.event_names),  # the tip's, then each joint's
        sources=c_files, units=[(u, UNITS[u]) for u in units],
        stop_time=_c_double(default_stop_time(scene)), tolerance=_c_double(scene.solver.rtol),
        variables=variables_, nominals={})
    return FmuSources(identifier, sources, tuple(defines), description,
                      _build_description(identifier, c_files, defines, cs))


def default_stop_time(scene: Scene) -> float:
    """The stop time of the FMU's DefaultExperiment: the scene's `solver.t_end`. An FMU always
    runs to a time, so for a scene that stops at its first separation it is just past that
    separation (by STOP_MARGIN of the impact's duration, rounded up to one significant digit of
    the margin), found by running the scene: the C engine, or the reference engine where the C
    engine cannot be built (a Model Exchange FMU needs no SUNDIALS). A scene whose run ends
    without a finished impact (none within `solver.t_max`, or a failure) gives `solver.t_max`."""
    if scene.solver.t_end is not None:
        return scene.solver.t_end
    try:
        result = simulate(scene, warn=False)  # a run to time the experiment, not one to report
    except BuildError:
        result = simulate(scene, engine="reference", warn=False)
    first = result.first_impact
    if result.status != "ok" or not first["impacts"] or not first["t_contact"]:
        return scene.solver.t_max
    margin = STOP_MARGIN * first["t_contact"]
    digit = math.floor(math.log10(margin))
    steps = math.ceil((first["t_impact"] + first["t_contact"] + margin) / 10.0 ** digit)
    return float(f"{steps}e{digit}")


def build_fmu(scene: Scene, out: Path, kind: str = "both") -> Path:
    """Write an FMI 2.0 FMU of `scene`, which any FMI importer can simulate.

    Parameters
    ----------
    scene : Scene
        The scene: its structure picks the model, its values are the parameters' start values.
    out : path
        The .fmu file to write (written aside, then renamed into place).
    kind : {"both", "me", "cs"}
        Model Exchange (the importer's solver integrates), Co-Simulation (CVODE inside), or both.

    Returns
    -------
    Path
        `out`.

    Raises
    ------
    SceneError
        For an unknown `kind`.
    BuildError
        When no C compiler is found or, for Co-Simulation, SUNDIALS' static libraries are
        missing; the message says what to install.
    """
    built = fmu_sources(scene, kind)
    identifier, cs = built.identifier, "FMU_CO_SIMULATION" in built.defines
    with tempfile.TemporaryDirectory(prefix="impactgen-fmu-") as tmp:
        work = Path(tmp)
        src = work / "sources"
        src.mkdir()
        for name, text in built.files.items():
            (src / name).write_text(text)
        (src / "buildDescription.xml").write_text(built.build_description)
        binary = work / "binaries" / platform_folder() / f"{identifier}.so"
        binary.parent.mkdir(parents=True)
        _compile(src, built.c_files, list(built.defines), cs, binary)
        (work / "modelDescription.xml").write_text(built.model_description)
        out = Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        partial = out.with_name(out.name + ".partial")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            z.write(work / "modelDescription.xml", "modelDescription.xml")
            z.write(binary, f"binaries/{platform_folder()}/{binary.name}")
            for f in sorted(src.iterdir()):
                z.write(f, f"sources/{f.name}")
        os.replace(partial, out)
    return out


def _compile(src: Path, c_files: list[str], defines: list[str], cs: bool, binary: Path) -> None:
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise BuildError("no C compiler found to build the FMU: install gcc (Debian: 'sudo apt-get install "
                         "build-essential') or set CC")
    args = [cc, "-std=c99", *COMPILE_ARGS, "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra",
            f"-I{src}", *[f"-D{d}" for d in defines], *[str(src / f) for f in c_files]]
    if cs:
        sundials = find_sundials()
        static = sundials.static_libraries()
        if static is None:
            raise BuildError(f"Co-Simulation carries CVODE inside the FMU, which needs SUNDIALS' static "
                             f"libraries (libsundials_cvodes.a, ...) in {sundials.lib_dir}: install them "
                             "(Debian's libsundials-dev has them), or build a Model Exchange FMU (--kind me)")
        args += [f"-I{d}" for d in sundials.include_dirs] + static
        args += [f"-l{lib}" for lib in sundials.libraries if not lib.startswith("sundials_")]
    exports = src.parent / "exports.map"
    exports.write_text(EXPORTS)
    args += ["-Wl,--exclude-libs,ALL", f"-Wl,--version-script={exports}", "-lm", "-o", str(binary)]
    res = subprocess.run(args, capture_output=True, text=True)
    if res.returncode != 0:
        first = next((ln for ln in res.stderr.splitlines() if "error" in ln), res.stderr.strip()[-300:])
        raise BuildError(f"compiling the FMU failed: {first}")


def _build_description(identifier: str, c_files: list[str], defines: list[str], cs: bool) -> str:
    files = "\n".join(f'      <SourceFile name="{f}"/>' for f in c_files)
    defs = "\n".join(f'      <PreprocessorDefinition name="{d}"/>' for d in defines)
    libs = ("\n" + "\n".join(f'      <Library name="{lib}"/>' for lib in
                             ("sundials_cvodes", "sundials_arkode", "sundials_nvecserial", "sundials_sunmatrixdense",
                              "sundials_sunlinsoldense"))) if cs else ""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiBuildDescription fmiVersion="2.0">
  <!-- Rebuild: compile the C99 files below into a shared library named {identifier}, with the
       definitions below{", linked to SUNDIALS CVODES 6 or 7 (statically, to export only fmi2*)" if cs else ""}. -->
  <BuildConfiguration modelIdentifier="{identifier}">
    <SourceFileSet language="C99">
{files}
{defs}
    </SourceFileSet>{libs}
  </BuildConfiguration>
</fmiBuildDescription>
"""
