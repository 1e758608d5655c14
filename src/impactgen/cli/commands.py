"""The commands of `impactgen`, one function each, by the name `COMMANDS` gives them."""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from ..errors import SceneError, SolverError
from .generated import generate
from .report import format_summary, one_line


def _fmu(args: argparse.Namespace) -> int:
    from ..fmu import build_fmu
    from ..scene import load_scene, steel_chain_scene
    if (args.scene is None) == (args.links is None):
        raise SceneError("scene", "give a scene or --links N (not both)")
    if args.links is not None:
        if not 1 <= args.links <= 60:
            raise SceneError("--links", f"expected a number of links from 1 to 60, got {args.links}")
        scene = steel_chain_scene(args.links)
        if args.set:
            scene = scene.replace(_overrides(args.set))
    else:
        scene = load_scene(args.scene, _overrides(args.set))
    out = args.out or Path(f"{scene.name}.fmu")
    if out.suffix != ".fmu":
        raise SceneError("--out", f"an FMU file ends in .fmu, got {out}")
    started = time.perf_counter()
    path = build_fmu(scene, out, args.kind)
    kinds = {"me": "Model Exchange", "cs": "Co-Simulation", "both": "Model Exchange and Co-Simulation"}
    print(f"{path}: FMI 2.0 {kinds[args.kind]}, {path.stat().st_size / 1024:.0f} KB "
          f"({time.perf_counter() - started:.1f} s). Its default experiment is the scene's stop time and "
          f"rtol: fmpy simulate {path} (docs/embedding.md)")
    return 0


def _overrides(items: list[str]) -> dict:
    """The --set KEY=VALUE items as an overrides mapping."""
    from ..scene import parse_override
    return dict(parse_override(item) for item in items)


def _run(args: argparse.Namespace) -> int:
    import impactgen
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    if args.format and args.out is None:
        raise SceneError("--format", "goes with --out DIR (the folder to write the tables into)")
    result = impactgen.simulate(scene, engine=args.engine, method=args.method, warn=False)  # printed below
    written = []
    if args.out is not None:
        from ..export import write_run
        written = write_run(result, args.out, args.format)
    if args.json:
        print(json.dumps(result.to_json_dict()))
    else:
        print(format_summary(result))
        for path in written:
            print(f"wrote {path}")
    for warning in result.warnings:
        print(f"impactgen: warning: {warning}", file=sys.stderr)
    if not result.success:  # the partial result is printed (and written) above
        print(f"impactgen: error: {one_line(result.message)}", file=sys.stderr)
        return SolverError.exit_code
    return 0


def _compare(args: argparse.Namespace) -> int:
    """impactgen compare: the compliant impact and the rigid laws given its coefficients."""
    import impactgen
    from ..compare import format_comparison
    if args.laws is not None or args.speeds is not None:
        return _compare_contact_laws(args)
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    if args.out is not None:
        raise SceneError("--out", "is the figure of --speeds: give --speeds LOW..HIGH[:N]")
    table = impactgen.compare_laws(scene, engine=args.engine)
    if args.json:
        rows = table.to_dict(orient="records")
        print(json.dumps({"scene": scene.name, "rows": [{k: _json_number(v) for k, v in r.items()} for r in rows]}))
    else:
        print("\n".join(format_comparison(table, scene.n)))
    return 0


def _law_split(args: argparse.Namespace):
    """The scene of `args` and the laws' own keys among its --set (contact.restitution, ...):
    the scene takes those its own law reads, and each law of --laws those it reads."""
    import impactgen
    from ..contact_compare import law_keys, under_law
    overrides = _overrides(args.set)
    settings = law_keys(overrides)
    scene = impactgen.load_scene(args.scene, {k: v for k, v in overrides.items() if k not in settings})
    return under_law(scene, scene["contact.model"], settings), settings


def _compare_contact_laws(args: argparse.Namespace) -> int:
    """impactgen compare --laws/--speeds: the contact laws side by side, in C (run_batch)."""
    from .. import contact_compare as cc
    scene, settings = _law_split(args)
    if args.engine != "c":
        raise SceneError("--engine", "compare --laws and --speeds run in C (impactgen.run_batch); "
                                     "leave out --engine reference")
    laws = cc.check_laws(args.laws if args.laws is not None else [scene["contact.model"]])
    speeds = cc.parse_speeds(args.speeds) if args.speeds is not None else None
    if speeds is None and args.out is not None:
        raise SceneError("--out", "is the figure of --speeds: give --speeds LOW..HIGH[:N]")
    table = cc.compare_contact_laws(scene, laws, settings)
    out = {"scene": scene.name, "rows": [{k: _json_number(v) for k, v in r.items()}
                                         for r in table.to_dict(orient="records")]}
    if speeds is not None:
        frame = cc.speed_sweep(scene, laws, speeds, settings)
        figure = cc.plot_speed_sweep(frame, args.out or Path(f"{scene.name}-laws.png"),
                                     f"{scene.name}: first impact against the normal impact speed")
        out.update({"speeds": cc.speeds_json(frame), "figure": str(figure)})
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"{scene.name}: the first impact under each contact law")
    print("\n".join(cc.format_law_table(table)))
    if speeds is not None:
        print(f"{len(laws)} laws x {len(speeds)} speeds from {speeds[0]:g} to {speeds[-1]:g} m/s: {out['figure']}")
    return 0


def _fit(args: argparse.Namespace) -> int:
    """impactgen fit: scene keys fitted to measured impacts, with their errors (docs/fitting.md)."""
    import impactgen
    from ..fitting.report import fit_json, format_fit, plot_fit
    scene, settings = _law_split(args)
    out = args.out or Path(f"{scene.name}-fit.png")
    if out.suffix.lower() != ".png":
        raise SceneError("--out", f"the figure is a PNG file: give a name ending in .png, got {out}")
    result = impactgen.fit(scene, args.data, args.fit, laws=args.law, settings=settings)
    figure = plot_fit(result, out)
    if args.json:
        print(json.dumps({**fit_json(result), "figure": str(figure)}))
    else:
        print("\n".join(format_fit(result)))
        print(f"figure of measured against fitted: {figure}")
    return 0


def _json_number(value):
    """NaN and infinities as null (JSON has none), numpy scalars as Python's."""
    value = value.item() if hasattr(value, "item") else value
    return None if isinstance(value, float) and not math.isfinite(value) else value


def _sweep(args: argparse.Namespace) -> int:
    import signal

    import impactgen
    from ..sweep import SweepSpec, run_sweep
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    spec = SweepSpec.from_vary(args.vary, random=args.random, seed=args.seed)
    if args.plot and args.out is None:
        raise SceneError("--plot", "the figures go into the --out folder: give one")
    # SIGTERM ends the sweep as Ctrl-C does: the finished parts are already on disk
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    bars = []  # the progress bar starts with the first finished cases, after every check
    done = [0]

    def progress(count: int) -> None:
        if not bars and not args.quiet:
            from tqdm import tqdm
            bars.append(tqdm(total=spec.count(), unit="case", file=sys.stderr, smoothing=0.1))
        done[0] += count
        if bars:
            bars[0].update(count)

    def resumed(count: int) -> None:
        print(f"impactgen: resuming: {count} of {spec.count()} cases were done in {args.out}; "
              f"computing the other {spec.count() - count}", file=sys.stderr)
    try:
        frame = run_sweep(scene, spec, workers=args.workers, out=args.out, progress=progress,
                          scheduler=args.scheduler, trajectories=_kept(args), on_resume=resumed)
    except KeyboardInterrupt:
        for bar in bars:
            bar.close()
        kept = f"; the {done[0]} finished cases are kept in {args.out}: run the same command to resume" \
            if args.out is not None else ""
        print(f"impactgen: interrupted after {done[0]} of {spec.count()} cases{kept}", file=sys.stderr)
        return 130
    for bar in bars:
        bar.close()
    counts = frame["status"].value_counts().to_dict()
    print(f"{len(frame)} cases: " + ", ".join(f"{n} {status}" for status, n in sorted(counts.items())))
    if args.out is not None:
        print(args.out / "sweep.parquet")
    else:
        shown = [c for c in frame.columns if c in ("case", *(a.key for a in spec.axes), "status",
                                                   "delta_max", "delta_r", "P_max", "delta_T", "t_contact")]
        print(frame[shown].to_string(index=False, max_rows=40))
    if args.plot:
        from ..sweep.figures import plot_sweep
        for path in plot_sweep(frame, spec, args.out):
            print(path)
    return 0


def _kept(args: argparse.Namespace) -> int | list[int]:
    """--trajectories K, or the case numbers of --trajectory-cases."""
    if args.trajectory_cases is None:
        return args.trajectories
    try:
        return [int(v) for v in args.trajectory_cases.split(",") if v.strip()]
    except ValueError:
        raise SceneError("--trajectory-cases", f"expected case numbers like 0,5,9, got "
                                               f"{args.trajectory_cases!r}") from None


def _examples(args: argparse.Namespace) -> int:
    from ..examples import copy_example, example_description, example_names
    if args.name is None:
        if args.out is not None:
            raise SceneError("--out", "name the example to copy: impactgen examples NAME --out PATH")
        for name in example_names():
            print(f"{name:<22} {example_description(name)}")
        print("run one with 'impactgen run NAME'; copy one out with 'impactgen examples NAME'")
        return 0
    path = copy_example(args.name, args.out if args.out is not None else Path.cwd())
    print(path)
    return 0


def _stability(args: argparse.Namespace) -> int:
    from ..stability import run_catalogue, write_report
    rows = run_catalogue(args.quick)
    path = write_report(rows, args.out, args.quick)
    if args.json:
        print(json.dumps({"report": str(path), "rows": rows}, default=lambda v: None))
        return 0
    ok = sum(r["status"] in ("ok", "no-impact") for r in rows)
    print(f"stability: {ok} of {len(rows)} runs passed, {len(rows) - ok} failed or failed a check")
    for r in rows:
        if r["status"] not in ("ok", "no-impact"):
            print(f"  {r['status']}: {r['case']} ({r['setting']}): {one_line(str(r.get('reason', '')))[:160]}")
    print(path)
    return 0


def _window_arg(text: str) -> tuple[float, float]:
    try:
        t0, t1 = (float(v) for v in text.split(":"))
    except ValueError:
        raise SceneError("--window", f"expected T0:T1 in seconds, e.g. 0:0.01, got {text!r}") from None
    if not (math.isfinite(t0) and math.isfinite(t1)) or t1 <= t0:
        raise SceneError("--window", f"expected two finite times T0 < T1, got {text!r}")
    return t0, t1


def _plot(args: argparse.Namespace) -> int:
    import impactgen
    from ..plots import plot_simulation
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    window = _window_arg(args.window) if args.window else None
    if args.impact is not None and args.impact < 1:
        raise SceneError("--impact", f"impacts are numbered from 1, got {args.impact}")
    result = impactgen.simulate(scene, engine=args.engine)
    out = args.out or Path("plots") / scene.name
    try:
        paths = plot_simulation(result, out, impact=args.impact, window=window, whole_run=args.whole_run)
    except OSError as exc:
        raise SceneError("--out", f"cannot write the figures to {out}: {exc}") from None
    for path in paths:
        print(path)
    if not result.success:
        print(f"impactgen: error: {one_line(result.message)}", file=sys.stderr)
        return SolverError.exit_code
    return 0


def _animate(args: argparse.Namespace) -> int:
    import impactgen
    from ..animate import animate, check_output, default_path
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    out = args.out if args.out is not None else default_path(scene.name)
    check_output(out, args.fps, args.seconds)  # a bad suffix, bad numbers or no ffmpeg: before the run
    result = impactgen.simulate(scene, engine=args.engine, dense_output=True)
    print(animate(result, out, fps=args.fps, seconds=args.seconds))
    if not result.success:
        print(f"impactgen: error: {one_line(result.message)}", file=sys.stderr)
        return SolverError.exit_code
    return 0


def _link_range(text: str) -> list[int]:
    try:
        if "-" in text:
            lo, hi = (int(v) for v in text.split("-", 1))
            links = list(range(lo, hi + 1))
        else:
            links = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise SceneError("--links", f"expected a range like 1-6 or a list like 2,4, got {text!r}") from None
    if not links or min(links) < 1 or max(links) > 60:
        raise SceneError("--links", f"expected link counts from 1 to 60, got {text!r}")
    return links


def _crosscheck(args: argparse.Namespace) -> int:
    import numpy as np
    from .. import crosscheck as cc
    from ..reference import METHODS
    if args.method not in METHODS:
        raise SceneError("--method", f"{args.method!r} is not one of {', '.join(METHODS)}")
    if not 0 < args.rtol < 1 or not args.tol > 0 or args.random < 0:
        raise SceneError("crosscheck", "--rtol must lie in (0, 1), --tol be > 0, --random >= 0")
    rng = np.random.default_rng(args.seed)
    scenes = cc.standard_scenes(_link_range(args.links), args.rtol) + cc.points_scenes(args.rtol)
    scenes += cc.random_scenes(rng, args.random, str(args.seed), args.rtol)
    reports = cc.run(scenes, args.method, progress=cc.stderr_progress)
    worst = cc.worst(reports)
    passed = all(v <= args.tol for v, _ in worst.values())
    if args.json:
        print(json.dumps({
            "passed": passed, "tolerance": args.tol, "rtol": args.rtol, "method": args.method,
            "worst": {q: {"difference": v, "scene": name} for q, (v, name) in worst.items()},
            "scenes": [{"scene": r.scene.name, "links": r.scene.n, "differences": r.differences,
                        "wall_c_s": r.wall_c, "wall_reference_s": r.wall_reference} for r in reports],
        }, default=lambda v: None))
    else:
        print(f"{'quantity':<14} {'largest relative difference':>28}   scene")
        for q, (v, name) in worst.items():
            flag = "" if v <= args.tol else "   > tolerance"
            print(f"{q:<14} {v:>28.2e}   {name}{flag}")
        wall_c = sum(r.wall_c for r in reports)
        wall_ref = sum(r.wall_reference for r in reports)
        print(f"{len(reports)} scenes at rtol {args.rtol:g}: C engine {wall_c * 1e3:.1f} ms, reference "
              f"({args.method}) {wall_ref:.1f} s; {'PASS' if passed else 'FAIL'} (tolerance {args.tol:g})")
    return 0 if passed else 1


def _bench(args: argparse.Namespace) -> int:
    from ..bench import PARTS, run_benchmarks
    parts = {p.strip() for p in args.parts.split(",") if p.strip()}
    unknown = parts - set(PARTS)
    if unknown or not parts:
        raise SceneError("--parts", f"choose from {', '.join(PARTS)} (got {args.parts!r})")
    report = run_benchmarks(args.out, args.quick, parts)
    for goal in json.loads((report.parent / "benchmark.json").read_text())["targets"]:
        print(f"{goal['verdict']:>12}  {goal['measured']:<24} {goal['target']}")
    print(report)
    return 0


def _materials(args: argparse.Namespace) -> int:
    """impactgen materials: the table of named materials."""
    import dataclasses

    from ..materials import MATERIALS, format_materials
    if args.json:
        units = {"E": "Pa", "nu": "1", "yield_strength": "Pa", "density": "kg/m^3"}
        print(json.dumps({"units": units, "materials": [dataclasses.asdict(m) for m in MATERIALS.values()]}))
    else:
        print("\n".join(format_materials()))
    return 0


def _paper_table(args: argparse.Namespace) -> int:
    """impactgen paper-table: the paper's Table 2 computed again, beside the published values."""
    from ..paper import COLUMNS, format_paper_table, paper_rows
    rows = paper_rows(args.engine)
    if args.json:
        print(json.dumps({"engine": args.engine, "units": COLUMNS, "rows": rows}))
    else:
        print("\n".join(format_paper_table(rows)))
    return 0


def _generate(args: argparse.Namespace) -> int:
    from ..scene import load_scene
    scene = load_scene(args.scene, _overrides(args.set))
    return generate(scene, args.out or Path("generated") / scene.name, args.prefix, force=args.force)


def links(args: argparse.Namespace) -> int:
    """`impactgen --links N`: generate and compile an N-link steel chain, and write its scene."""
    if args.links < 1 or args.links > 60:
        raise SceneError("--links", f"expected a number of links from 1 to 60, got {args.links}")
    from ..scene import steel_chain_scene
    return generate(steel_chain_scene(args.links), args.out or Path("generated") / f"chain{args.links}",
                    args.prefix, write_scene=True, force=args.force)


COMMANDS = {"run": _run, "examples": _examples, "sweep": _sweep, "crosscheck": _crosscheck, "plot": _plot,
            "animate": _animate, "stability": _stability, "compare": _compare, "bench": _bench, "fmu": _fmu,
            "generate": _generate, "paper-table": _paper_table, "fit": _fit,
            "materials": _materials}
