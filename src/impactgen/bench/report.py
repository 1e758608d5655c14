"""Write the benchmark's raw data (CSV, JSON), its figures (PNG) and a markdown report."""
from __future__ import annotations

import csv
import json
import math
import os
import platform
import subprocess
from dataclasses import asdict
from pathlib import Path

from .points import points_report_lines, points_targets
from .sweep import sweep_report_lines, sweep_targets
from .verdict import verdict
from .workprecision import Run, Truth, plot_workprecision, time_at_error

TARGET_RTOL = 1e-8


def machine() -> dict:
    import numpy
    import scipy
    import sympy
    from ..sundials import find_sundials
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        cc = subprocess.run(["cc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    except (OSError, IndexError):
        cc = "unknown"
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30 if hasattr(os, "sysconf") else math.nan
    return {"cpu": cpu, "cores": os.cpu_count(), "memory_gib": round(mem, 1), "os": platform.platform(),
            "python": platform.python_version(), "numpy": numpy.__version__, "scipy": scipy.__version__,
            "sympy": sympy.__version__, "sundials": find_sundials().version, "compiler": cc}


def _write_csv(path: Path, rows: list[dict]) -> None:
    if not rows:
        return
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _plot_lines(rows: list[dict], x: str, series: dict[str, str], ylabel: str, title: str, path: Path) -> Path:
    from ..plots import _pyplot
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for key, label in series.items():
        ax.semilogy([r[x] for r in rows], [r[key] for r in rows], marker="o", label=label)
    ax.set_xlabel(x)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def speedups(runs: list[Run], scene: str) -> list[dict]:
    """At the error CVODE BDF reaches with rtol 1e-8: how long every contender needs for it."""
    base = [r for r in runs if r.scene == scene and r.contender == "CVODE BDF (impactgen C)" and r.status == "ok"]
    if not base:
        return []
    target = min(base, key=lambda r: abs(math.log10(r.rtol) - math.log10(TARGET_RTOL)))
    rows = []
    for name in dict.fromkeys(r.contender for r in runs if r.scene == scene):
        mine = [r for r in runs if r.scene == scene and r.contender == name]
        t, how = time_at_error(mine, target.err_u_final)
        rows.append({"contender": name, "time_ms": t * 1e3, "how": how,
                     "slower_than_cvode_bdf": t / target.wall_s if t == t else math.nan})
    return [{"target_error": target.err_u_final, "cvode_bdf_ms": target.wall_s * 1e3}] + rows


DEFAULT = "auto, DOPRI5 then BDF (impactgen C)"  # the default method: the contender of the targets
SUMMARY_ONLY = "auto, DOPRI5 then BDF (impactgen C, summary only)"  # ... of target (a)
OPTION_TARGET = 1.1  # simulate(scene, rtol=...) at most this times the scene with the rtol inside it


def target_contenders(runs: list[Run]) -> tuple[float, list[str]] | None:
    """The error the targets compare at (CVODE BDF's at rtol 1e-8 on the paper) and the
    contenders they compare: the default with and without its steps, the fastest scipy
    method with the C right-hand side, and the reference engine's Radau and fastest method."""
    head = speedups(runs, "paper")
    if not head:
        return None
    by_name = {r["contender"]: r["time_ms"] for r in head[1:] if r["time_ms"] == r["time_ms"]}
    picked = [DEFAULT, SUMMARY_ONLY]
    for family in ("scipy", "reference"):
        names = [name for name in by_name if name.startswith(family)]
        if names:
            picked.append(min(names, key=by_name.get))
    picked += [name for name in by_name if name.startswith("reference (Radau")]
    return head[0]["target_error"], list(dict.fromkeys(picked))


def targets(runs: list[Run], rhs_rows: list[dict], scaling_rows: list[dict], c_loop: dict | None = None,
            in_turn: dict | None = None) -> list[dict]:
    """The issues' speed and accuracy targets against what this run measured: the ratios
    from the target contenders timed in turn (`in_turn`), else from the sweep's own times."""
    rows = []
    head = speedups(runs, "paper")
    c_loop = c_loop or {}
    if head:
        by_name = {r["contender"]: r["time_ms"] for r in head[1:]}
        how = "the sweep's times"
        if in_turn and in_turn.get("ms"):
            by_name = dict(in_turn["ms"])  # only the contenders timed side by side
            how = f"timed in turn, {in_turn['rounds']} rounds"
        mine = by_name.get(DEFAULT, math.nan)
        refs = [t for name, t in by_name.items() if name.startswith("reference") and t == t]
        ref = next((t for name, t in by_name.items() if name.startswith("reference (Radau")), math.nan)
        fastest_ref = min(refs, default=math.nan)
        scipy = min((t for name, t in by_name.items() if name.startswith("scipy") and t == t), default=math.nan)
        rows.append({"target": "paper impact, rtol 1e-8: >= 100x faster than the reference engine at the same error",
                     "measured": f"{ref / mine:.0f}x ({how})", "verdict": verdict(ref / mine, ref / mine >= 100)})
        rows.append({"target": "... and >= 10x faster than the best scipy method with the C right-hand side",
                     "measured": f"{scipy / mine:.1f}x ({how})", "verdict": verdict(scipy / mine, scipy / mine >= 10)})
        best_name, best = min(((name, t) for name, t in by_name.items()
                               if name.endswith("(impactgen C)") and t == t), key=lambda item: item[1],
                              default=("", mine))
        best_text = f"; best impactgen method {best_name.split(' (')[0]}: {scipy / best:.1f}x" if best < mine else ""
        rows.append({"target": "speed 1: paper impact, rtol 1e-8, Python API, trajectory recorded: >= 100x faster "
                               "than the best scipy method with the same C right-hand side, at the same error",
                     "measured": f"{scipy / mine:.1f}x (default auto {mine:.3f} ms, scipy {scipy:.2f} ms{best_text}; {how})",
                     "verdict": verdict(scipy / mine, scipy / mine >= 100)})
        lean = by_name.get(SUMMARY_ONLY, math.nan)
        best_lean_name, best_lean = min(((name, t) for name, t in by_name.items()
                                         if name.endswith("summary only)") and t == t), key=lambda item: item[1],
                                        default=("", lean))
        lean_text = (f"; best impactgen method {best_lean_name.split(' (')[0]}: {fastest_ref / best_lean:.0f}x"
                     if best_lean < lean else "")
        rows.append({"target": "(a) the paper's impact, Python API, summary only: >= 250x faster than the reference "
                               "engine's fastest method (numpy/scipy: Radau, LSODA) at the error of rtol 1e-8",
                     "measured": f"{fastest_ref / lean:.0f}x (default auto, summary only: {lean:.3f} ms per impact, "
                                 f"reference {fastest_ref:.2f} ms{lean_text}; {how})",
                     "verdict": verdict(fastest_ref / lean, fastest_ref / lean >= 250)})
    if "option_ratio" in c_loop:
        ratio = c_loop["option_ratio"]
        rows.append({"target": f"(b) simulate(scene, rtol=1e-8) within {OPTION_TARGET}x of the same scene with "
                               "rtol 1e-8 inside it (the paper, summary only)",
                     "measured": f"{ratio:.3f}x (the median of {len(c_loop['option_ratios'])} rounds' ratios; "
                                 f"medians {c_loop['option_ms']:.4f} / {c_loop['python_ms']:.4f} ms per impact)",
                     "verdict": verdict(ratio, ratio <= OPTION_TARGET)})
    if "ratio" in c_loop:
        rows.append({"target": "(c) the Python API against the pure-C loop over the same impacts (examples/c "
                               "driver, the paper, rtol 1e-8, summary only; 1.49x at the start of issue 36)",
                     "measured": f"{c_loop['ratio']:.2f}x (the median of {len(c_loop['c_runs_ms'])} pairs' ratios; "
                                 f"medians {c_loop['python_ms']:.4f} / {c_loop['c_ms']:.4f} ms per impact)",
                     "verdict": "reported" if c_loop["ratio"] == c_loop["ratio"] else "not measured"})
    cvode = [r.err_u_final for r in runs if r.scene == "paper" and r.contender.startswith("CVODE") and r.status == "ok"]
    if cvode:
        rows.append({"target": "CVODE with the generated C reaches 1e-9 relative error in u_final",
                     "measured": f"{min(cvode):.1e}", "verdict": verdict(min(cvode), min(cvode) <= 1e-9)})
    two = next((r for r in rhs_rows if r["links"] == 2), None)
    if two:
        phases = ("free", "elastic", "elastoplastic", "restitution")
        worst = max(two[f"c_{p}_ns"] for p in phases)
        rows.append({"target": "right-hand side, n = 2, from C: < 100 ns per call (every contact phase)",
                     "measured": " / ".join(f"{two[f'c_{p}_ns']:.0f}" for p in phases) + " ns",
                     "verdict": verdict(worst, worst < 100)})
    for n, limit in ((10, 20.0), (20, 90.0), (30, 60.0)):
        row = next((r for r in scaling_rows if r["links"] == n), None)
        if row:
            rows.append({"target": f"cold build (derive + emit + compile), n = {n}: < {limit:.0f} s",
                         "measured": f"{row['total_s']:.1f} s", "verdict": verdict(row["total_s"], row["total_s"] < limit)})
    if len(scaling_rows) > 1:
        from .scaling import loglog_slope
        rows.append({"target": "growth with n: log-log slopes of the cold build and of the time per impact (reported)",
                     "measured": f"build n^{loglog_slope(scaling_rows, 'total_s'):.2f}, "
                                 f"impact n^{loglog_slope(scaling_rows, 'impact_ms'):.2f}",
                     "verdict": "reported"})
    return rows


def where_the_time_goes(c_loop: dict) -> list[str]:
    """A table of where an impact's microseconds go: the C engine's time split by its
    instruction shares (callgrind), and the Python API's time beyond the C loop."""
    shares = c_loop.get("instruction_shares")
    if not shares:
        return []
    c_us, py_us = c_loop["c_ms"] * 1e3, c_loop["python_ms"] * 1e3
    lines = ["", "Where the microseconds of one impact go (the C loop's time split by its instruction shares; "
                 "Python is the API's time beyond it):", "", "| part | share of the C engine | us |", "|---|---|---|"]
    lines += [f"| {part} | {share:.1%} | {share * c_us:.0f} |" for part, share in shares.items()]
    lines.append(f"| Python (simulate, summary only) | | {py_us - c_us:.0f} |")
    return lines


def write_report(out: Path, mode: str, runs: list[Run], truths: list[Truth], notes: list[str],
                 rhs_rows: list[dict], scaling_rows: list[dict], elapsed_s: float,
                 sweep_result: dict | None = None, c_loop: dict | None = None, in_turn: dict | None = None,
                 points_result: dict | None = None, extra: dict | None = None) -> Path:
    """Write benchmark.json, the figures and report.md. `extra` maps a part's name to its module
    (with `targets` and `report_lines`) and its result."""
    out.mkdir(parents=True, exist_ok=True)
    info = machine()
    _write_csv(out / "workprecision.csv", [asdict(r) for r in runs])
    _write_csv(out / "rhs.csv", rhs_rows)
    _write_csv(out / "scaling.csv", scaling_rows)
    scenes = list(dict.fromkeys(r.scene for r in runs))
    summary = {s: speedups(runs, s) for s in scenes}
    sweep_result = sweep_result or {}
    points_result = points_result or {}
    goals = (targets(runs, rhs_rows, scaling_rows, c_loop, in_turn) + sweep_targets(sweep_result)
             + points_targets(points_result))
    extra = extra or {}
    for part, result in extra.values():
        goals += part.targets(result)
    (out / "benchmark.json").write_text(json.dumps({
        "mode": mode, "machine": info, "elapsed_s": elapsed_s, "notes": notes,
        "truth": [asdict(t) for t in truths], "runs": [asdict(r) for r in runs],
        "speedups_at_rtol_1e-8": summary, "targets": goals, "rhs": rhs_rows, "scaling": scaling_rows,
        "sweep": sweep_result, "c_loop": c_loop or {}, "in_turn": in_turn or {}, "points": points_result,
        **{name: result for name, (_, result) in extra.items()},
    }, indent=1, default=lambda v: None))
    figures = [plot_workprecision(runs, s, out) for s in scenes]
    if rhs_rows:
        figures.append(_plot_lines(rhs_rows, "links", {"c_elastoplastic_ns": "generated C, called from C",
                                                        "cffi_ns": "generated C through cffi",
                                                        "lambdify_ns": "sympy lambdify (numpy)",
                                                        "reference_ns": "reference (numpy)"},
                                   "ns per call", "right-hand side, elasto-plastic phase", out / "rhs.png"))
    if scaling_rows:
        figures.append(_plot_lines(scaling_rows, "links", {"derive_s": "derive (Kane)", "emit_s": "emit (CSE, C)",
                                                            "compile_s": "compile (cffi + CVODE)", "total_s": "total"},
                                   "seconds", "cold build cost against chain length", out / "scaling.png"))

    lines = [f"# impactgen benchmark ({mode})", "",
             f"Measured by `impactgen bench{' --quick' if mode == 'quick' else ''}` in {elapsed_s:.0f} s.", "",
             "## Machine", ""]
    lines += [f"- {k}: {v}" for k, v in info.items()]
    if goals:
        lines += ["", "## Targets", "", "| target | measured | |", "|---|---|---|"]
        lines += [f"| {g['target']} | {g['measured']} | {g['verdict']} |" for g in goals]
    lines += ["", "## Method", "",
              "Error: relative error of u_final (max norm), delta_r and delta_T against a reference",
              "solution from CVODE BDF at rtol 1e-13, atol 1e-15, whose agreement with the independent",
              "reference engine (Radau, rtol 1e-12) is shown below. Time: median wall time of repeated",
              "runs in a warm process (models compiled, imports done): at least 5 runs (3 with --quick),",
              "and a fast contender repeats until its runs add up to 0.25 s. Python-driven contenders have a",
              "budget of right-hand-side calls; a contender stops tightening after a failure, a budget",
              "overrun or a run slower than the limit.", ""]
    lines += ["| scene | u_final | delta_r | delta_T | (reference engine vs CVODE at 1e-13) |", "|---|---|---|---|---|"]
    lines += [f"| {t.scene} | {t.check['u_final']:.1e} | {t.check['delta_r']:.1e} | {t.check['delta_T']:.1e} | |" for t in truths]
    lines += [""] + [f"- {n}" for n in notes]
    for scene in scenes:
        lines += ["", f"## {scene}", "", f"![work-precision {scene}](workprecision_{scene}.png)", ""]
        s = summary[scene]
        if s:
            head = s[0]
            lines += [f"At the error CVODE BDF reaches at rtol 1e-8 (u_final: {head['target_error']:.1e}, "
                      f"{head['cvode_bdf_ms']:.2f} ms):", "",
                      "| contender | time for that error (ms) | x CVODE BDF | |", "|---|---|---|---|"]
            lines += [f"| {r['contender']} | {r['time_ms']:.2f} | {r['slower_than_cvode_bdf']:.1f} | {r['how']} |"
                      for r in s[1:]]
        lines += ["", "| contender | rtol | u_final error | delta_r error | delta_T error | ms | steps | RHS calls | status |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in runs:
            if r.scene == scene:
                lines.append(f"| {r.contender} | {r.rtol:.0e} | {r.err_u_final:.1e} | {r.err_delta_r:.1e} | "
                             f"{r.err_delta_T:.1e} | {r.wall_s * 1e3:.2f} | {r.nsteps} | {r.nfev} | {r.status} |")
    if rhs_rows:
        lines += ["", "## Right-hand side, ns per call", "", "![rhs](rhs.png)", "",
                  "Generated C called from a C loop, per contact phase (the fastest of 7 loops of about",
                  "50 ms); the other columns in the",
                  "elasto-plastic phase (Jackson-Green: a logarithm, four exponentials, a cosine).", "",
                  "| links | C free | C elastic | C elasto-plastic | C restitution | C through cffi | "
                  "sympy lambdify | reference |", "|---|---|---|---|---|---|---|---|"]
        lines += [f"| {r['links']} | {r['c_free_ns']:.0f} | {r['c_elastic_ns']:.0f} | {r['c_elastoplastic_ns']:.0f} | "
                  f"{r['c_restitution_ns']:.0f} | {r['cffi_ns']:.0f} | {r['lambdify_ns']:.0f} | "
                  f"{r['reference_ns']:.0f} |" for r in rhs_rows]
    if scaling_rows:
        lines += ["", "## Cold build cost against chain length", "", "![scaling](scaling.png)", "",
                  "| links | derive (s) | emit (s) | compile (s) | total (s) | C bytes | impact (ms) |",
                  "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['links']} | {r['derive_s']:.2f} | {r['emit_s']:.2f} | {r['compile_s']:.2f} | "
                  f"{r['total_s']:.2f} | {r['c_bytes']} | {r.get('impact_ms', math.nan):.2f} |" for r in scaling_rows]
        from .scaling import loglog_slope
        lines += ["", f"Log-log slopes over n: cold build n^{loglog_slope(scaling_rows, 'total_s'):.2f}, "
                      f"time per impact n^{loglog_slope(scaling_rows, 'impact_ms'):.2f} (the steel chain, "
                      "to separation, rtol 1e-8, difference-quotient Jacobian, median of 7 warm runs). Beyond 8 links the equations come "
                      "from their closed form, which a test holds equal to Kane's method for 1 to 6 links."]
    if in_turn and in_turn.get("ms"):
        lines += ["", "## The target contenders in turn", "",
                  f"At the error the targets compare at ({in_turn['error']:.1e} in u_final, {in_turn['scene']}), each "
                  "contender's two work-precision runs that bracket it (the same tolerances, so the same steps) run "
                  f"again one contender after the other, {in_turn['rounds']} rounds, each time for at least as many "
                  "runs as in the sweep (their median); each round's time at the error interpolated from its two, "
                  "and the median of the rounds (ms). The targets' ratios use these.", "",
                  "| contender | ms | rounds (ms) |", "|---|---|---|"]
        lines += [f"| {name} | {ms:.3f} | {', '.join(f'{v:.3f}' for v in in_turn['round_ms'][name])} |"
                  for name, ms in in_turn["ms"].items()]
    if c_loop:
        lines += ["", "## The pure-C loop", ""]
        if "error" in c_loop and "ratio" not in c_loop:
            lines.append(f"Not measured: {c_loop['error']}.")
        else:
            lines.append(f"The paper's impact at rtol {c_loop['rtol']:g}, run by examples/c/impact_driver.c (the same "
                         "generated model, phase machine and CVODE glue, no Python; warm runs on a reset solver) "
                         "and by `impactgen.simulate(scene, record_steps=False).summary` (warm, in a process of "
                         f"its own that stays up), timed in {len(c_loop['c_runs_ms'])} pairs back to back, the "
                         "order swapped every pair: "
                         f"C {', '.join(f'{v:.3f}' for v in c_loop['c_runs_ms'])} ms, "
                         f"Python {', '.join(f'{v:.3f}' for v in c_loop['python_runs_ms'])} ms; the pairs' ratios "
                         + ", ".join(f"{v:.2f}" for v in c_loop.get("pair_ratios", ())) +
                         f"; their median {c_loop['ratio']:.2f}x (the verdict's), the medians' "
                         f"{c_loop['c_ms']:.3f} and {c_loop['python_ms']:.3f} ms "
                         f"({c_loop['python_ms'] / c_loop['c_ms']:.2f}x).")
            if "option_ratios" in c_loop:
                lines += ["", "Each Python timing alternates its calls, 20 at a time, with as many of "
                              "`impactgen.simulate(base, rtol=rtol, record_steps=False).summary` on the scene without "
                              f"the rtol: {', '.join(f'{v:.3f}' for v in c_loop['option_runs_ms'])} ms; each round's "
                              "ratio to the scene with the rtol inside it (the median of its blocks' ratios) "
                              + ", ".join(f"{v:.3f}" for v in c_loop["option_ratios"])
                              + f"; their median {c_loop['option_ratio']:.3f}x (target (b)'s)."]
            if "instructions_per_step" in c_loop:  # reported, not a target
                by_phase = c_loop.get("instructions_per_step_by_phase", {})
                lines += ["", f"callgrind: {c_loop['instructions_per_run']:.0f} instructions per run of the C loop, "
                              f"{c_loop['steps']} CVODE steps: {c_loop['instructions_per_step']:.0f} per step"
                              + (" (" + ", ".join(f"{p} {n:.0f}" for p, n in by_phase.items()) + ")." if by_phase
                                 else ".")]
                if "instruction_ratio" in c_loop:
                    lines += ["", f"callgrind: {c_loop['api_instructions_per_run']:.0f} instructions per call of the "
                                  "Python API (summary only), "
                                  f"{c_loop['instruction_ratio']:.2f} times the C loop's run."]
                lines += where_the_time_goes(c_loop)
            elif "error" in c_loop:
                lines += ["", f"Instructions per step not measured: {c_loop['error']}."]
    if sweep_result:
        lines += sweep_report_lines(sweep_result)
    lines += points_report_lines(points_result)
    for part, result in extra.values():
        lines += part.report_lines(result)
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path
