"""Benchmarks: error against run time, right-hand-side cost, build cost as n grows, and sweeps."""
from __future__ import annotations

import importlib
import time
from pathlib import Path


FULL_LINKS = (2, 3, 5, 10, 20, 30)  # the chain lengths the growth with n is measured at
QUICK_LINKS = (2, 3, 5)
# the parts `impactgen bench --parts` runs, by default all but "batch" (a million cases: minutes)
PARTS = ("workprecision", "rhs", "scaling", "sweep", "points", "free", "laws", "batch")
DEFAULT_PARTS = tuple(p for p in PARTS if p != "batch")


def seconds_per_run(run, repeats: int) -> float:
    """The mean wall time of `repeats` calls of `run` (one timing: a run shorter than the clock's
    step is timed in a loop)."""
    started = time.perf_counter()
    for _ in range(repeats):
        run()
    return (time.perf_counter() - started) / repeats


def run_benchmarks(out: Path, quick: bool, parts: set[str]) -> Path:
    """Run the parts asked for ("workprecision", "rhs", "scaling", "sweep", "points", "free", "laws",
    "batch") and write the report ("batch" is not among the default parts: a million cases take
    minutes)."""
    from .report import write_report
    from .rhs import rhs_benchmark
    from .scaling import scaling
    from .workprecision import FULL, QUICK, run_workprecision
    started = time.perf_counter()
    settings = QUICK if quick else FULL
    runs, truths, notes = run_workprecision(settings) if "workprecision" in parts else ([], [], [])
    c_loop, in_turn = {}, {}
    if "workprecision" in parts:
        from .inturn import ROUNDS, time_in_turn
        from .report import target_contenders
        picked = target_contenders(runs)
        if picked:
            in_turn = time_in_turn(runs, "paper", *picked, settings, rounds=3 if quick else ROUNDS)
        from .cloop import c_loop as measure_c_loop
        c_loop = measure_c_loop()
    rhs_rows = rhs_benchmark((2, 3, 5) if quick else (2, 3, 5, 10, 20)) if "rhs" in parts else []
    scaling_rows = scaling(QUICK_LINKS if quick else FULL_LINKS) if "scaling" in parts else []
    sweep_result = {}
    if "sweep" in parts:
        from .sweep import sweep_benchmark
        sweep_result = sweep_benchmark(quick)
    if "batch" in parts:  # the sweep against the C loop, and a million cases: what the batch entry is judged by
        from .sweep import batch_benchmark
        sweep_result["batch"] = batch_benchmark(quick)
    points_result = {}
    if "points" in parts:
        from .points import points_benchmark
        points_result = points_benchmark(quick)
    extra = {}  # the parts of one scene each, with their targets and their report's lines
    for name, module in (("free", "free_bodies"), ("laws", "laws")):
        if name in parts:
            part = importlib.import_module(f".{module}", __name__)
            extra[name] = (part, part.benchmark(quick))
    return write_report(out, "quick" if quick else "full", runs, truths, notes, rhs_rows, scaling_rows,
                        time.perf_counter() - started, sweep_result, c_loop, in_turn, points_result, extra)
