"""The pure-C loop (examples/c/impact_driver.c) against the Python API over the same impacts,
and the C engine's instructions per step (valgrind's callgrind, when installed).

Speed targets of the speed issue need a floor to compare with: the same generated model,
phase machine and CVODE glue, driven by a C loop with no Python. The driver is built from
the repository's examples/c (an editable install, as `make setup` makes); an installed
package without it reports the figures as not measured.
"""
from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
DRIVER = ROOT / "examples" / "c"
RTOL = 1e-8  # the speed targets' tolerance
C_REPEATS = 500  # warm runs per timing of the C loop
PY_BLOCK = 50  # warm runs per timing of the Python API
ROUNDS = 5  # C and Python alternated this many times; medians


def _build(scene, folder: Path) -> Path:
    from ..codegen.emit import driver_files, generate_model
    from ..engines import model_spec
    from ..sundials import find_sundials
    gen = generate_model(model_spec(scene))
    for name, text in driver_files(gen, scene).items():
        (folder / name).write_text(text)
    flags = find_sundials().cc_args()
    out = folder / "impact_driver"
    res = subprocess.run(["make", "-s", "-C", str(DRIVER), f"MODEL={folder}", f"OUT={out}",
                          "SUNDIALS_CFLAGS=" + " ".join(f for f in flags if f.startswith("-I")),
                          "SUNDIALS_LIBS=" + " ".join(f for f in flags if not f.startswith("-I"))],
                         capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"building the C driver failed: {res.stderr.strip()[-300:]}")
    return out


def _c_ms(driver: Path) -> float:
    out = subprocess.run([str(driver), "--repeat", str(C_REPEATS)], capture_output=True, text=True, check=True)
    return float(out.stdout.split("ms_per_run")[1].split()[0])


def _python_ms(scene) -> float:
    import impactgen
    started = time.perf_counter()
    for _ in range(PY_BLOCK):
        impactgen.simulate(scene).summary
    return (time.perf_counter() - started) / PY_BLOCK * 1e3


def _instructions_per_step(driver: Path, folder: Path) -> dict:
    """callgrind's instructions per run of the C loop (the driver with --repeat 1 and with
    --repeat 11, differenced, so its start-up cancels), over CVODE's steps per run."""
    if not shutil.which("valgrind"):
        return {"error": "valgrind is not installed"}
    counts = {}
    for repeat in (1, 11):
        out = folder / f"callgrind.{repeat}"
        res = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(driver),
                              "--repeat", str(repeat)], capture_output=True, text=True)
        totals = [line for line in res.stderr.splitlines() if "Collected" in line]
        if res.returncode != 0 or not totals:
            return {"error": f"callgrind failed: {res.stderr.strip()[-200:]}"}
        counts[repeat] = int(totals[-1].split(":")[-1].strip().replace(",", ""))
        steps = int(res.stdout.split("steps")[1].split()[0])
    per_run = (counts[11] - counts[1]) / 10
    return {"instructions_per_run": per_run, "steps": steps, "instructions_per_step": per_run / steps}


def c_loop(scene_name: str = "paper") -> dict:
    """The C loop against the Python API (summary read), alternated; and instructions per step."""
    import impactgen
    if not (DRIVER / "impact_driver.c").is_file():
        return {"error": f"the C driver's source is not here ({DRIVER}): an editable install has it"}
    scene = impactgen.load_scene(scene_name).replace({"solver.rtol": RTOL})
    with tempfile.TemporaryDirectory(prefix="impactgen-cloop-") as tmp:
        folder = Path(tmp)
        try:
            driver = _build(scene, folder)
        except (RuntimeError, OSError) as exc:
            return {"error": str(exc)}
        _python_ms(scene)
        c, py = [], []
        for _ in range(ROUNDS):
            c.append(_c_ms(driver))
            py.append(_python_ms(scene))
        result = {"scene": scene_name, "rtol": RTOL, "c_ms": statistics.median(c), "python_ms": statistics.median(py),
                  "c_runs_ms": c, "python_runs_ms": py}
        result["ratio"] = result["python_ms"] / result["c_ms"]
        result.update(_instructions_per_step(driver, folder))
    return result


if __name__ == "__main__":  # pragma: no cover - a manual look
    print(c_loop(sys.argv[1] if len(sys.argv) > 1 else "paper"))
