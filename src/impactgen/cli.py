"""The `impactgen` command.

    impactgen --links N [--out DIR]            generate and compile an N-link steel chain (+ its scene)
    impactgen generate SCENE [--out DIR]       generate and compile what SCENE needs
    impactgen run SCENE|EXAMPLE [--engine c|reference] [--method M] [--json] [--set KEY=VALUE ...]
                  [--out DIR [--format parquet|csv]]
    impactgen examples [NAME [--out PATH]]     list the shipped example scenes, or copy one out
    impactgen crosscheck [--links 1-6] [--random N] [--seed S] [--json]
    impactgen plot SCENE [--out DIR] [--impact K | --window T0:T1] [--set KEY=VALUE ...]
    impactgen animate SCENE [--out FILE.gif|.mp4] [--fps N] [--seconds S] [--set KEY=VALUE ...]
    impactgen bench [--quick] [--out DIR] [--parts workprecision,rhs,scaling]
    impactgen stability [--quick] [--json] [--out DIR]
    impactgen compare SCENE [--engine c|reference] [--json] [--set KEY=VALUE ...]

Exit codes: 0 success, 2 bad input, 3 build failure, 4 solver failure. Errors are one line
on stderr; --debug shows the traceback.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Sequence

from .errors import ImpactgenError, SceneError, SolverError

SET_HELP = "override a scene value (TOML), e.g. --set initial.u=[-0.1,-0.3] or --set initial.u[2]=-0.3"
SCENE_HELP = "a scene file (TOML), or the name of a shipped example (see 'impactgen examples')"


class _Parser(argparse.ArgumentParser):
    """argparse that raises SceneError (exit 2, one line) instead of printing usage."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise SceneError(None, f"{message} (see 'impactgen --help')")


def _parser() -> argparse.ArgumentParser:
    from . import __version__
    p = _Parser(prog="impactgen", description="Generate fast C for an n-link pendulum impact "
                "and simulate it (MODEL: Hertz, Jackson-Green, restitution, friction).",
                epilog="Exit codes: 0 success, 2 bad input, 3 build failure, 4 solver failure.")
    p.add_argument("--version", action="version", version=f"impactgen {__version__}")
    p.add_argument("--links", type=int, metavar="N", help="generate and compile an N-link "
                   "steel chain (the paper's materials), write its scene, and print where the files are")
    p.add_argument("--out", type=Path, help="folder for the generated C and scene (with --links; "
                   "default generated/chainN)")
    p.add_argument("--prefix", default="model", help="C name prefix of the generated files (default model)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = p.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")

    run = sub.add_parser("run", help="simulate a scene", description="Simulate a scene and print "
                         "its first impact and, for a run to a time, the whole run.")
    run.add_argument("scene", type=Path, help=SCENE_HELP)
    run.add_argument("--engine", choices=("c", "reference"), default="c",
                     help="c: generated C with CVODE (default); reference: the pure-Python engine")
    run.add_argument("--method", default=None, help="integrator: auto, bdf, adams, erk or dopri5 (c engine); Radau, BDF, "
                     "LSODA, DOP853 or RK45 (reference engine)")
    run.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    run.add_argument("--out", type=Path, default=None, help="also write the trajectories, the impacts "
                     "table and summary.json into this folder")
    run.add_argument("--format", choices=("parquet", "csv"), default=None,
                     help="table format with --out (default parquet if pyarrow is installed, else csv)")
    run.add_argument("--debug", action="store_true", help="show tracebacks")

    ex = sub.add_parser("examples", help="list the shipped example scenes, or copy one out")
    ex.add_argument("name", nargs="?", help="the example to copy out")
    ex.add_argument("--out", type=Path, default=None, help="file or folder to copy it to (default ./NAME.toml)")
    ex.add_argument("--debug", action="store_true", help="show tracebacks")

    sw = sub.add_parser("sweep", help="run a scene over a grid or random draws of its values",
                        description="One row per case, in a table (Parquet with --out). KEY is a scene "
                        "key, an element counted from 1 (initial.u[2]); SPEC a list [a,b], linspace(a,b,n), "
                        "logspace(a,b,n), or with --random uniform(a,b), normal(mu,sigma), lognormal(mu,sigma).")
    sw.add_argument("scene", type=Path, help=SCENE_HELP)
    sw.add_argument("--vary", action="append", default=[], metavar="KEY=SPEC", required=True,
                    help="a varied key and its values; several make a full grid")
    sw.add_argument("--random", type=int, default=0, metavar="N", help="draw N cases from the distributions")
    sw.add_argument("--seed", type=int, default=0, help="seed of the random draws (default 0)")
    sw.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    sw.add_argument("--workers", type=int, default=None, metavar="K",
                    help="processes of the local pool, or of --scheduler local (default: all cores)")
    sw.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="run on a Dask cluster: tcp://HOST:PORT of its scheduler, or 'local' "
                         "for a LocalCluster started here")
    kept = sw.add_mutually_exclusive_group()
    kept.add_argument("--trajectories", type=int, default=0, metavar="K",
                      help="keep the samples of K evenly chosen cases (needs --out), for T(t) figures")
    kept.add_argument("--trajectory-cases", default=None, metavar="I,J,...",
                      help="keep the samples of these cases (numbered from 0, as the table's 'case')")
    sw.add_argument("--plot", action="store_true", help="draw the figures the varied keys call for "
                    "into OUT/_figures (needs --out)")
    sw.add_argument("--out", type=Path, default=None, help="folder for sweep.parquet; the same command "
                    "resumes an interrupted sweep there")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.add_argument("--debug", action="store_true", help="show tracebacks")

    cc = sub.add_parser("crosscheck", help="compare the C engine with the reference engine")
    cc.add_argument("--links", default="1-6", help="steel chains to run, e.g. 1-6 or 2,4")
    cc.add_argument("--random", type=int, default=0, metavar="N", help="N random scenes")
    cc.add_argument("--seed", type=int, default=0, help="seed of the random scenes")
    cc.add_argument("--rtol", type=float, default=1e-11, help="solver rtol of both engines")
    cc.add_argument("--tol", type=float, default=1e-7, help="largest relative difference allowed")
    cc.add_argument("--method", default="Radau", help="solve_ivp method of the reference")
    cc.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    cc.add_argument("--debug", action="store_true", help="show tracebacks")

    plot = sub.add_parser("plot", help="figures of one simulation (the paper's Figures 4-8, or the whole run)")
    plot.add_argument("scene", type=Path, help=SCENE_HELP)
    plot.add_argument("--out", type=Path, help="folder for the PNG files (default plots/<name>)")
    plot.add_argument("--engine", choices=("c", "reference"), default="c", help="engine (default c)")
    which = plot.add_mutually_exclusive_group()
    which.add_argument("--impact", type=int, metavar="K", help="the figures of impact K (from 1)")
    which.add_argument("--window", metavar="T0:T1", help="the figures between two times in s")
    which.add_argument("--whole-run", action="store_true", help="the whole-run view even for one impact")
    plot.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    plot.add_argument("--debug", action="store_true", help="show tracebacks")

    # -- compare (the rigid-body impact laws beside the compliant run): impactgen.compare
    cmp = sub.add_parser("compare", help="the rigid-body impact laws beside the compliant run",
                         description="Simulate a scene's first impact, then give its pre-impact state to "
                                     "Newton's, Poisson's and Stronge's energetic law with the coefficients "
                                     "of restitution the compliant run produced (docs/impact-laws.md).")
    cmp.add_argument("scene", type=Path, help=SCENE_HELP)
    cmp.add_argument("--engine", choices=("c", "reference"), default="c", help="engine (default c)")
    cmp.add_argument("--json", action="store_true", help="print the rows as one JSON object")
    cmp.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    cmp.add_argument("--debug", action="store_true", help="show tracebacks")

    anim = sub.add_parser("animate", help="an animation of the chain over the run (GIF or MP4)",
                          description="Draw the chain moving over the run, the surface, and each contact "
                          "point (every joint, the tip) coloured by its phase. The frames are spread evenly "
                          "over a warped time: the impacts share half of them equally, flight and sustained "
                          "contact the other half in proportion to their duration (all of them if the run "
                          "is all impact or all flight). Beside the chain: the simulated time, and the tip's "
                          "height above the surface in micrometres (docs/animate.md).")
    anim.add_argument("scene", type=Path, help=SCENE_HELP)
    anim.add_argument("--out", type=Path, default=None, metavar="FILE",
                      help="a .gif (Pillow) or .mp4 (needs ffmpeg) file (default ./<scene name>.gif)")
    anim.add_argument("--fps", type=int, default=20, metavar="N", help="frames per second (default 20)")
    anim.add_argument("--seconds", type=float, default=6.0, metavar="S",
                      help="length of the animation (default 6); it has N * S frames")
    anim.add_argument("--engine", choices=("c", "reference"), default="c", help="engine (default c)")
    anim.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    anim.add_argument("--debug", action="store_true", help="show tracebacks")

    bench = sub.add_parser("bench", help="work-precision, RHS and scaling benchmarks with a report")
    bench.add_argument("--quick", action="store_true", help="a smaller run (under 3 minutes)")
    bench.add_argument("--out", type=Path, default=Path("bench-results"), help="report folder")
    bench.add_argument("--parts", default="workprecision,rhs,scaling,sweep,points",
                       help="which benchmarks, comma-separated (workprecision, rhs, scaling, sweep, points)")
    bench.add_argument("--debug", action="store_true", help="show tracebacks")

    stab = sub.add_parser("stability", help="run the catalogue of stiff and extreme cases")
    stab.add_argument("--quick", action="store_true", help="fewer cases and settings")
    stab.add_argument("--json", action="store_true", help="print the rows as one JSON object")
    stab.add_argument("--out", type=Path, default=Path("stability-results"), help="report folder")
    stab.add_argument("--debug", action="store_true", help="show tracebacks")

    fmu = sub.add_parser("fmu", help="export an FMI 2.0 FMU (Model Exchange, Co-Simulation or both)")
    fmu.add_argument("scene", type=Path, nargs="?", help=SCENE_HELP)
    fmu.add_argument("--links", type=int, help="an N-link steel chain instead of a scene (as impactgen --links N)")
    fmu.add_argument("--out", type=Path, help="the .fmu file (default <scene name>.fmu)")
    fmu.add_argument("--kind", default="both", choices=("me", "cs", "both"),
                     help="me: Model Exchange (the importer's solver), cs: Co-Simulation (CVODE inside), "
                          "both (default)")
    fmu.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    fmu.add_argument("--debug", action="store_true", help="show tracebacks")

    gen = sub.add_parser("generate", help="generate and compile the C a scene needs")
    gen.add_argument("scene", type=Path, help=SCENE_HELP)
    gen.add_argument("--out", type=Path, help="folder for the C files (default generated/<name>)")
    gen.add_argument("--prefix", default="model", help="C name prefix (default model)")
    gen.add_argument("--force", action="store_true", help=FORCE_HELP)
    gen.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
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
        if args.command == "examples":
            return _examples(args)
        if args.command == "sweep":
            return _sweep(args)
        if args.command == "crosscheck":
            return _crosscheck(args)
        if args.command == "plot":
            return _plot(args)
        if args.command == "animate":
            return _animate(args)
        if args.command == "stability":
            return _stability(args)
        if args.command == "compare":
            return _compare(args)
        if args.command == "bench":
            from .bench import run_benchmarks
            parts = {p.strip() for p in args.parts.split(",") if p.strip()}
            unknown = parts - {"workprecision", "rhs", "scaling", "sweep", "points"}
            if unknown or not parts:
                raise SceneError("--parts", f"choose from workprecision, rhs, scaling, sweep, points (got {args.parts!r})")
            report = run_benchmarks(args.out, args.quick, parts)
            for goal in json.loads((report.parent / "benchmark.json").read_text())["targets"]:
                print(f"{goal['verdict']:>12}  {goal['measured']:<24} {goal['target']}")
            print(report)
            return 0
        if args.command == "fmu":
            return _fmu(args)
        if args.command == "generate":
            from .scene import load_scene
            scene = load_scene(args.scene, _overrides(args.set))
            return _generate(scene, args.out or Path("generated") / scene.name, args.prefix, force=args.force)
        if args.links is not None:
            if args.links < 1 or args.links > 60:
                raise SceneError("--links", f"expected a number of links from 1 to 60, got {args.links}")
            from .scene import steel_chain_scene
            return _generate(steel_chain_scene(args.links),
                             args.out or Path("generated") / f"chain{args.links}", args.prefix,
                             write_scene=True, force=args.force)
        raise SceneError(None, "nothing to do: give a command (run, examples, generate, plot, ...) or "
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
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else 0


def _fmu(args) -> int:
    from .fmu import build_fmu
    from .scene import load_scene, steel_chain_scene
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
          f"({time.perf_counter() - started:.1f} s). Simulate it at rtol 1e-8 to 1e-10, e.g. "
          f"fmpy simulate {path} --relative-tolerance 1e-10 (docs/embedding.md)")
    return 0


def _one_line(text: str) -> str:
    """One printable line whatever a message holds: breaks become spaces, and other control
    characters (which str.splitlines may also take for line breaks) are escaped."""
    text = " ".join(text.splitlines())
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


def _overrides(items: list[str]) -> dict:
    from .scene import parse_override
    return dict(parse_override(item) for item in items)


FORCE_HELP = "write into --out even if it holds files impactgen did not write there (they are replaced)"
GENERATED_MANIFEST = ".impactgen-generated.json"  # what `generate` wrote into a folder, with digests


def _digest(path: Path) -> str:
    import hashlib
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _check_out_folder(out: Path, files: dict[str, str], force: bool) -> None:
    """`out` may take `files` if it is empty or new, or if every file they replace is one
    impactgen wrote there and nobody changed since (its manifest says); else --force."""
    if force or not out.exists():
        return
    if not out.is_dir():
        raise SceneError("--out", f"{out} is a file, not a folder")
    try:
        known = json.loads((out / GENERATED_MANIFEST).read_text()).get("files", {})
    except FileNotFoundError:
        known = {}
    except (OSError, ValueError, AttributeError):
        known = {}  # unreadable: treated as absent, so nothing is replaced unasked
    foreign = sorted(name for name in files if (out / name).exists()
                     and (name not in known or _digest(out / name) != known[name]))
    if not known and any(out.iterdir()):
        foreign = foreign or sorted(p.name for p in out.iterdir())[:3]
    if foreign:
        raise SceneError("--out", f"{out} holds files impactgen did not write or that were changed since "
                                  f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); choose an "
                                  "empty folder, or add --force to replace them")


def _write_generated(out: Path, files: dict[str, str]) -> None:
    """Write `files` into `out` and note them, with their digests, in its manifest."""
    out.mkdir(parents=True, exist_ok=True)
    manifest = out / GENERATED_MANIFEST
    try:
        known = json.loads(manifest.read_text()).get("files", {})
    except (OSError, ValueError, AttributeError):
        known = {}
    for name, text in files.items():
        (out / name).write_text(text)
        known[name] = _digest(out / name)
    manifest.write_text(json.dumps({"written by": "impactgen generate", "files": known}, indent=1) + "\n")


def _generate(scene, out: Path, prefix: str, write_scene: bool = False, force: bool = False) -> int:
    from .build import compile_model
    from .codegen.emit import driver_files, generate_model
    from .engines import model_spec
    if not prefix.isidentifier() or not prefix.isascii():
        raise SceneError("--prefix", f"{prefix!r} is not a C identifier")
    spec = model_spec(scene)
    started = time.perf_counter()
    gen = generate_model(spec, prefix)
    files = driver_files(gen, scene)
    if write_scene:
        files["scene.toml"] = scene.to_toml()
    _check_out_folder(out, files, force)
    compiled = compile_model(spec)
    elapsed = time.perf_counter() - started
    try:
        _write_generated(out, files)
    except OSError as exc:
        raise SceneError("--out", f"cannot write to {out}: {exc}") from None
    print(f"{spec.slug}: {', '.join(str(out / name) for name in gen.files())} "
          f"(plain C99: the model and its phase machine; link with -lm), and the scene's values "
          f"in {out / (prefix + '_scene.h')}")
    if write_scene:
        print(f"scene: {out / 'scene.toml'} (simulate it: impactgen run {out / 'scene.toml'})")
    print(f"compiled with CVODE: {compiled.path} ({elapsed:.1f} s)")
    return 0


def _run(args: argparse.Namespace) -> int:
    import impactgen
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    if args.format and args.out is None:
        raise SceneError("--format", "goes with --out DIR (the folder to write the tables into)")
    result = impactgen.simulate(scene, engine=args.engine, method=args.method)
    written = []
    if args.out is not None:
        from .export import write_run
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
        print(f"impactgen: error: {_one_line(result.message)}", file=sys.stderr)
        return SolverError.exit_code
    return 0


def _compare(args: argparse.Namespace) -> int:
    """impactgen compare: the compliant impact and the rigid laws given its coefficients."""
    import impactgen
    from .compare import format_comparison
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    table = impactgen.compare_laws(scene, engine=args.engine)
    if args.json:
        rows = table.to_dict(orient="records")
        print(json.dumps({"scene": scene.name, "rows": [{k: _json_number(v) for k, v in r.items()} for r in rows]}))
    else:
        print("\n".join(format_comparison(table, scene.n)))
    return 0


def _json_number(value):
    """NaN and infinities as null (JSON has none), numpy scalars as Python's."""
    value = value.item() if hasattr(value, "item") else value
    return None if isinstance(value, float) and not math.isfinite(value) else value


def _sweep(args: argparse.Namespace) -> int:
    import signal

    import impactgen
    from .sweep import SweepSpec, run_sweep
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
        from .sweep.figures import plot_sweep
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
    from .examples import copy_example, example_description, example_names
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
    from .stability import run_catalogue, write_report
    rows = run_catalogue(args.quick)
    path = write_report(rows, args.out, args.quick)
    if args.json:
        print(json.dumps({"report": str(path), "rows": rows}, default=lambda v: None))
        return 0
    ok = sum(r["status"] in ("ok", "no-impact") for r in rows)
    print(f"stability: {ok} of {len(rows)} runs passed, {len(rows) - ok} failed or failed a check")
    for r in rows:
        if r["status"] not in ("ok", "no-impact"):
            print(f"  {r['status']}: {r['case']} ({r['setting']}): {_one_line(str(r.get('reason', '')))[:160]}")
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
    from .plots import plot_simulation
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
        print(f"impactgen: error: {_one_line(result.message)}", file=sys.stderr)
        return SolverError.exit_code
    return 0


def _animate(args: argparse.Namespace) -> int:
    import impactgen
    from .animate import animate, check_output, default_path
    scene = impactgen.load_scene(args.scene, _overrides(args.set))
    out = args.out if args.out is not None else default_path(scene.name)
    check_output(out, args.fps, args.seconds)  # a bad suffix, bad numbers or no ffmpeg: before the run
    result = impactgen.simulate(scene, engine=args.engine, dense_output=True)
    print(animate(result, out, fps=args.fps, seconds=args.seconds))
    if not result.success:
        print(f"impactgen: error: {_one_line(result.message)}", file=sys.stderr)
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
    from . import crosscheck as cc
    from .reference import METHODS
    if args.method not in METHODS:
        raise SceneError("--method", f"{args.method!r} is not one of {', '.join(METHODS)}")
    if not 0 < args.rtol < 1 or not args.tol > 0 or args.random < 0:
        raise SceneError("crosscheck", "--rtol must lie in (0, 1), --tol be > 0, --random >= 0")
    rng = np.random.default_rng(args.seed)
    scenes = cc.standard_scenes(_link_range(args.links), args.rtol) + cc.points_scenes(args.rtol)
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


IMPACT_ROWS_SHOWN = (5, 3)  # the per-impact table shows the first and the last few impacts


def _phase_line(result) -> str:
    """The first impact's phases, times from its start in microseconds (a contact lasts
    about 0.5 ms: absolute times in 4 figures would hide it)."""
    tips = [impact for impact in result.impacts if impact.point == "tip"]
    if not tips:
        return "phases: " + ", ".join(f"{p.phase} [{p.t0:.9g}, {p.t1:.9g}] s" for p in result.phases[:12])
    impact = tips[0]
    end = impact.t_end if impact.t_end is not None else math.inf
    spans = [p for p in result.phases if p.phase != "free" and impact.t_start <= p.t0 <= end][:12]
    us = 1e6
    text = ", ".join(f"{p.phase}{' (' + p.slip_state + ')' if p.slip_state else ''} "
                     f"{(p.t0 - impact.t_start) * us:.6g}-{(p.t1 - impact.t_start) * us:.6g}"
                     for p in spans)
    return f"phases of impact 1 (us from its start at t = {impact.t_start:.9g} s): {text}"


def _impacts_table(result) -> list[str]:
    head, tail = IMPACT_ROWS_SHOWN
    rows = list(enumerate(result.impacts, start=1))
    shown = rows if len(rows) <= head + tail + 1 else rows[:head] + [None] + rows[-tail:]
    points = any(i.point != "tip" for i in result.impacts)  # several contact points: say whose
    lines = [f"{'impact':>6}{format('point', '>9') if points else ''} {'t_start (s)':>13} {'duration (us)':>14} "
             f"{'delta_max (m)':>14} {'delta_r (m)':>12} {'P_max (N)':>10} {'T before (J)':>13} {'T after (J)':>12}"]
    for row in shown:
        if row is None:
            lines.append(f"{'...':>6} ({len(rows) - head - tail} more)")
            continue
        k, i = row
        duration = f"{i.duration * 1e6:14.6g}" if i.duration is not None else f"{'(open)':>14}"
        lines.append(f"{k:>6}{f' {i.point:>8}' if points else ''} {i.t_start:13.7g} {duration} {i.delta_max:14.4g} "
                     f"{i.delta_r:12.4g} {i.P_max:10.4g} {i.T_before:13.6g} {i.T_after:12.6g}")
    return lines


def _coefficient_lines(c: dict) -> list[str]:
    """The impact's coefficients of restitution and impulses (docs/impact-laws.md), once it ended."""
    if c["e_N"] is None:
        return []
    return [f"  restitution       e_N = {c['e_N']:.5f}, e_P = {c['e_P']:.5f}, e_E = {c['e_E']:.5f} "
            f"(v_n0 = {c['v_n0']:.4g} m/s; impactgen compare: the rigid-body laws)",
            f"  impulses          P_c = {c['P_c']:.5g} N s, P_r = {c['P_r']:.5g} N s, P_t = {c['P_t']:.5g} N s, "
            f"friction's share of the loss {c['friction_share']:.3f}"]


def format_summary(result) -> str:
    """The text `impactgen run` prints: the first impact, then the whole run if it went on."""
    first, run = result.first_impact, result.summary
    lines = [f"{result.scene.name} ({result.engine} engine): {result.status}"
             + (f", {result.message}" if result.message else ""), _phase_line(result)]
    if result.impacts:
        s = first
        e = s["energy"]
        lines += [
            "first impact:",
            f"  max deformation   delta_m = {s['delta_max']:.6g} m",
            f"  permanent         delta_r = {s['delta_r']:.6g} m",
            f"  max force         P_m     = {s['P_max']:.6g} N",
            f"  unloading radius  R_res   = {s['R_res']:.6g} m",
            f"  impact duration           = {s['t_contact']:.6g} s",
            f"  kinetic energy    T0 = {s['T0']:.6g} J, Tf = {s['Tf']:.6g} J, Delta T = {s['delta_T']:.4g} J",
            f"  energy budget     W_normal = {e['W_normal']:.4g} J, W_friction = {e['W_friction']:.4g} J, "
            f"W_gravity = {e['W_gravity']:.4g} J, residual = {e['residual']:.2g} J",
            "  speeds after      u = [" + ", ".join(f"{v:.6g}" for v in s["u_final"]) + "] rad/s",
        ]
        lines += _coefficient_lines(s["coefficients"])
        if s["stick_slip"]:
            lines.append("  stick-slip        " + ", ".join(f"{w['from']} -> {w['to']} at {w['t']:.9g} s"
                                                         for w in s["stick_slip"]))
    if run is not first:
        e = run["energy"]
        sustained = (f", sustained contact from t = {run['t_sustained']:.6g} s"
                     if run["t_sustained"] is not None else "")
        joints = f" at the tip, {run['joint_impacts']} at the joints" if run["joint_impacts"] else ""
        lines += [
            f"whole run to t = {run['t_final']:.6g} s: {run['impacts']} impacts{joints}{sustained}",
            "  final angles      q = [" + ", ".join(f"{v:.6g}" for v in run["q_final"]) + "] rad",
            "  final speeds      u = [" + ", ".join(f"{v:.6g}" for v in run["u_final"]) + "] rad/s",
            f"  kinetic energy    T(0) = {run['T0']:.6g} J, T(end) = {run['Tf']:.6g} J",
            f"  energy budget     W_normal = {e['W_normal']:.4g} J, W_friction = {e['W_friction']:.4g} J, "
            f"W_gravity = {e['W_gravity']:.4g} J, residual = {e['residual']:.2g} J",
            f"  deepest dent      delta_r = {run['delta_r']:.6g} m, largest force P_m = {run['P_max']:.6g} N",
        ]
    if len(result.impacts) > 1:
        lines += ["impacts:"] + ["  " + line for line in _impacts_table(result)]
    lines.append(f"solver            {result.stats.get('nsteps', 0)} steps, {result.stats.get('nfev', 0)} RHS "
                 f"calls, {result.stats.get('wall_s', 0.0) * 1e3:.2f} ms")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
