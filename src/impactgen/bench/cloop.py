"""The pure-C loop (examples/c/impact_driver.c) against the Python API over the same impacts,
and, in the same Python timings, `simulate(scene, rtol=...)` against the scene with that rtol
inside it. Reported beside them, not judged: the C engine's instructions per step, by
contact phase, and where they go (valgrind's callgrind, when installed), with the API's
instructions per call beside the C loop's.

The targets need a floor to compare with: the same generated model, phase machine and CVODE
glue, driven by a C loop with no Python. The driver is built from the repository's
examples/c (an editable install, as `make setup` makes); an installed package without it
reports the figures as not measured.
"""
from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
DRIVER = ROOT / "examples" / "c"
RTOL = 1e-8  # the speed targets' tolerance
C_REPEATS = 2000  # warm runs per timing of the C loop
PY_BLOCK = 200  # warm runs per block of the Python API
PY_BLOCKS = 7  # blocks per timing of the Python API: their median, about as long as the C loop's
PY_WARM = 50  # runs before the first timing (the model loaded, the integrator pooled)
ROUNDS = 9  # pairs of a C timing and a Python timing back to back; the median of the pairs' ratios
API_CALLS = 300  # calls of the Python API counted by callgrind (about 20 s under valgrind)


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


_PYTHON_LOOP = """
import statistics, sys, time
import impactgen
base = impactgen.load_scene(sys.argv[1])
rtol = float(sys.argv[2])
scene = base.replace({"solver.rtol": rtol})
warm, block, count = (int(a) for a in sys.argv[3:6])
OPTION_WARM = 20
TURN = 20  # calls of one form before the other's: about a millisecond, shorter than the host's swings
for _ in range(OPTION_WARM):  # the same count in every process: callgrind's difference cancels it
    impactgen.simulate(base, rtol=rtol, record_steps=False).summary
for _ in range(warm):
    impactgen.simulate(scene, record_steps=False).summary
print("ready", flush=True)
clock = time.perf_counter
turn = min(TURN, block)
for _ in sys.stdin:  # one timing per line asked for: the scene with its rtol, and the option, in short turns
    inside, option = [], []
    for _ in range(count):
        a = b = 0.0
        for _ in range(block // turn):
            started = clock()
            for _ in range(turn):
                impactgen.simulate(scene, record_steps=False).summary
            middle = clock()
            for _ in range(turn):
                impactgen.simulate(base, rtol=rtol, record_steps=False).summary
            a, b = a + middle - started, b + clock() - middle
        inside.append(a / (block // turn * turn) * 1e3)
        option.append(b / (block // turn * turn) * 1e3)
    ratios = [b / a for a, b in zip(inside, option)]
    print(statistics.median(inside), statistics.median(option), statistics.median(ratios), flush=True)
"""


class PythonLoop:
    """The Python API as a sweep calls it (summary only, without the steps), warm, in a
    process of its own as the C loop runs in one (a process that has imported sympy to build
    the driver pays for its objects in every garbage collection). It stays up between
    timings, so that each Python timing follows its C timing within milliseconds: this
    host's speed moves by half within a second, and a pair timed a process start apart
    (about a second) measured the host as much as the code."""

    def __init__(self, scene_name: str):
        self.process = subprocess.Popen(
            [sys.executable, "-c", _PYTHON_LOOP, scene_name, str(RTOL), str(PY_WARM), str(PY_BLOCK), str(PY_BLOCKS)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        if self.process.stdout.readline().strip() != "ready":
            self.close()
            raise RuntimeError("the Python API's timing process did not start")

    def ms(self) -> tuple[float, float, float]:
        """One timing: PY_BLOCKS blocks of PY_BLOCK calls of the scene with its rtol, in turns
        of 20 calls with as many of the scene given the rtol as an option (a turn lasts about
        a millisecond, so the host's speed moves both forms alike, and each form runs on
        warm caches of its own); the medians (ms per call) of each and of the blocks' ratios
        (option / inside)."""
        self.process.stdin.write("\n")
        self.process.stdin.flush()
        inside, option, ratio = (float(v) for v in self.process.stdout.readline().split())
        return inside, option, ratio

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait(timeout=60)

    def __enter__(self) -> "PythonLoop":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def paired_timings(driver: Path, scene_name: str) -> dict:
    """ROUNDS pairs of a C timing and a Python timing back to back, the order swapped every
    round (a trend in the host's speed then favours neither); the ratio is the median of the
    pairs' ratios, as the sweep-overhead target takes it. The Python timing also gives the
    cost of `simulate(scene, rtol=...)` against the scene with that rtol inside it."""
    c, py, option, option_ratios = [], [], [], []
    with PythonLoop(scene_name) as python:
        for k in range(ROUNDS):
            if k % 2:
                timing = python.ms()
                c.append(_c_ms(driver))
            else:
                c.append(_c_ms(driver))
                timing = python.ms()
            py.append(timing[0])
            option.append(timing[1])
            option_ratios.append(timing[2])
    ratios = [p / q for p, q in zip(py, c)]
    return {"c_ms": statistics.median(c), "python_ms": statistics.median(py), "c_runs_ms": c, "python_runs_ms": py,
            "pair_ratios": ratios, "ratio": statistics.median(ratios), "option_ms": statistics.median(option),
            "option_runs_ms": option, "option_ratios": option_ratios, "option_ratio": statistics.median(option_ratios)}


def _instructions_per_step(driver: Path, folder: Path) -> dict:
    """callgrind's instructions per run of the C loop (the driver with --repeat 1 and with
    --repeat 11, differenced, so its start-up cancels), over CVODE's steps per run."""
    if not shutil.which("valgrind"):
        return {"error": "valgrind is not installed"}
    counts = {}
    try:
        for repeat in (1, 11):
            out = folder / f"callgrind.{repeat}"
            stdout = _callgrind(driver, out, repeat)
            counts[repeat] = _instructions(out)
            steps = int(stdout.split("steps")[1].split()[0])
    except RuntimeError as exc:
        return {"error": str(exc)}
    per_run = (counts[11] - counts[1]) / 10
    return {"instructions_per_run": per_run, "steps": steps, "instructions_per_step": per_run / steps}


def _callgrind(driver: Path, out: Path, repeat: int, *options: str) -> str:
    return _under_callgrind([*options, str(driver), "--repeat", str(repeat)], out)


def _under_callgrind(command: list[str], out: Path, env: dict | None = None, stdin: str | None = None) -> str:
    """Run `command` (callgrind's options first) under callgrind, its counts to `out`; its stdout."""
    res = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *command],
                         capture_output=True, text=True, env=env, input=stdin)
    if res.returncode != 0:
        raise RuntimeError(f"callgrind failed: {res.stderr.strip()[-200:]}")
    return res.stdout


def _api_instructions(scene_name: str, folder: Path) -> dict:
    """callgrind's instructions per call of the Python API, by `PythonLoop`'s script run for
    one call and for one plus API_CALLS, differenced (start-up and the first call's pools
    cancel): the API's cost beside the C loop's in a count the host's load cannot move.
    numpy's OpenBLAS gets no thread pool: its idle threads spin a varying while after
    start-up, and callgrind counts their instructions (300 calls read 620 to 715 thousand
    instructions each with the pool, 668 thousand to within 0.1 thousand without it)."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"}
    counts = {}
    for calls in (1, 1 + API_CALLS):
        out = folder / f"callgrind.api.{calls}"
        _under_callgrind([sys.executable, "-c", _PYTHON_LOOP, scene_name, str(RTOL), str(calls), "1", "1"], out, env,
                         stdin="")  # no timing asked for: the warm calls are the count
        counts[calls] = _instructions(out)
    return {"api_instructions_per_run": (counts[1 + API_CALLS] - counts[1]) / API_CALLS}


def _instructions(dump: Path) -> int:
    """The instruction count of one callgrind dump (its summary line)."""
    return int(next(line for line in dump.read_text().splitlines() if line.startswith("summary:")).split()[1])


def _segment_steps(scene) -> list[tuple[str, int]]:
    """(phase, CVODE steps) of each segment of the scene's run: every step is a sample."""
    import numpy as np

    import impactgen
    result = impactgen.simulate(scene)
    return [(span.phase, int(np.searchsorted(result.t, span.t1, "right") - np.searchsorted(result.t, span.t0, "right")))
            for span in result.phases]


def _instructions_by_phase(driver: Path, folder: Path, segments: list[tuple[str, int]]) -> dict:
    """Instructions per CVODE step in each contact phase: callgrind dumps its counts at every
    entry into the machine's switch, so each dump holds one segment (with the switch before
    it); the first run's dumps (the program's start-up) are left out."""
    repeat = 10
    _callgrind(driver, folder / "bysegment", repeat, "--dump-before=model_machine_switch")
    dumps = sorted(folder.glob("bysegment.*"), key=lambda f: int(f.suffix[1:]))
    counts = [_instructions(f) for f in dumps]
    per_run = len(segments)
    if len(counts) != per_run * (repeat + 1):
        return {"error": f"expected {per_run * (repeat + 1)} callgrind dumps, found {len(counts)}"}
    ir: dict[str, float] = {}
    steps: dict[str, int] = {}
    for k, count in enumerate(counts[per_run:]):
        phase, n = segments[k % per_run]
        ir[phase] = ir.get(phase, 0.0) + count
        steps[phase] = steps.get(phase, 0) + n
    return {"instructions_per_step_by_phase": {p: ir[p] / steps[p] for p in ir}}


# Where the C engine's instructions go: the inclusive cost of these functions of the glue,
# the small kernels and the generated model, against the whole of ig_run.
COST_PARTS = {  # the generated functions: the integrators' own wrappers may be inlined
    "right-hand side": ("model_rhs",),
    "event functions (roots)": ("model_events",),
    "Jacobian": ("model_jacobian",),
    "linear algebra (dense LU)": ("dense_setup", "dense_solve"),
    "phase machine and samples": ("model_machine_switch", "model_machine_observe", "model_machine_events",
                                  "model_outputs"),
}


def _where_instructions_go(driver: Path, folder: Path) -> dict:
    out = folder / "inclusive"
    _callgrind(driver, out, 10)
    res = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                         capture_output=True, text=True)
    inclusive: dict[str, int] = {}
    for line in res.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].replace(",", "").isdigit() and ":" in line:
            name = line.rsplit(":", 1)[1].split()[0]
            inclusive.setdefault(name, int(parts[0].replace(",", "")))
    total = inclusive.get("ig_run")
    if not total:
        return {"error": "callgrind_annotate did not list ig_run"}
    shares = {part: sum(inclusive.get(f, 0) for f in names) / total for part, names in COST_PARTS.items()}
    shares["the integrator's own work"] = 1.0 - sum(shares.values())
    return {"instruction_shares": shares}


def c_loop(scene_name: str = "paper") -> dict:
    """The C loop against the Python API (summary read) and the option form, alternated; and
    the instruction counts (reported)."""
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
        try:
            result = {"scene": scene_name, "rtol": RTOL, **paired_timings(driver, scene_name)}
        except (RuntimeError, OSError, ValueError, subprocess.SubprocessError) as exc:
            return {"error": f"timing the Python API failed: {exc}"}
        result.update(_instructions_per_step(driver, folder))
        if "instructions_per_step" in result:
            try:
                result.update(_instructions_by_phase(driver, folder, _segment_steps(scene)))
                result.update(_where_instructions_go(driver, folder))
                result.update(_api_instructions(scene_name, folder))
                result["instruction_ratio"] = result["api_instructions_per_run"] / result["instructions_per_run"]
            except (RuntimeError, OSError) as exc:
                result["error"] = str(exc)
    return result


if __name__ == "__main__":  # pragma: no cover - a manual look
    print(c_loop(sys.argv[1] if len(sys.argv) > 1 else "paper"))
