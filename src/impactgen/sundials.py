"""Find SUNDIALS CVODES (headers and libraries) for the build, version 6.x or 7.x.

CVODES, not CVODE: the BDF stepper integrates the works and impulses as CVODES quadratures
(native/step_cvode.c). Debian's libsundials-dev, conda's and Homebrew's sundials ship both."""
from __future__ import annotations

import functools
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from .errors import BuildError

INSTALL_HINT = (
    "install SUNDIALS (CVODES): on Debian/Ubuntu 'sudo apt-get install libsundials-dev' "
    "(or run 'make setup'), with conda 'conda install -c conda-forge sundials', on macOS "
    "'brew install sundials'; or set SUNDIALS_DIR to the prefix it is installed under"
)


MPI_HINT = (
    "install the MPI development files it was built with (Debian/Ubuntu: 'sudo apt-get install "
    "mpi-default-dev'; conda: 'conda install -c conda-forge openmpi'), or set SUNDIALS_DIR to a "
    "SUNDIALS built without MPI"
)


@dataclass(frozen=True)
class Sundials:
    version: str
    include_dirs: tuple[str, ...]  # SUNDIALS' own first, then MPI's if its headers need mpi.h
    library_dirs: tuple[str, ...]  # empty: the compiler's default search path
    libraries: tuple[str, ...]  # in link order
    lib_dir: str = ""  # where the libraries were found (system folders included)

    @property
    def major(self) -> int:
        return int(self.version.split(".")[0])

    def static_libraries(self) -> list[str] | None:
        """The static archives (lib*.a) of the SUNDIALS libraries, in link order, for a
        shared object that must carry CVODES inside (an FMU); None when one is missing."""
        found = []
        for lib in self.libraries:
            if not lib.startswith("sundials_"):
                continue  # MPI and friends stay dynamic
            path = Path(self.lib_dir) / f"lib{lib}.a"
            if not path.is_file():
                return None
            found.append(str(path))
        return found

    def cc_args(self) -> list[str]:
        """-I, -L, rpath and -l flags for a plain compiler command (test drivers, scripts)."""
        return ([f"-I{d}" for d in self.include_dirs] + [f"-L{d}" for d in self.library_dirs]
                + [f"-Wl,-rpath,{d}" for d in self.library_dirs] + [f"-l{lib}" for lib in self.libraries])


def _prefixes() -> list[Path]:
    out = []
    if os.environ.get("SUNDIALS_DIR"):
        out.append(Path(os.environ["SUNDIALS_DIR"]))
    if os.environ.get("CONDA_PREFIX"):
        out.append(Path(os.environ["CONDA_PREFIX"]))
    out += [Path(sys.prefix), Path("/usr/local"), Path("/usr"), Path("/opt/homebrew"),
            Path("/opt/local")]
    return out


def _pkg_config(package: str, *what: str) -> list[str] | None:
    """The flags pkg-config gives for `package`, or None when it does not know it."""
    if not shutil.which("pkg-config"):
        return None
    try:
        res = subprocess.run(["pkg-config", *what, package], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return res.stdout.split() if res.returncode == 0 else None


def _pkg_config_include() -> list[Path]:
    flags = _pkg_config("sundials-cvodes", "--cflags-only-I") or []
    return [Path(flag[2:]) for flag in flags if flag.startswith("-I")]


def _mpi(include: Path, lib_dir: Path) -> tuple[list[str], list[str], list[str]] | None:
    """Include dirs, library dirs and libraries of MPI, for a SUNDIALS 7 built with it: its
    sundials_types.h includes mpi.h, and SUN_COMM_NULL is MPI_COMM_NULL, which OpenMPI
    defines through a symbol of libmpi. None when no MPI development files are found."""
    if (include / "mpi.h").is_file():  # conda and hand-made prefixes: MPI beside SUNDIALS
        return [], [], ["mpi"] if any(lib_dir.glob("libmpi.*")) else []
    for package in ("mpi", "ompi-c", "mpich"):
        flags = _pkg_config(package, "--cflags", "--libs")
        if flags is not None:
            return tuple([f[2:] for f in flags if f.startswith(kind)] for kind in ("-I", "-L", "-l"))
    return None


def _library_dir(prefix: Path, name: str) -> Path | None:
    for sub in ("lib", "lib64", f"lib/{_multiarch()}"):
        d = prefix / sub
        if any(d.glob(f"lib{name}.*")):
            return d
    return None


def _multiarch() -> str:
    import sysconfig
    return sysconfig.get_config_var("MULTIARCH") or "x86_64-linux-gnu"


@functools.lru_cache(maxsize=1)
def find_sundials() -> Sundials:
    """Locate CVODES; raise BuildError saying how to install it when it is missing."""
    candidates = [(p / "include", p) for p in _prefixes()]
    candidates = [(inc, inc.parent) for inc in _pkg_config_include()] + candidates
    looked = []
    for include, prefix in candidates:
        config = include / "sundials" / "sundials_config.h"
        looked.append(str(include))
        if not (include / "cvodes" / "cvodes.h").is_file() or not config.is_file():
            continue
        text = config.read_text(errors="replace")
        match = re.search(r'#define\s+SUNDIALS_VERSION\s+"([0-9.]+)', text)
        if not match:
            continue
        version = match.group(1)
        major = int(version.split(".")[0])
        if major < 6:
            raise BuildError(f"SUNDIALS {version} found in {include} is too old: impactgen "
                             f"needs 6.x or 7.x; {INSTALL_HINT}")
        libs = ["sundials_cvodes", "sundials_arkode", "sundials_nvecserial", "sundials_sunmatrixdense",
                "sundials_sunlinsoldense"]
        lib_dir = _library_dir(prefix, "sundials_cvodes")
        if lib_dir is None:
            continue
        if major >= 7 and any(lib_dir.glob("libsundials_core.*")):
            libs.append("sundials_core")
        missing = [lib for lib in libs if not any(lib_dir.glob(f"lib{lib}.*"))]
        if missing:
            raise BuildError(f"SUNDIALS {version} in {prefix} lacks {', '.join(missing)}; "
                             f"{INSTALL_HINT}")
        system = str(lib_dir).startswith(("/usr/lib", "/lib"))
        include_dirs, library_dirs = [str(include)], [] if system else [str(lib_dir)]
        if major >= 7 and re.search(r"#define\s+SUNDIALS_MPI_ENABLED\s+1", text):
            mpi = _mpi(include, lib_dir)
            if mpi is None:
                raise BuildError(f"SUNDIALS {version} in {prefix} was built with MPI, so its headers "
                                 f"include mpi.h, and no MPI was found (looked in {include} and asked "
                                 f"pkg-config for mpi, ompi-c and mpich); {MPI_HINT}")
            include_dirs += mpi[0]
            library_dirs += [d for d in mpi[1] if d not in library_dirs]
            libs += mpi[2]
        return Sundials(version, tuple(include_dirs), tuple(library_dirs), tuple(libs), str(lib_dir))
    raise BuildError(f"SUNDIALS CVODES not found (looked for cvodes/cvodes.h under "
                     f"{', '.join(dict.fromkeys(looked))}); {INSTALL_HINT}")
