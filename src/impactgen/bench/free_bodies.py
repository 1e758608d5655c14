"""A free body's impact: the rod-drop example's first impact (its lower end striking the plate),
timed in the C engine and in the reference engine on the same scene, summary only, in turn
(issue 46's target: at least 200 times faster than the reference engine)."""
from __future__ import annotations

import statistics

from . import seconds_per_run

TARGET_RATIO = 200.0  # the C engine against the reference engine, per impact
ROUNDS = {"quick": 3, "full": 7}  # alternating rounds: C then the reference engine, each timed
C_REPEATS = 50  # C runs per round (one takes well under a millisecond)


def first_impact():
    """rod-drop up to the end of its first impact, as a scene."""
    import impactgen
    return impactgen.load_scene("rod-drop", {"solver.t_end": "separation"})


def benchmark(quick: bool) -> dict:
    """Median over alternating rounds of the time of the first impact in each engine, after one
    run of each outside the timing (the model built, the modules imported)."""
    import impactgen
    scene = first_impact()
    c = impactgen.simulate(scene, record_steps=False, warn=False)
    ref = impactgen.simulate(scene, engine="reference", warn=False)
    c_s, ref_s = [], []
    for _ in range(ROUNDS["quick" if quick else "full"]):
        c_s.append(seconds_per_run(lambda: impactgen.simulate(scene, record_steps=False, warn=False), C_REPEATS))
        ref_s.append(seconds_per_run(lambda: impactgen.simulate(scene, engine="reference", warn=False), 1))
    return {"scene": "rod-drop", "status": c.status, "reference_status": ref.status,
            "point": c.impacts[0].point if c.impacts else None,
            # the impact's own record: the summary's fields are the tip's impacts, and the base strikes first
            "delta_max": c.impacts[0].delta_max if c.impacts else None,
            "reference_delta_max": ref.impacts[0].delta_max if ref.impacts else None,
            "c_s": statistics.median(c_s), "reference_s": statistics.median(ref_s),
            "c_rounds_s": c_s, "reference_rounds_s": ref_s, "rtol": scene.solver.rtol}


def targets(result: dict) -> list[dict]:
    if not result:
        return []
    ratio = result["reference_s"] / result["c_s"]
    ok = result["status"] == "ok" and result["reference_status"] == "ok"
    return [{"target": f"a free rod's impact (rod-drop's first, at its {result['point']}): at least "
                       f"{TARGET_RATIO:.0f}x faster than the reference engine, summary only",
             "measured": (f"{ratio:.0f}x ({result['c_s'] * 1e3:.3f} ms against {result['reference_s'] * 1e3:.0f} ms, "
                          f"medians of {len(result['c_rounds_s'])} alternating rounds)"),
             "verdict": ("met" if ratio >= TARGET_RATIO else "missed") if ok else
             f"failed: {result['status']} / {result['reference_status']}"}]


def report_lines(result: dict) -> list[str]:
    if not result:
        return []
    return ["", "## A free body's impact", "",
            f"The rod-drop example (a free steel rod, 0.5 m, 10 mm diameter, dropped at 30 degrees from "
            f"5 cm) up to the end of its first impact, at its {result['point']} "
            f"(`impactgen.bench.free_bodies.first_impact()`, rtol {result['rtol']:g}), summary only, "
            f"the two engines timed in turn: C {result['c_s'] * 1e3:.3f} ms, the reference engine "
            f"{result['reference_s'] * 1e3:.0f} ms; delta_max {result['delta_max']:.6e} m against "
            f"{result['reference_delta_max']:.6e} m."]
