"""The small kernels CVODE runs on (vector, dense matrix, dense LU) give the library's results
bit for bit: tests/c/kernels_driver.c compares them call by call."""
from __future__ import annotations

import shutil
import subprocess

import pytest

from impactgen.build import _native
from impactgen.sundials import find_sundials
from conftest import ROOT

CC = shutil.which("cc") or shutil.which("gcc")


@pytest.mark.skipif(CC is None, reason="no C compiler")
def test_small_kernels_agree_with_sundials_bit_for_bit(tmp_path):
    for name in ("small_kernels.c", "small_kernels.h"):
        (tmp_path / name).write_text(_native(name))
    sundials = find_sundials()
    build = subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", f"-I{tmp_path}",
                            str(ROOT / "tests" / "c" / "kernels_driver.c"), str(tmp_path / "small_kernels.c"),
                            *sundials.cc_args(), "-lm", "-o", str(tmp_path / "driver")],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(tmp_path / "driver")], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "kernels: ok" in run.stdout
