"""The explicit pair's stages take their angles' sines and cosines from the step start's by a
short series (dopri5.c, shifted_trig): within an ulp of 1 of the exact values, closer than libm
at the stage angle rounded to a double, and so is a chain of TRIG_CHAIN_MAX of them (a step's
end point shifted from its start's, step after step); and the model's trig entry points give
the plain ones' results bit for bit. tests/c/trig_shift_driver.c checks both."""
from __future__ import annotations

import shutil
import subprocess

import pytest

from impactgen.build import COMPILE_ARGS
from conftest import ROOT

CC = shutil.which("cc") or shutil.which("gcc")
MODEL = ROOT / "generated" / "paper-double-pendulum"
NATIVE = ROOT / "src" / "impactgen" / "native"


@pytest.mark.skipif(CC is None, reason="no C compiler")
def test_shifted_sines_and_cosines_are_within_an_ulp(tmp_path):
    build = subprocess.run([CC, "-std=c99", *COMPILE_ARGS, "-Wall", "-Wextra", "-Werror", f"-I{MODEL}", f"-I{NATIVE}",
                            str(ROOT / "tests" / "c" / "trig_shift_driver.c"), str(MODEL / "model.c"), "-lm",
                            "-o", str(tmp_path / "driver")], capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(tmp_path / "driver")], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "trig shift: ok" in run.stdout
