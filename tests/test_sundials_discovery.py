"""Finding SUNDIALS 6.x and 7.x, and the MPI that a SUNDIALS 7 built with MPI needs, on fake
install prefixes (the real build against SUNDIALS 7 is checked by hand: docs/safety.md)."""
from __future__ import annotations

from pathlib import Path

import pytest

from impactgen import sundials
from impactgen.errors import BuildError

LIBS = ("sundials_cvodes", "sundials_arkode", "sundials_nvecserial", "sundials_sunmatrixdense",
        "sundials_sunlinsoldense", "sundials_core")


def _prefix(root: Path, version: str, mpi_enabled: bool, mpi_beside: bool = False) -> Path:
    """A prefix with what find_sundials looks at: cvodes.h, sundials_config.h, the libraries."""
    (root / "include" / "cvodes").mkdir(parents=True)
    (root / "include" / "sundials").mkdir()
    (root / "lib").mkdir()
    (root / "include" / "cvodes" / "cvodes.h").write_text("")
    (root / "include" / "sundials" / "sundials_config.h").write_text(
        f'#define SUNDIALS_VERSION "{version}"\n#define SUNDIALS_MPI_ENABLED {int(mpi_enabled)}\n')
    for lib in LIBS:
        (root / "lib" / f"lib{lib}.so").write_text("")
    if mpi_beside:
        (root / "include" / "mpi.h").write_text("")
        (root / "lib" / "libmpi.so").write_text("")
    return root


def _find(monkeypatch, prefix: Path, pkg_config: dict[str, list[str]]) -> sundials.Sundials:
    monkeypatch.setattr(sundials, "_prefixes", lambda: [prefix])
    monkeypatch.setattr(sundials, "_pkg_config", lambda package, *what: pkg_config.get(package))
    return sundials.find_sundials.__wrapped__()


def test_sundials_7_with_mpi_and_no_mpi_says_what_to_install(tmp_path, monkeypatch):
    prefix = _prefix(tmp_path, "7.1.1", mpi_enabled=True)
    with pytest.raises(BuildError, match="built with MPI.*apt-get install mpi-default-dev"):
        _find(monkeypatch, prefix, {})


def test_sundials_7_with_mpi_takes_mpi_flags_from_pkg_config(tmp_path, monkeypatch):
    prefix = _prefix(tmp_path, "7.1.1", mpi_enabled=True)
    found = _find(monkeypatch, prefix, {"mpi": ["-I/opt/mpi/include", "-L/opt/mpi/lib", "-lmpi"]})
    assert found.major == 7
    assert found.include_dirs == (str(prefix / "include"), "/opt/mpi/include")
    assert found.library_dirs == (str(prefix / "lib"), "/opt/mpi/lib")
    assert found.libraries == (*LIBS, "mpi")  # libmpi after the SUNDIALS libraries that need it


def test_sundials_7_with_mpi_beside_it_needs_no_pkg_config(tmp_path, monkeypatch):
    prefix = _prefix(tmp_path, "7.2.0", mpi_enabled=True, mpi_beside=True)
    found = _find(monkeypatch, prefix, {})
    assert found.include_dirs == (str(prefix / "include"),)
    assert found.libraries[-1] == "mpi"


@pytest.mark.parametrize("version, mpi_enabled", [("6.4.1", True), ("7.1.1", False)])
def test_no_mpi_flags_when_the_headers_do_not_include_mpi_h(tmp_path, monkeypatch, version, mpi_enabled):
    prefix = _prefix(tmp_path, version, mpi_enabled)
    found = _find(monkeypatch, prefix, {"mpi": ["-I/opt/mpi/include", "-lmpi"]})
    assert found.include_dirs == (str(prefix / "include"),)
    assert "mpi" not in found.libraries
    assert ("sundials_core" in found.libraries) == version.startswith("7")


def test_cc_args_link_every_library_from_its_folder(tmp_path, monkeypatch):
    prefix = _prefix(tmp_path, "7.1.1", mpi_enabled=False)
    args = _find(monkeypatch, prefix, {}).cc_args()
    lib = prefix / "lib"
    assert args == [f"-I{prefix / 'include'}", f"-L{lib}", f"-Wl,-rpath,{lib}", *(f"-l{name}" for name in LIBS)]
