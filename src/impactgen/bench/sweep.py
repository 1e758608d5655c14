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
C_LOOP_TARGET = 1.15  # the sweep's time per case at most this times the C loop's per impact / workers
MILLION_WALL_GOAL_S = 30.0  # a million Monte Carlo cases on the local pool of two workers
MILLION_MEMORY_GOAL_MIB = 500.0  # the driver's peak resident memory over them
DASK_TARGET = 1.2  # the same on a LocalCluster of two workers, at most this times the pool's wall
BATCH_CASES = 20000  # cases of each sweep timed against the C loop
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
                  "cases_s": float(table["wall_s"].sum()),
                  "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "workers_peak_rss_mib": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
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


def against_c_loop(cases: int, rounds: int) -> dict:
    """The summary-only sweep against the pure-C loop (examples/c) over the same impact (the
    paper's, at the C loop's rtol): the sweep's wall time per case against the C loop's time
    per impact over the two workers, alternated `rounds` times in a fresh process."""
    code = ("import json, sys; from impactgen.bench.sweep import measure_against_c_loop; "
            "print(json.dumps(measure_against_c_loop(int(sys.argv[1]), int(sys.argv[2]))))")
    res = subprocess.run([sys.executable, "-c", code, str(cases), str(rounds)], capture_output=True, text=True,
                         timeout=3600)
    if res.returncode != 0:
        return {"error": res.stderr.strip()[-500:] or f"exit {res.returncode}"}
    return json.loads(res.stdout.strip().splitlines()[-1])


def measure_against_c_loop(cases: int, rounds: int) -> dict:
    """In turn, `rounds` times: the C loop (C_REPEATS runs of the paper's impact in one
    process), then a sweep of `cases` copies of the same impact on two workers. Each round's
    ratio is the sweep's time per case over the C loop's per impact / workers; their median."""
    import impactgen

    from .cloop import RTOL, _build, _c_ms
    scene = impactgen.load_scene("paper").replace({"solver.rtol": RTOL})
    vary = {"initial.u[2]": f"linspace({scene.u0[1]!r},{scene.u0[1]!r},{cases})"}  # the scene's own impact
    impactgen.sweep(scene, vary={"initial.u[2]": "linspace(-0.5,-0.1,20)"}, workers=WORKERS)  # warm
    with tempfile.TemporaryDirectory(prefix="impactgen-cloop-") as folder:
        driver = _build(scene, Path(folder))
        c_ms, walls, ok = [], [], 0
        for _ in range(rounds):
            c_ms.append(_c_ms(driver))
            started = time.perf_counter()
            table = impactgen.sweep(scene, vary=vary, workers=WORKERS)
            walls.append(time.perf_counter() - started)
            ok = int((table["status"] == "ok").sum())
    ratios = [(w / cases) / (c / 1e3 / WORKERS) for w, c in zip(walls, c_ms)]
    return {"cases": cases, "workers": WORKERS, "rounds": rounds, "rtol": RTOL, "c_ms": c_ms, "walls_s": walls,
            "sweep_ms_per_case": [w / cases * 1e3 for w in walls], "ratios": ratios,
            "ratio": statistics.median(ratios), "ok": ok}


def million(cases: int, rounds: int) -> dict:
    """The Monte Carlo on the local pool of two workers and on a Dask LocalCluster of two,
    alternated `rounds` times, each in its own driver process (wall time, peak memory)."""
    pool, dask = [], []
    for _ in range(rounds):
        pool.append(_drive(cases, None))
        dask.append(_drive(cases, "local"))
    return {"cases": cases, "rounds": rounds, "pool": pool, "dask": dask}


def batch_benchmark(quick: bool) -> dict:
    """What the batch entry is judged by (bench part "batch"): the sweep against the C loop,
    and a million Monte Carlo cases (100 000 with --quick) on the pool and on Dask."""
    return {"c_loop": against_c_loop(BATCH_CASES, 3),
            "million": million(100_000 if quick else 1_000_000, 1)}


def sweep_benchmark(quick: bool) -> dict:
    # 20000 cases: the fixed costs (imports, starting the pool) need a sweep this size to amortize
    return {"overhead": overhead(20000, rounds=3 if quick else 5),
            "monte_carlo": monte_carlo(10_000 if quick else 100_000)}


def sweep_targets(result: dict) -> list[dict]:
    rows = batch_targets(result["batch"]) if result.get("batch") else []
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


def batch_targets(result: dict) -> list[dict]:
    rows = []
    c = result.get("c_loop")
    if c and "error" not in c:
        rows.append({"target": f"summary-only sweep, {c['workers']} workers: time per case <= {C_LOOP_TARGET} x "
                               "(pure-C loop's time per impact / workers)",
                     "measured": f"{c['ratio']:.2f}x ({c['cases']} cases, median of {c['rounds']} rounds)",
                     "verdict": verdict(c["ratio"], c["ratio"] <= C_LOOP_TARGET)})
    elif c:
        rows.append({"target": "sweep against the C loop", "measured": c["error"][-200:], "verdict": "missed"})
    m = result.get("million")
    if m:
        pool = [r for r in m["pool"] if "error" not in r]
        dask = [r for r in m["dask"] if "error" not in r]
        if pool:
            wall = statistics.median(r["wall_s"] for r in pool)
            memory = max(r["peak_rss_mib"] for r in pool)
            rows.append({"target": f"{m['cases']} Monte Carlo cases, local pool of {WORKERS}: wall < "
                                   f"{MILLION_WALL_GOAL_S:g} s", "measured": f"{wall:.1f} s",
                         "verdict": verdict(wall, wall < MILLION_WALL_GOAL_S)})
            rows.append({"target": f"the same: driver's peak memory < {MILLION_MEMORY_GOAL_MIB:g} MB",
                         "measured": f"{memory:.0f} MiB", "verdict": verdict(memory, memory < MILLION_MEMORY_GOAL_MIB)})
            if dask:
                ratio = statistics.median(r["wall_s"] for r in dask) / wall
                rows.append({"target": f"the same on a Dask LocalCluster of {WORKERS}: wall <= {DASK_TARGET} x the "
                                       "pool's", "measured": f"{ratio:.2f}x",
                             "verdict": verdict(ratio, ratio <= DASK_TARGET)})
        for where, runs in (("pool", m["pool"]), ("Dask", m["dask"])):
            for r in runs:
                if "error" in r:
                    rows.append({"target": f"Monte Carlo on the {where}", "measured": r["error"][-200:],
                                 "verdict": "missed"})
    return rows


def batch_report_lines(result: dict) -> list[str]:
    lines = ["", "## Batches: the sweep against the C loop, a million cases", ""]
    c = result.get("c_loop")
    if c and "error" not in c:
        lines += [f"The paper's impact at rtol {c['rtol']:g}: the pure-C loop (examples/c) and a summary-only "
                  f"sweep of {c['cases']} copies of it on {c['workers']} workers, alternated {c['rounds']} times. "
                  f"C loop {', '.join(f'{x:.4f}' for x in c['c_ms'])} ms per impact; sweep "
                  f"{', '.join(f'{x:.4f}' for x in c['sweep_ms_per_case'])} ms per case (wall over cases). "
                  f"Each round's ratio (sweep per case over C per impact / {c['workers']}): "
                  f"{', '.join(f'{r:.2f}' for r in c['ratios'])}; median {c['ratio']:.2f}.", ""]
    m = result.get("million")
    if m:
        lines += [f"Monte Carlo, {m['cases']} cases of the inputs above, seed {MONTE_CARLO_SEED}, the pool and a "
                  "Dask LocalCluster in turn:", "",
                  "| where | wall (s) | cases' own time (s) | cases ok | driver peak RSS (MiB) | workers' peak RSS (MiB) |",
                  "|---|---|---|---|---|---|"]
        for where, runs in (("local pool, 2 workers", m["pool"]), ("Dask LocalCluster, 2 workers", m["dask"])):
            for r in runs:
                if "error" in r:
                    lines.append(f"| {where} | {r['error'][-120:]} | | | | |")
                else:
                    lines.append(f"| {where} | {r['wall_s']:.1f} | {r.get('cases_s', float('nan')):.1f} | {r['ok']} | "
                                 f"{r['peak_rss_mib']:.0f} | {r.get('workers_peak_rss_mib', float('nan')):.0f} |")
    return lines


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
    if result.get("batch"):
        lines += batch_report_lines(result["batch"])
    return lines
