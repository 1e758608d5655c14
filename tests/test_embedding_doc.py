"""The C program of docs/embedding.md ("The C API"), taken from the page as it stands: it
compiles warning-free against a generated model with nothing but the generated files, and its
fixed-step run to the first separation gives `impactgen run`'s impact."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import impactgen

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "embedding.md"
FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror")
MODEL_FILES = ("model.c", "model_params.c", "model_machine.c", "model_stick_slip.c")
RTOL = 1e-4  # its fixed step of 1e-7 s against impactgen run at rtol 1e-10


def doc_program() -> str:
    text = DOC.read_text(encoding="utf-8")
    found = re.search(r"<!-- embed\.c:begin -->\n```c\n(.*?)```\n<!-- embed\.c:end -->", text, re.S)
    assert found, "docs/embedding.md has no program between <!-- embed.c:begin --> and <!-- embed.c:end -->"
    return found.group(1)


def compile_and_run(folder: Path, work: Path) -> dict[str, float]:
    cc = shutil.which("cc") or shutil.which("gcc")
    if not cc:
        pytest.skip("no C compiler")
    source = work / "embed.c"
    source.write_text(doc_program())
    binary = work / "embed"
    made = subprocess.run([cc, *FLAGS, f"-I{folder}", str(source), *(str(folder / f) for f in MODEL_FILES), "-lm",
                           "-o", str(binary)], capture_output=True, text=True)
    assert made.returncode == 0, made.stderr
    out = subprocess.run([str(binary)], capture_output=True, text=True, check=True).stdout
    return {name: float(value) for name, value in (line.split(" ", 1) for line in out.splitlines())}


@pytest.mark.parametrize("scene_name", ["paper", pytest.param("chain3-free-flight", marks=pytest.mark.slow)])
def test_the_documented_program_compiles_and_gives_impactgen_runs_impact(scene_name, tmp_path):
    folder = tmp_path / "model"
    subprocess.run([sys.executable, "-m", "impactgen.cli", "generate", scene_name, "--out", str(folder)],
                   check=True, capture_output=True, text=True)
    printed = compile_and_run(folder, tmp_path)
    s = impactgen.simulate(impactgen.load_scene(scene_name)).summary
    assert printed["impacts"] == 1
    for name in ("delta_max", "delta_r", "P_max"):
        assert printed[name] == pytest.approx(s[name], rel=RTOL), name
    assert printed["t_end"] == pytest.approx(s["t_final"], rel=RTOL)
    assert printed["T"] == pytest.approx(s["Tf"], rel=RTOL)
    assert printed["W_normal"] == pytest.approx(s["energy"]["W_normal"], rel=RTOL)
    for i, u in enumerate(s["u_final"], start=1):
        assert printed[f"u_final[{i}]"] == pytest.approx(u, rel=RTOL)
