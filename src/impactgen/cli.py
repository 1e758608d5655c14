"""The `impactgen` command.

    impactgen --links N [--out DIR]            generate and compile an N-link steel chain
    impactgen generate SCENE [--out DIR]       generate and compile what SCENE needs
    impactgen run SCENE [--engine c|reference] [--json] [--set KEY=VALUE ...]
    impactgen crosscheck [--links 1-6] [--random N] [--seed S] [--json]
    impactgen plot SCENE [--out DIR] [--set KEY=VALUE ...]
    impactgen bench [--quick] [--out DIR] [--parts workprecision,rhs,scaling]
    impactgen stability [--quick] [--json] [--out DIR]

Exit codes: 0 success, 2 bad input, 3 build failure, 4 solver failure. Errors are one line
on stderr; --debug shows the traceback.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Sequence

from .errors import ImpactgenError, SceneError


class _Parser(argparse.ArgumentParser):
    """argparse that raises SceneError (exit 2, one line) instead of printing usage."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise SceneError(None, f"{message} (see 'impactgen --help')")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="impactgen", description="Generate fast C for an n-link pendulum impact "
                "and simulate it (MODEL: Hertz, Jackson-Green, restitution, friction).")
    p.add_argument("--links", type=int, metavar="N", help="generate and compile an N-link "
                   "steel chain (the paper's materials) and print where the files are")
    p.add_argument("--out", type=Path, help="folder for the generated C (with --links)")
    p.add_argument("--prefix", default="model", help="C name prefix of the generated files")
    p.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)

    run = sub.add_parser("run", help="simulate a scene")
    run.add_argument("scene", type=Path)
    run.add_argument("--engine", choices=("c", "reference"), default="c")
    run.add_argument("--method", default=None, help="solve_ivp method of the reference engine "
                     "(Radau, BDF, LSODA, DOP853, RK45)")
    run.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. --set initial.u=[-0.1,-0.3]")
    run.add_argument("--debug", action="store_true", help="show tracebacks")

    cc = sub.add_parser("crosscheck", help="compare the C engine with the reference engine")
    cc.add_argument("--links", default="1-6", help="steel chains to run, e.g. 1-6 or 2,4")
    cc.add_argument("--random", type=int, default=0, metavar="N", help="N random scenes")
    cc.add_argument("--seed", type=int, default=0)
    cc.add_argument("--rtol", type=float, default=1e-11, help="solver rtol of both engines")
    cc.add_argument("--tol", type=float, default=1e-7, help="largest relative difference allowed")
    cc.add_argument("--method", default="Radau", help="solve_ivp method of the reference")
    cc.add_argument("--json", action="store_true")
    cc.add_argument("--debug", action="store_true", help="show tracebacks")

    plot = sub.add_parser("plot", help="figures of one simulation (the paper's Figures 4-8)")
    plot.add_argument("scene", type=Path)
    plot.add_argument("--out", type=Path, help="folder for the PNG files (default plots/<name>)")
    plot.add_argument("--engine", choices=("c", "reference"), default="c")
    plot.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    plot.add_argument("--debug", action="store_true", help="show tracebacks")

    bench = sub.add_parser("bench", help="work-precision, RHS and scaling benchmarks with a report")
    bench.add_argument("--quick", action="store_true", help="a smaller run (under 3 minutes)")
    bench.add_argument("--out", type=Path, default=Path("bench-results"))
    bench.add_argument("--parts", default="workprecision,rhs,scaling")
    bench.add_argument("--debug", action="store_true", help="show tracebacks")

    stab = sub.add_parser("stability", help="run the catalogue of stiff and extreme cases")
    stab.add_argument("--quick", action="store_true", help="fewer cases and settings")
    stab.add_argument("--json", action="store_true", help="print the rows as one JSON object")
    stab.add_argument("--out", type=Path, default=Path("stability-results"))
    stab.add_argument("--debug", action="store_true", help="show tracebacks")

    gen = sub.add_parser("generate", help="generate and compile the C a scene needs")
    gen.add_argument("scene", type=Path)
    gen.add_argument("--out", type=Path)
    gen.add_argument("--prefix", default="model")
    gen.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    gen.add_argument("--debug", action="store_true", help="show tracebacks")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    wants_json = "--json" in argv
    try:
        args = _parser().parse_args(argv)
        if args.command == "run":
            return _run(args)
        if args.command == "crosscheck":
            return _crosscheck(args)
        if args.command == "plot":
            return _plot(args)
        if args.command == "stability":
            from .stability import run_catalogue, write_report
            rows = run_catalogue(args.quick)
            path = write_report(rows, args.out, args.quick)
            if args.json:
                print(json.dumps({"report": str(path), "rows": rows}, default=lambda v: None))
            else:
                print(path)
            return 0
        if args.command == "bench":
            from .bench import run_benchmarks
            parts = {p.strip() for p in args.parts.split(",") if p.strip()}
            unknown = parts - {"workprecision", "rhs", "scaling"}
            if unknown or not parts:
                raise SceneError("--parts", f"choose from workprecision, rhs, scaling (got {args.parts!r})")
            report = run_benchmarks(args.out, args.quick, parts)
            for goal in json.loads((report.parent / "benchmark.json").read_text())["targets"]:
                print(f"{goal['verdict']:>12}  {goal['measured']:<24} {goal['target']}")
            print(report)
            return 0
        if args.command == "generate":
            from .scene import load_scene
            scene = load_scene(args.scene, _overrides(args.set))
            return _generate(scene, args.out or Path("generated") / scene.name, args.prefix)
        if args.links is not None:
            if args.links < 1 or args.links > 60:
                raise SceneError("--links", f"expected a number of links from 1 to 60, got {args.links}")
            from .scene import steel_chain_scene
            return _generate(steel_chain_scene(args.links),
                             args.out or Path("generated") / f"chain{args.links}", args.prefix)
        raise SceneError(None, "nothing to do: give a command (run, generate, crosscheck) or "
                               "--links N; see 'impactgen --help'")
    except ImpactgenError as exc:
        if debug:
            raise
        message = _one_line(str(exc))
        print(f"impactgen: error: {message}", file=sys.stderr)
        if wants_json:
            print(json.dumps({"status": "error", "exit_code": exc.exit_code, "message": message}))
        return exc.exit_code
    except KeyboardInterrupt:
        print("impactgen: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader (head, say) stopped reading: not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except SystemExit as exc:  # --help
        return exc.code if isinstance(exc.code, int) else 0


def _one_line(text: str) -> str:
    """One printable line whatever a message holds: breaks become spaces, and other control
    characters (which str.splitlines may also take for line breaks) are escaped."""
    text = " ".join(text.splitlines())
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


def _overrides(items: list[str]) -> dict:
    from .scene import parse_override
    return dict(parse_override(item) for item in items)


def _generate(scene, out: Path, prefix: str) -> int:
    from .build import compile_model
    from .codegen.emit import generate_model
    from .engines import model_spec
    if not prefix.isidentifier() or not prefix.isascii():
        raise SceneError("--prefix", f"{prefix!r} is not a C identifier")
    spec = model_spec(scene)
    started = time.perf_counter()
    gen = generate_model(spec, prefix)
    compiled = compile_model(spec)
    elapsed = time.perf_counter() - started
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / f"{prefix}.h").write_text(gen.header)
        (out / f"{prefix}.c").write_text(gen.source)
    except OSError as exc:
        raise SceneError("--out", f"cannot write to {out}: {exc}") from None
    print(f"{spec.slug}: {out / (prefix + '.h')}, {out / (prefix + '.c')} "
          f"(plain C99, link with -lm)")
    print(f"compiled with CVODE: {compiled.path} ({elapsed:.1f} s)")
    return 0


def _run(args: argparse.Namespace) -> int:
    import impactgen
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    options = {"method": args.method} if args.method and args.engine == "reference" else {}
    if args.method and args.engine != "reference":
        raise SceneError("--method", "only the reference engine takes --method (the C engine "
                         "uses solver.method = bdf | adams)")
    result = impactgen.simulate(scene, engine=args.engine, **options)
    if args.json:
        print(json.dumps(result.to_json_dict()))
        return 0
    print(format_summary(result))
    for warning in result.warnings:
        print(f"impactgen: warning: {warning}", file=sys.stderr)
    return 0


def _plot(args: argparse.Namespace) -> int:
    import impactgen
    from .plots import plot_simulation
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    result = impactgen.simulate(scene, engine=args.engine)
    out = args.out or Path("plots") / scene.name
    try:
        paths = plot_simulation(result, out)
    except OSError as exc:
        raise SceneError("--out", f"cannot write the figures to {out}: {exc}") from None
    for path in paths:
        print(path)
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
    from . import crosscheck as cc
    from .reference import METHODS
    if args.method not in METHODS:
        raise SceneError("--method", f"{args.method!r} is not one of {', '.join(METHODS)}")
    if not 0 < args.rtol < 1 or not args.tol > 0 or args.random < 0:
        raise SceneError("crosscheck", "--rtol must lie in (0, 1), --tol be > 0, --random >= 0")
    rng = np.random.default_rng(args.seed)
    scenes = cc.standard_scenes(_link_range(args.links), args.rtol)
    scenes += [cc.random_scene(rng, int(rng.integers(1, 7)), f"random-{args.seed}-{i}", args.rtol)
               for i in range(args.random)]
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


def format_summary(result) -> str:
    s = result.summary
    e = s["energy"]
    lines = [f"{result.scene.name} ({result.engine} engine): {result.status}"
             + (f", {result.message}" if result.message else "")]
    spans = [f"{p.phase}{' (' + p.friction + ')' if p.friction else ''} [{p.t0:.4g}, {p.t1:.4g}] s"
             for p in result.phases]
    if len(spans) > 12:  # repeated impacts: the first and the last few
        spans = spans[:4] + [f"... {len(spans) - 8} more ..."] + spans[-4:]
    lines.append("phases: " + ", ".join(spans))
    if s["impacts"]:
        lines += [
            f"max deformation   delta_m = {s['delta_max']:.4g} m",
            f"permanent         delta_r = {s['delta_r']:.4g} m",
            f"max force         P_m     = {s['P_max']:.4g} N",
            f"unloading radius  R_res   = {s['R_res']:.4g} m",
            f"impact duration           = {s['t_contact']:.4g} s",
        ]
        if s["stick_slip"]:
            lines.append("stick-slip        " + ", ".join(f"{w['from']} -> {w['to']} at {w['t']:.4g} s"
                                                       for w in s["stick_slip"]))
        if s["impacts"] > 1:
            lines.append(f"impacts           {s['impacts']} (the summary is the first)")
    lines += [
        f"kinetic energy    T0 = {s['T0']:.6g} J, Tf = {s['Tf']:.6g} J, Delta T = {s['delta_T']:.4g} J",
        f"energy budget     W_normal = {e['W_normal']:.4g} J, W_friction = {e['W_friction']:.4g} J, "
        f"W_gravity = {e['W_gravity']:.4g} J, residual = {e['residual']:.2g} J",
        "final speeds      u = [" + ", ".join(f"{v:.6g}" for v in s["u_final"]) + "] rad/s",
        f"solver            {result.stats.get('nsteps', 0)} steps, {result.stats.get('nfev', 0)} RHS calls, "
        f"{result.stats.get('wall_s', 0.0) * 1e3:.2f} ms",
    ]
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
