"""Memory safety: the glue under sanitizers, and no growth over repeated simulations."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

import impactgen
from conftest import PAPER, ROOT

SANITIZED = bool(os.environ.get("IMPACTGEN_SANITIZE"))
CC = shutil.which("cc") or shutil.which("gcc")


def _asan_available() -> bool:
    if CC is None:
        return False
    lib = subprocess.run([CC, "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    return os.path.isabs(lib) and os.path.exists(lib)


def _rss_bytes() -> int:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(SANITIZED or not os.path.exists("/proc/self/statm"), reason="needs /proc; ASan holds freed memory")
def test_thousand_simulations_do_not_grow_memory(paper_scene):
    failing = impactgen.load_scene(PAPER, overrides={"solver.max_steps": 5})

    def batch(count: int) -> None:
        for _ in range(count):
            impactgen.simulate(paper_scene)
            assert not impactgen.simulate(failing).success  # the error path frees CVODE too

    batch(100)  # warm up: the model is loaded, numpy and the allocator settle
    before = _rss_bytes()
    batch(1000)
    growth = _rss_bytes() - before
    # a leaked CVODE instance (vectors, dense matrix, integrator) is tens of kB: 2000 of them
    # would be tens of MB
    assert growth < 4 * 2**20, f"resident memory grew by {growth / 2**20:.1f} MiB"


def _sanitize_command() -> dict:
    return {"args": ["bash", str(ROOT / "scripts" / "sanitize.sh"), "-k",
                     "matches_the_paper or no_phase_ends or free_flight or hertz_model or stuck_tip "
                     "or static_equilibrium or t_eval_samples or partial_trajectory or explicit_pair"],
            "timeout": 900, "env": {**os.environ, "PYTHON": sys.executable}}


# about a minute of compiling and running under the sanitizers, in a cache and a folder of its own:
# first, so that it runs beside the other tests
@pytest.mark.first
@pytest.mark.skipif(SANITIZED or not _asan_available(),
                    reason="already under the sanitizers, or no AddressSanitizer runtime")
def test_glue_and_simulations_are_clean_under_sanitizers():
    res = subprocess.run(capture_output=True, text=True, **_sanitize_command())
    output = res.stdout + res.stderr
    assert res.returncode == 0, output[-4000:]
    assert "ok (0 failures)" in output
    assert "fmu ok (0 failures)" in output  # the FMI glue, driven as an importer would
    assert "AddressSanitizer" not in output and "runtime error" not in output
    assert "sanitize: clean" in output
