"""Find SUNDIALS CVODE (headers and libraries) for the build, version 6.x or 7.x."""
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
    "install SUNDIALS CVODE: on Debian/Ubuntu 'sudo apt-get install libsundials-dev' "
    "(or run 'make setup'), with conda 'conda install -c conda-forge sundials', on macOS "
    "'brew install sundials'; or set SUNDIALS_DIR to the prefix it is installed under"
)


@dataclass(frozen=True)
class Sundials:
    version: str
    include_dir: str
    library_dir: str | None  # None: the compiler's default search path
    libraries: tuple[str, ...]

    @property
    def major(self) -> int:
        return int(self.version.split(".")[0])


def _prefixes() -> list[Path]:
    out = []
    if os.environ.get("SUNDIALS_DIR"):
        out.append(Path(os.environ["SUNDIALS_DIR"]))
    if os.environ.get("CONDA_PREFIX"):
        out.append(Path(os.environ["CONDA_PREFIX"]))
    out += [Path(sys.prefix), Path("/usr/local"), Path("/usr"), Path("/opt/homebrew"),
            Path("/opt/local")]
    return out


def _pkg_config_include() -> list[Path]:
    if not shutil.which("pkg-config"):
        return []
    try:
        res = subprocess.run(["pkg-config", "--cflags-only-I", "sundials-cvode"],
                             capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return []
    if res.returncode != 0:
        return []
    return [Path(flag[2:]) for flag in res.stdout.split() if flag.startswith("-I")]


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
    """Locate CVODE; raise BuildError saying how to install it when it is missing."""
    candidates = [(p / "include", p) for p in _prefixes()]
    candidates = [(inc, inc.parent) for inc in _pkg_config_include()] + candidates
    looked = []
    for include, prefix in candidates:
        config = include / "sundials" / "sundials_config.h"
        looked.append(str(include))
        if not (include / "cvode" / "cvode.h").is_file() or not config.is_file():
            continue
        match = re.search(r'#define\s+SUNDIALS_VERSION\s+"([0-9.]+)', config.read_text(errors="replace"))
        if not match:
            continue
        version = match.group(1)
        major = int(version.split(".")[0])
        if major < 6:
            raise BuildError(f"SUNDIALS {version} found in {include} is too old: impactgen "
                             f"needs 6.x or 7.x; {INSTALL_HINT}")
        libs = ["sundials_cvode", "sundials_nvecserial", "sundials_sunmatrixdense",
                "sundials_sunlinsoldense"]
        lib_dir = _library_dir(prefix, "sundials_cvode")
        if lib_dir is None:
            continue
        if major >= 7 and any(lib_dir.glob("libsundials_core.*")):
            libs.append("sundials_core")
        missing = [lib for lib in libs if not any(lib_dir.glob(f"lib{lib}.*"))]
        if missing:
            raise BuildError(f"SUNDIALS {version} in {prefix} lacks {', '.join(missing)}; "
                             f"{INSTALL_HINT}")
        system = str(lib_dir).startswith(("/usr/lib", "/lib"))
        return Sundials(version, str(include), None if system else str(lib_dir), tuple(libs))
    raise BuildError(f"SUNDIALS CVODE not found (looked for cvode/cvode.h under "
                     f"{', '.join(dict.fromkeys(looked))}); {INSTALL_HINT}")
