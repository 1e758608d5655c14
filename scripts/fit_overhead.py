"""The fit's own overhead (issue #47's target): the wall time of a two-parameter fit to the 20
measured impacts of examples/fit/paper-impacts.csv, against the number of impacts it simulates
times the API's time per impact.

    .venv/bin/python scripts/fit_overhead.py [--repeats 5]

The API's time per impact (summary only, no samples) is taken four ways: `impactgen.run_batch`
inside the fit (its time in run_batch over the impacts it simulated, the calls as the fit makes
them: the rows at a point, or at every parameter's step); one run_batch call of the fit's 20
rows at the fitted values; one run_batch call of 2000 rows (the 20 repeated), the batch's
throughput; and `impactgen.simulate(scene, record_steps=False)` of each of the 20 rows. Each
figure is the median of --repeats runs, after one warm-up run (the model built, the modules
imported). The machine's other load moves the last three against the fit's wall time; the
first is measured within the same runs.
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import pandas as pd

import impactgen

DATA = Path(__file__).resolve().parent.parent / "examples" / "fit" / "paper-impacts.csv"
FIT = "rod.yield_strength=3e8..1.1e9,contact.friction=0..1"


def _median_time(run, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        run()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    repeats = parser.parse_args().repeats
    scene = impactgen.load_scene("paper")
    result = impactgen.fit(scene, DATA, FIT)  # warm-up
    walls, inside, impacts = [], [], set()
    for _ in range(repeats):
        result = impactgen.fit(scene, DATA, FIT)
        walls.append(result.wall_s)
        inside.append(result.batch_s)
        impacts.add(result.impacts)
    wall, n = statistics.median(walls), impacts.pop()
    rows = pd.read_csv(DATA)[["initial.u[2]"]]
    for key, value in result.parameters.items():
        rows[key] = value["value"]
    many = pd.concat([rows] * 100, ignore_index=True)
    per_call = _median_time(lambda: impactgen.run_batch(scene, rows), repeats) / len(rows)
    per_batch = _median_time(lambda: impactgen.run_batch(scene, many), repeats) / len(many)
    scenes = [scene.replace(row) for row in rows.to_dict(orient="records")]
    per_simulate = _median_time(lambda: [impactgen.simulate(s, record_steps=False, warn=False) for s in scenes],
                                repeats) / len(scenes)
    print(f"fit of 2 parameters to {len(rows)} impacts: wall {wall * 1e3:.1f} ms, {n} impacts simulated "
          f"({result.best.evaluations} residual evaluations)")
    for name, per_impact in (("run_batch inside the fit", statistics.median(inside) / n),
                             ("run_batch of the 20 rows", per_call), ("run_batch of 2000 rows", per_batch),
                             ("simulate of each row", per_simulate)):
        ratio = wall / (n * per_impact)
        print(f"API time per impact, {name}: {per_impact * 1e3:.3f} ms; wall / (N x time per impact) = {ratio:.2f}")


if __name__ == "__main__":
    main()
