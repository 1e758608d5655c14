"""Contact at every joint: a chain dropped onto the surface, timed in the C engine and in the
reference engine on the same scene (issue 38's target: the time, and the impacts per second)."""
from __future__ import annotations

import time

LINKS = 8
# The chain of eight 0.2 m steel bars, level with its pivot and released at rest, 15 cm above
# the surface: every joint can reach it (the first is 0.2 m from the pivot).
DROPPED = {"chain.links": LINKS, "chain.length": 0.2, "chain.mass": 0.2, "initial.q_deg": [0.0] * LINKS,
           "initial.u": [0.0] * LINKS, "surface.height": -0.15, "solver.t_end": 1.0}
REFERENCE_SPAN = {"quick": 0.21, "full": 0.3}  # s of the same motion the reference engine runs
ROUNDS = {"quick": 2, "full": 3}
METHODS = ("auto", "bdf")  # the falling-chain example under the default method and BDF (analytic Jacobian)


def dropped_chain():
    """The dropped 8-link chain of the bench, as a scene."""
    import impactgen
    return impactgen.load_scene("falling-chain", DROPPED)


def _best(run, rounds: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(rounds):
        started = time.perf_counter()
        result = run()
        best = min(best, time.perf_counter() - started)
    return best, result


def points_benchmark(quick: bool) -> dict:
    """The dropped chain for 1 s in the C engine (summary only, best of the rounds, after one
    run that builds the model), and over its first REFERENCE_SPAN s in both engines, with the
    impacts of each point."""
    import impactgen
    mode = "quick" if quick else "full"
    scene = dropped_chain()
    impactgen.simulate(scene.replace({"solver.t_end": 1e-3}))  # build, outside the timing
    wall, result = _best(lambda: impactgen.simulate(scene, record_steps=False), ROUNDS[mode])
    # both engines simulate every impact over the span (no sustained contact)
    span = scene.replace({"solver.t_end": REFERENCE_SPAN[mode], "solver.sustained_contact": False})
    c_span, c_short = _best(lambda: impactgen.simulate(span), ROUNDS[mode])
    ref_span, ref_short = _best(lambda: impactgen.simulate(span, engine="reference"), 1)
    summary = result.summary
    example = impactgen.load_scene("falling-chain")
    methods = {}
    for method in METHODS:  # the shipped example, every point with the analytic Jacobian
        impactgen.simulate(example, method=method, record_steps=False)  # build, outside the timing
        seconds, run = _best(lambda: impactgen.simulate(example, method=method, record_steps=False), ROUNDS[mode])
        methods[method] = {"wall_s": seconds, "status": run.status, "impacts": len(run.impacts),
                           "nsteps": run.stats.get("nsteps"), "njev": run.stats.get("njev"),
                           "nfev": run.stats.get("nfev")}
    return {
        "links": LINKS, "t_end": scene.solver.t_end, "status": result.status, "wall_s": wall,
        "impacts": summary["impacts"], "joint_impacts": summary["impacts"] - summary["point_impacts"]["tip"],
        "residual_J": summary["energy"]["residual"],
        "span_s": REFERENCE_SPAN[mode], "c_span_s": c_span, "reference_span_s": ref_span,
        "c_span_impacts": len(c_short.impacts), "reference_span_impacts": len(ref_short.impacts),
        "reference_status": ref_short.status, "falling_chain": methods,
    }


def points_targets(result: dict) -> list[dict]:
    if not result:
        return []
    ok = result["status"] == "ok"
    ratio = result["reference_span_s"] / result["c_span_s"]
    return [{"target": f"contact at every joint: an {result['links']}-link chain dropped onto the surface, "
                       f"{result['t_end']:g} s of motion (reported)",
             "measured": (f"{result['wall_s']:.2f} s, {result['impacts']} impacts ({result['joint_impacts']} at "
                          f"the joints), {result['impacts'] / result['wall_s']:.0f} impacts/s; its first "
                          f"{result['span_s']:g} s {ratio:.0f}x faster than the reference engine "
                          f"({result['c_span_s']:.3f} s against {result['reference_span_s']:.1f} s)"),
             "verdict": "reported" if ok else f"failed: {result['status']}"}] + [
        {"target": f"the falling-chain example (6 links, 1 s) with method {method!r} (reported; A/B in the closing "
                   f"note of issue 44)",
         "measured": (f"{run['wall_s']:.3f} s, {run['impacts']} impacts, {run['nsteps']} steps, {run['njev']} "
                      f"Jacobians, {run['nfev']} right-hand sides"),
         "verdict": "reported" if run["status"] == "ok" else f"failed: {run['status']}"}
        for method, run in result.get("falling_chain", {}).items()]


def points_report_lines(result: dict) -> list[str]:
    if not result:
        return []
    return ["", "## Contact at every joint", "",
            f"An {result['links']}-link chain of 0.2 m steel bars, level with its pivot and released at rest "
            f"15 cm above the surface (`impactgen.bench.points.dropped_chain()`): every joint can reach the "
            f"surface. Over {result['t_end']:g} s the C engine (summary only, best of its rounds) takes "
            f"{result['wall_s']:.2f} s for {result['impacts']} impacts, {result['joint_impacts']} of them at the "
            f"joints ({result['impacts'] / result['wall_s']:.0f} impacts per second of run time), and closes the "
            f"energy budget to {result['residual_J']:.1e} J. Over the first {result['span_s']:g} s, in both "
            f"engines with the trajectory recorded and every impact simulated (no sustained contact): C {result['c_span_s']:.3f} s ({result['c_span_impacts']} "
            f"impacts), the reference engine {result['reference_span_s']:.1f} s "
            f"({result['reference_span_impacts']} impacts, status {result['reference_status']})."]
