"""Work-precision: error against run time for every contender, tolerance by tolerance.

The error of a run is measured against a solution computed far more accurately: CVODE
BDF at rtol 1e-13 (atol 1e-15), checked against the independent reference engine (Radau)
at rtol 1e-12; their disagreement is reported beside the results. Time is the median wall
time of repeated runs in a warm process (models compiled, caches filled): at least
`repeats` of them, and a fast contender repeats until its runs add up to `min_time_s`, so
that a millisecond run's median rests on hundreds of runs rather than on five.
"""
from __future__ import annotations

import dataclasses
import math
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..scene import Scene, load_scene, steel_chain_scene
from .contenders import BudgetExceeded, Contender, available_contenders, with_tolerance

TRUTH_RTOL = 1e-13
MAX_REPEATS = 500
CHECK_RTOL = 1e-12
# The errors a work-precision figure plots, one panel each: the Run field and the quantity's name.
ERRORS = (("err_u_final", "u_final"), ("err_delta_r", "delta_r"), ("err_delta_T", "delta_T"))
# Each line of a figure has a colour and a marker of its own (the 20 colours of matplotlib's
# "tab20", the markers below), and its family a line style: impactgen's lines are solid,
# scipy's dashed, so that no two lines look alike.
MARKERS = ("o", "s", "^", "v", "D", "<", ">", "p", "h", "*", "X", "P", "d", "H", "8", "1", "2", "3", "4", "+", "x")
LEGEND_COLUMNS = 4  # the legend goes below the three panels, in this many columns
LEGEND_ROW = 0.045  # of the figure's height per legend row
FAMILY_LINES = {"impactgen": "-", "scipy + C": "--", "reference": ":", "scikit-sundae": "-.", "PyDy": "-."}


@dataclass(frozen=True)
class Settings:
    rtols: tuple[float, ...]
    repeats: int
    budget: int  # right-hand-side calls for the Python-driven contenders
    slow_s: float  # a run slower than this is not repeated, and ends the contender's sweep
    scenes: tuple[str, ...]
    min_time_s: float = 0.25  # a fast contender repeats until its runs add up to this (at most MAX_REPEATS)


QUICK = Settings(tuple(10.0 ** -k for k in range(3, 13)), 3, 200_000, 2.0, ("paper", "chain3"))
FULL = Settings(tuple(10.0 ** (-k / 2) for k in range(6, 25)), 5, 2_000_000, 20.0, ("paper", "chain3", "chain6"))


@dataclass
class Run:
    scene: str
    contender: str
    family: str
    rtol: float
    status: str  # "ok", "budget", "failed: ..."
    wall_s: float = math.nan
    err_u_final: float = math.nan
    err_delta_r: float = math.nan
    err_delta_T: float = math.nan
    nsteps: int = 0
    nfev: int = 0


@dataclass
class Truth:
    scene: str
    summary: dict
    check: dict  # relative disagreement of the reference engine with the truth
    wall_s: dict = field(default_factory=dict)


def bench_scenes(names: tuple[str, ...]) -> dict[str, Scene]:
    from importlib.resources import files
    from pathlib import Path
    paper = load_scene(Path(str(files("impactgen.scenes") / "paper.toml")))
    known = {"paper": paper, "chain3": steel_chain_scene(3), "chain6": steel_chain_scene(6)}
    return {name: known[name] for name in names}


def errors(summary: dict, truth: dict) -> tuple[float, float, float]:
    u, u_ref = np.array(summary["u_final"]), np.array(truth["u_final"])
    return (float(np.max(np.abs(u - u_ref)) / np.max(np.abs(u_ref))),
            abs(summary["delta_r"] - truth["delta_r"]) / abs(truth["delta_r"]),
            abs(summary["delta_T"] - truth["delta_T"]) / abs(truth["delta_T"]))


def compute_truth(name: str, scene: Scene) -> Truth:
    from ..engines import simulate
    started = time.perf_counter()
    accurate = scene.replace(solver=dataclasses.replace(scene.solver, rtol=TRUTH_RTOL, atol=1e-15))
    c = simulate(accurate, engine="c", warn=False).summary
    t_c = time.perf_counter() - started
    started = time.perf_counter()
    r = simulate(with_tolerance(scene, CHECK_RTOL), engine="reference", warn=False).summary
    t_r = time.perf_counter() - started
    e = errors(r, c)
    return Truth(name, c, {"u_final": e[0], "delta_r": e[1], "delta_T": e[2]},
                 {"cvode": t_c, "reference": t_r})


def measure(contender: Contender, name: str, scene: Scene, rtol: float, truth: Truth,
            settings: Settings) -> Run:
    run = Run(name, contender.name, contender.family, rtol, "ok")
    try:
        times, result = repeat_timed(contender, scene, rtol, settings)
    except BudgetExceeded:
        run.status = "budget"
        return run
    except Exception as exc:  # any contender may fail at some tolerance: record why
        run.status = f"failed: {type(exc).__name__}: {str(exc)[:120]}"
        return run
    if not result.success:
        run.status = f"failed: {result.message[:120]}"
        return run
    run.wall_s = statistics.median(times)
    run.err_u_final, run.err_delta_r, run.err_delta_T = errors(result.summary, truth.summary)
    run.nsteps, run.nfev = int(result.stats.get("nsteps", 0)), int(result.stats.get("nfev", 0))
    return run


def log_log_at(a: tuple[float, float], b: tuple[float, float], error: float) -> float:
    """The time at `error` on the straight line through (error, time) points a and b in
    log-log coordinates (a's time when both have the same error)."""
    (e1, t1), (e2, t2) = a, b
    w = (math.log(error) - math.log(e1)) / (math.log(e2) - math.log(e1)) if e2 > e1 else 0.0
    return math.exp(math.log(t1) + w * (math.log(t2) - math.log(t1)))


def repeat_timed(contender: Contender, scene: Scene, rtol: float, settings: Settings) -> tuple[list[float], object]:
    """Wall times of repeated runs (at least `repeats`, and until they add up to `min_time_s`;
    a run slower than `slow_s` is not repeated) and the last result; a failed run ends it."""
    times: list[float] = []
    given = contender.prepare(scene, rtol, settings.budget)
    while len(times) < settings.repeats or (sum(times) < settings.min_time_s and len(times) < MAX_REPEATS):
        started = time.perf_counter()
        result = contender.run(given, rtol, settings.budget)
        times.append(time.perf_counter() - started)
        if not result.success or times[-1] > settings.slow_s:
            break
    return times, result


def progress_bar(done: int, total: int, text: str) -> None:
    width = 30
    filled = int(width * done / max(total, 1))
    end = "\r" if sys.stderr.isatty() else "\n"
    print(f"[{'#' * filled}{'.' * (width - filled)}] {done}/{total} {text}"[:110].ljust(110),
          end=end, file=sys.stderr, flush=True)


def run_workprecision(settings: Settings) -> tuple[list[Run], list[Truth], list[str]]:
    contenders, notes = available_contenders()
    scenes = bench_scenes(settings.scenes)
    truths, runs = [], []
    total = len(scenes) * len(contenders) * len(settings.rtols)
    done = 0
    for name, scene in scenes.items():
        progress_bar(done, total, f"{name}: reference solution")
        truth = compute_truth(name, scene)
        truths.append(truth)
        for contender in contenders:
            contender.run(contender.prepare(scene, settings.rtols[0], settings.budget), settings.rtols[0],
                          settings.budget)  # warm: build, import, JIT
            stopped = False
            for rtol in settings.rtols:
                done += 1
                progress_bar(done, total, f"{name}: {contender.name} rtol {rtol:.0e}")
                if stopped:
                    continue
                run = measure(contender, name, scene, rtol, truth, settings)
                runs.append(run)
                if run.status != "ok" or run.wall_s > settings.slow_s:
                    stopped = True  # tighter tolerances would only cost more
    print(file=sys.stderr)
    return runs, truths, notes


def bracketing(runs: list[Run], error: float, key: str = "err_u_final") -> list[Run]:
    """The ok runs to read the time for `error` from: the two whose errors bracket it, the
    fastest when even the loosest run is that accurate, none when no run reaches it."""
    ok = sorted((r for r in runs if r.status == "ok" and getattr(r, key) > 0), key=lambda r: getattr(r, key))
    for a, b in zip(ok, ok[1:]):
        if getattr(a, key) <= error <= getattr(b, key):
            return [a, b]
    if ok and error >= getattr(ok[-1], key):
        return [min(ok, key=lambda r: r.wall_s)]
    return []


def time_at_error(runs: list[Run], error: float, key: str = "err_u_final") -> tuple[float, str]:
    """Wall time a contender needs for `error`, by log-log interpolation between its runs;
    ('', 'not reached') when its most accurate run is less accurate."""
    if not any(r.status == "ok" and getattr(r, key) > 0 for r in runs):
        return math.nan, "no run"
    pair = bracketing(runs, error, key)
    if len(pair) == 2:
        a, b = pair
        return log_log_at((getattr(a, key), a.wall_s), (getattr(b, key), b.wall_s), error), "interpolated"
    if pair:
        return pair[0].wall_s, "its loosest run is already this accurate"
    return math.nan, "not reached"


def line_styles(runs: list[Run]) -> dict[str, dict[str, str]]:
    """Each contender's line style (colour, marker, line style by its family), the same in
    every figure of a benchmark and different for every contender (colours from "tab20",
    and evenly spaced hues beyond 20 contenders)."""
    from matplotlib import colormaps
    families = dict((r.contender, r.family) for r in runs)
    count = len(families)
    palette = colormaps["tab20"] if count <= 20 else colormaps["hsv"]
    styles = {}
    for i, (name, family) in enumerate(families.items()):
        # tab20 in pairs of a strong and a light shade: the strong ones first
        colour = palette((2 * i) % 20 + (2 * i) // 20) if count <= 20 else palette(i / count)
        styles[name] = {"color": colour, "marker": MARKERS[i % len(MARKERS)],
                        "linestyle": FAMILY_LINES.get(family, "-")}
    return styles


def plot_workprecision(runs: list[Run], scene: str, out: Path) -> Path:
    """The work-precision figure of `scene`: wall time against the relative error of each of
    ERRORS, one line per contender (`line_styles`), written as out/workprecision_<scene>.png."""
    from ..plots import _pyplot
    plt = _pyplot()
    styles = line_styles(runs)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    names = list(dict.fromkeys(r.contender for r in runs if r.scene == scene))
    for ax, (key, label) in zip(axes, ERRORS):
        for name in names:
            pts = [(getattr(r, key), r.wall_s) for r in runs
                   if r.scene == scene and r.contender == name and r.status == "ok" and getattr(r, key) > 0]
            if pts:
                e, t = zip(*pts)
                ax.loglog(e, [x * 1e3 for x in t], ms=5, lw=1.2, label=name, **styles[name])
        ax.set_xlabel(f"relative error of {label} (1)")
        ax.set_ylabel("wall time (ms)")
        ax.grid(alpha=0.3, which="both")
        ax.invert_xaxis()
    handles, labels = axes[0].get_legend_handles_labels()
    rows = -(-len(labels) // LEGEND_COLUMNS)
    fig.legend(handles, labels, loc="lower center", ncol=LEGEND_COLUMNS, fontsize=8)  # below: no line hidden
    fig.suptitle(f"work-precision: {scene}")
    fig.tight_layout(rect=(0, LEGEND_ROW * rows, 1, 1))
    path = out / f"workprecision_{scene}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
