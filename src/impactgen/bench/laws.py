"""The contact laws and the fit (issue 47's targets).

- Each law's impact against the paper's law on the same scene (the paper's double pendulum,
  its first impact, summary only): the laws timed in turn, round after round, so that the
  machine's load falls on all alike. Target: no law slower per impact than the paper's.
- A fit of two parameters to the 20 measured impacts of examples/fit/paper-impacts.csv: its
  wall time against the number of impacts it simulates times the API's time per impact
  (`run_batch` as the fit calls it, measured within the same fits). Target: at most 1.5.
"""
from __future__ import annotations

import statistics
from pathlib import Path

from . import seconds_per_run

# Each law's own keys, near the paper's impact (e_N = 0.64): the damped Hertz laws at that
# design coefficient; Kelvin-Voigt an underdamped impact of about a millisecond; Thornton a
# limiting pressure of 1.5 GPa (the paper's steel yields at 1.12 GPa).
LAW_SETTINGS = {"three-phase": {}, "hertz": {},
                **{law: {"contact.restitution": 0.64}
                   for law in ("hunt-crossley", "lankarani-nikravesh", "flores", "gonthier")},
                "kelvin-voigt": {"contact.stiffness": 2e7, "contact.damping": 800.0},
                "thornton": {"contact.limiting_pressure": 1.5e9}}
PAPER_LAW = "three-phase"
SLOWER_MARGIN = 1.05  # a law within 5 % of the paper's law is "no slower" (the rounds' noise)
FIT_TARGET = 1.5
FIT_DATA = Path(__file__).resolve().parents[3] / "examples" / "fit" / "paper-impacts.csv"
FIT_KEYS = "rod.yield_strength=3e8..1.1e9,contact.friction=0..1"
ROUNDS = {"quick": 3, "full": 7}
REPEATS = 100  # runs of one law per round


def law_scene(law: str):
    """The paper's scene under `law`, with the law's keys of LAW_SETTINGS."""
    import impactgen
    return impactgen.load_scene("paper", {"contact.model": law, **LAW_SETTINGS[law]})


def laws_in_turn(rounds: int) -> dict:
    """Each law's time per impact: the median over rounds, each round every law in turn."""
    import impactgen
    from ..scene import CONTACT_MODELS
    scenes = {law: law_scene(law) for law in CONTACT_MODELS}
    first = {law: impactgen.simulate(s, record_steps=False, warn=False) for law, s in scenes.items()}  # built
    seconds: dict[str, list[float]] = {law: [] for law in scenes}
    for _ in range(rounds):
        for law, s in scenes.items():
            seconds[law].append(seconds_per_run(lambda: impactgen.simulate(s, record_steps=False, warn=False), REPEATS))
    return {law: {"ms_per_impact": statistics.median(t) * 1e3, "rounds_ms": [x * 1e3 for x in t],
                  "status": first[law].status, "e_N": first[law].summary["coefficients"]["e_N"],
                  "t_contact": first[law].summary["t_contact"]} for law, t in seconds.items()}


def fit_overhead(rounds: int) -> dict:
    """The median fit's wall time, the impacts it simulated and its time inside run_batch."""
    import impactgen
    if not FIT_DATA.exists():  # the data ship with a checkout, not inside the package
        return {"error": f"{FIT_DATA} not found: run the bench from a checkout of impactgen"}
    scene = impactgen.load_scene("paper")
    impactgen.fit(scene, FIT_DATA, FIT_KEYS)  # built, imported
    fits = [impactgen.fit(scene, FIT_DATA, FIT_KEYS) for _ in range(rounds)]
    wall = statistics.median(f.wall_s for f in fits)
    inside = statistics.median(f.batch_s / f.impacts for f in fits)
    return {"rows": fits[0].measurements.rows, "wall_s": wall, "impacts": fits[0].impacts, "evaluations": fits[0].best.evaluations,
            "batch_s_per_impact": inside, "ratio": wall / (fits[0].impacts * inside)}


def benchmark(quick: bool) -> dict:
    rounds = ROUNDS["quick" if quick else "full"]
    return {"laws": laws_in_turn(rounds), "fit": fit_overhead(rounds)}


def targets(result: dict) -> list[dict]:
    if not result:
        return []
    laws = result["laws"]
    paper = laws[PAPER_LAW]["ms_per_impact"]
    rows = [{"target": f"the {law} law's impact on the paper's scene: no slower than the paper's law",
             "measured": f"{run['ms_per_impact']:.3f} ms against {paper:.3f} ms ({run['ms_per_impact'] / paper:.2f}x)",
             "verdict": ("met" if run["ms_per_impact"] <= SLOWER_MARGIN * paper else "missed")
             if run["status"] == "ok" else f"failed: {run['status']}"}
            for law, run in laws.items() if law != PAPER_LAW]
    fit = result["fit"]
    if "error" in fit:
        return rows + [{"target": "a fit's own overhead", "measured": fit["error"], "verdict": "not measured"}]
    rows.append({"target": f"a fit of two parameters to {fit['rows']} measured impacts: wall time at most {FIT_TARGET:g}x "
                           "its impacts times the API's time per impact",
                 "measured": (f"{fit['ratio']:.2f}x ({fit['wall_s'] * 1e3:.0f} ms for {fit['impacts']} impacts at "
                              f"{fit['batch_s_per_impact'] * 1e3:.3f} ms each in run_batch)"),
                 "verdict": "met" if fit["ratio"] <= FIT_TARGET else "missed"})
    return rows


def report_lines(result: dict) -> list[str]:
    if not result:
        return []
    laws = result["laws"]
    lines = ["", "## Contact laws and fitting", "",
             "The paper's double pendulum up to the end of its first impact under each law "
             "(`impactgen.bench.laws.law_scene(law)`: the law's keys in `LAW_SETTINGS`), summary only, "
             f"the laws timed in turn over {len(next(iter(laws.values()))['rounds_ms'])} rounds of {REPEATS} runs:", "",
             "| law | ms per impact | e_N | t_contact (s) |", "|---|---|---|---|"]
    lines += [f"| {law} | {run['ms_per_impact']:.3f} | {run['e_N']:.4f} | {run['t_contact']:.4g} |"
              for law, run in laws.items()]
    fit = result["fit"]
    if "error" in fit:
        return lines + ["", f"The fit was not measured: {fit['error']}."]
    lines += ["", f"`impactgen fit paper examples/fit/paper-impacts.csv --fit {FIT_KEYS}`: "
                  f"{fit['wall_s'] * 1e3:.0f} ms, {fit['evaluations']} evaluations of the residuals, "
                  f"{fit['impacts']} impacts simulated at {fit['batch_s_per_impact'] * 1e3:.3f} ms each inside "
                  f"run_batch: the fit's own overhead is {fit['ratio']:.2f} times the impacts' time."]
    return lines
