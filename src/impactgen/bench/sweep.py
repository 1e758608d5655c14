"""Sweep benchmark: what a sweep costs on top of the engine, and a Monte Carlo at scale.

- Overhead: a summary-only sweep of the paper's scene (omega20 varied) on a pool of two
  workers, against N times the engine's own time per impact over two cores, measured as
  that: the same two workers each running `simulate` (without its steps, as a sweep runs it,
  and reading its summary) over their half of the same cases, nothing else. The two are
  alternated 5 times (3 with --quick), in a process that has run a small sweep first (its
  imports done, as the engine is timed warm); the median of the rounds' ratios.
- Scale: a Monte Carlo over seven uncertain inputs (MONTE_CARLO) on the local pool, and the
  same command on a Dask cluster made of a `dask scheduler` and two `dask worker` processes
  started separately on localhost. Each driver runs in its own process, which reports its
  wall time and its own peak resident memory (the workers are other processes).
"""
from __future__ import annotations

import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .verdict import verdict

OVERHEAD_TARGET = 1.15  # sweep wall time at most this times N x engine time / workers
WORKERS = 2
MONTE_CARLO = {  # the ranges docs/sweeps.md states
    "initial.q_deg[1]": "uniform(-80,-60)",
    "initial.q_deg[2]": "uniform(-70,-50)",
    "initial.u[1]": "uniform(-0.3,-0.05)",
    "initial.u[2]": "uniform(-0.5,-0.1)",
    "contact.friction": "uniform(0.1,0.4)",
    "rod.yield_strength": "normal(1.12e9,0.08e9)",
    "surface.yield_strength": "normal(1.12e9,0.08e9)",
}
MONTE_CARLO_SEED = 2020

_DRIVER = """
import json, resource, sys, time
import impactgen
vary, n, seed, scheduler = json.loads(sys.argv[1])
started = time.perf_counter()
table = impactgen.sweep("paper", vary=vary, random=n, seed=seed, scheduler=scheduler,
                        workers=None if scheduler not in (None, "local") else %d)
wall = time.perf_counter() - started
ok = table[table["status"] == "ok"]
print(json.dumps({"cases": len(table), "ok": len(ok), "impacts": int(ok["impacts"].sum()), "wall_s": wall,
                  "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "statuses": table["status"].value_counts().to_dict()}))
""" % WORKERS


def overhead(cases: int, rounds: int = 3) -> dict:
    """Measured in a fresh process, as a user's sweep would run (a process with other threads
    starts its workers clean instead of forking, which costs their start-up)."""
    code = ("import json, sys; from impactgen.bench.sweep import measure_overhead; "
            "print(json.dumps(measure_overhead(int(sys.argv[1]), int(sys.argv[2]))))")
    res = subprocess.run([sys.executable, "-c", code, str(cases), str(rounds)], capture_output=True, text=True,
                         timeout=3600)
    if res.returncode != 0:
        raise RuntimeError(f"the overhead benchmark failed: {res.stderr.strip()[-500:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def _engine_only(raw: dict, values: list[float]) -> float:
    """Seconds a worker spends in `simulate` alone over these cases (scenes built first)."""
    import impactgen
    from ..scene import scene_from_dict
    scenes = [scene_from_dict(raw, {"initial.u[2]": w}) for w in values]
    impactgen.simulate(scenes[0])
    started = time.perf_counter()
    for scene in scenes:
        impactgen.simulate(scene, record_steps=False).summary
    return time.perf_counter() - started


def _ideal(cases: int) -> float:
    """N x the engine's time per impact / workers, measured as it would run: the workers each
    simulate their share of the cases, nothing else; the slower worker's time."""
    import numpy as np

    import impactgen
    from ..sweep.execute import _start_method
    raw = impactgen.load_scene("paper").to_dict()
    values = np.linspace(-0.5, -0.1, cases).tolist()
    shares = [values[k::WORKERS] for k in range(WORKERS)]
    from concurrent.futures import ProcessPoolExecutor
    with ProcessPoolExecutor(WORKERS, mp_context=_start_method()) as pool:
        return max(pool.map(_engine_only, [raw] * WORKERS, shares))


def measure_overhead(cases: int, rounds: int = 3) -> dict:
    """The sweep against the engine alone on the same workers, alternated `rounds` times.
    This machine's speed moves by tens of percent from one minute to the next, so each sweep
    is compared with the engine-alone run just before it; the ratio is the median of the
    rounds' ratios (the medians of each are reported beside it)."""
    import impactgen
    impactgen.simulate(impactgen.load_scene("paper"))  # the model loaded before any fork
    # a warm process, as the engine is timed in one: what a sweep imports (pandas, pyarrow) once
    impactgen.sweep("paper", vary={"initial.u[2]": "linspace(-0.5,-0.1,20)"}, workers=WORKERS)
    ideals, walls, outside, ok = [], [], [], 0
    for _ in range(rounds):
        ideals.append(_ideal(cases))
        started = time.perf_counter()
        table = impactgen.sweep("paper", vary={"initial.u[2]": f"linspace(-0.5,-0.1,{cases})"}, workers=WORKERS)
        walls.append(time.perf_counter() - started)
        outside.append(walls[-1] - float(table["wall_s"].sum()) / WORKERS)
        ok = int((table["status"] == "ok").sum())
    ideal, wall = statistics.median(ideals), statistics.median(walls)
    ratios = [w / i for w, i in zip(walls, ideals)]
    return {"cases": cases, "workers": WORKERS, "rounds": rounds, "wall_s": wall, "walls_s": walls,
            "ideal_s": ideal, "ideals_s": ideals, "engine_ms": ideal * WORKERS / cases * 1e3,
            "ratios": ratios, "ratio": statistics.median(ratios), "ok": ok, "outside_cases_s": outside}


def _drive(cases: int, scheduler: str | None) -> dict:
    args = json.dumps([MONTE_CARLO, cases, MONTE_CARLO_SEED, scheduler])
    res = subprocess.run([sys.executable, "-c", _DRIVER, args], capture_output=True, text=True, timeout=3600)
    if res.returncode != 0:
        return {"error": res.stderr.strip().splitlines()[-1] if res.stderr.strip() else f"exit {res.returncode}"}
    return json.loads(res.stdout.strip().splitlines()[-1])


def monte_carlo(cases: int) -> dict:
    """The Monte Carlo on the local pool, then on a separately started Dask cluster."""
    pool = _drive(cases, None)
    cluster = _on_dask_cluster(cases)
    return {"cases": cases, "pool": pool, "dask": cluster}


def _on_dask_cluster(cases: int) -> dict:
    try:
        import distributed  # noqa: F401
    except ImportError:
        return {"error": "dask distributed is not installed (pip install 'impactgen[sweep]')"}
    with tempfile.TemporaryDirectory(prefix="impactgen-dask-") as tmp:
        address_file = Path(tmp) / "scheduler.json"
        log = open(Path(tmp) / "cluster.log", "w")
        start = dict(stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        processes = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host",
                                       "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file",
                                       str(address_file)], **start)]
        try:
            for _ in range(600):
                if address_file.exists() and address_file.stat().st_size:
                    break
                time.sleep(0.1)
            address = json.loads(address_file.read_text())["address"]
            worker = [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(address_file),
                      "--nthreads", "1", "--no-dashboard"]
            processes += [subprocess.Popen(worker, **start) for _ in range(WORKERS)]
            from distributed import Client
            with Client(address, timeout="30s") as client:
                client.wait_for_workers(WORKERS, timeout=120)
            result = _drive(cases, address)
            result["address"] = address
            return result
        finally:
            for process in processes:
                try:
                    os.killpg(process.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
            for process in processes:
                process.wait(timeout=60)
            log.close()


def sweep_benchmark(quick: bool) -> dict:
    # 20000 cases: the fixed costs (imports, starting the pool) need a sweep this size to amortize
    return {"overhead": overhead(20000, rounds=3 if quick else 5),
            "monte_carlo": monte_carlo(10_000 if quick else 100_000)}


def sweep_targets(result: dict) -> list[dict]:
    rows = []
    o = result.get("overhead")
    if o:
        rows.append({"target": f"summary-only sweep, {o['workers']} workers: wall <= {OVERHEAD_TARGET} x "
                               "(N x engine time per impact / workers)",
                     "measured": f"{o['ratio']:.2f}x ({o['cases']} cases, {o['wall_s']:.1f} s)",
                     "verdict": verdict(o["ratio"], o["ratio"] <= OVERHEAD_TARGET)})
    mc = result.get("monte_carlo")
    if mc:
        for where, key in (("local pool", "pool"), ("Dask cluster (scheduler + 2 workers)", "dask")):
            run = mc.get(key, {})
            done = "error" not in run and run.get("cases") == mc["cases"]
            measured = (f"{run['wall_s']:.0f} s, {run['impacts'] / run['wall_s']:.0f} impacts/s"
                        if done else run.get("error", "not run"))
            rows.append({"target": f"{mc['cases']}-case Monte Carlo of the paper's scene finishes ({where})",
                         "measured": measured, "verdict": "met" if done else "missed"})
    return rows


def sweep_report_lines(result: dict) -> list[str]:
    lines = ["", "## Sweeps", ""]
    o = result.get("overhead")
    if o:
        lines += [f"Summary-only sweep of the paper's scene, omega20 over {o['cases']} values, {o['workers']} "
                  f"workers, alternated {o['rounds']} times with the engine alone on the same workers: "
                  f"sweep {', '.join(f'{w:.2f}' for w in o['walls_s'])} s, engine alone "
                  f"{', '.join(f'{w:.2f}' for w in o['ideals_s'])} s ({o['engine_ms']:.3f} ms per impact). "
                  f"Each round's ratio: {', '.join(f'{r:.2f}' for r in o.get('ratios', []))}; their median "
                  f"{o['ratio']:.2f} (the medians of each: {o['wall_s']:.2f} s against {o['ideal_s']:.2f} s).", ""]
        if "outside_cases_s" in o:
            lines += ["Of each sweep's wall time, the part outside its cases (the wall time less the cases' "
                      f"own times, `wall_s`, shared over the {o['workers']} workers: the start before the "
                      "first chunk, the pauses between chunks, the end after the last, uneven finishing): "
                      f"{', '.join(f'{w:.3f}' for w in o['outside_cases_s'])} s. The rest, the cases "
                      "themselves, is what varies with this host's speed from round to round.", ""]
    mc = result.get("monte_carlo")
    if mc:
        lines += [f"Monte Carlo, {mc['cases']} cases, seed {MONTE_CARLO_SEED}, inputs drawn as:", ""]
        lines += [f"- `{k}`: `{v}`" for k, v in MONTE_CARLO.items()]
        lines += ["", "| where | wall (s) | cases ok | impacts | impacts/s | driver peak RSS (MiB) |",
                  "|---|---|---|---|---|---|"]
        for where, key in (("local pool, 2 workers", "pool"), ("Dask: dask scheduler + 2 dask worker", "dask")):
            run = mc.get(key, {})
            if "error" in run or not run:
                lines.append(f"| {where} | {run.get('error', 'not run')} | | | | |")
            else:
                lines.append(f"| {where} | {run['wall_s']:.1f} | {run['ok']} | {run['impacts']} | "
                             f"{run['impacts'] / run['wall_s']:.0f} | {run['peak_rss_mib']:.0f} |")
    return lines
