"""The `impactgen` command.

    impactgen --links N [--out DIR]            generate and compile an N-link steel chain
    impactgen generate SCENE [--out DIR]       generate and compile what SCENE needs
    impactgen run SCENE [--engine c|reference] [--json] [--set KEY=VALUE ...]

Exit codes: 0 success, 2 bad input, 3 build failure, 4 solver failure. Errors are one line
on stderr; --debug shows the traceback.
"""
from __future__ import annotations

import argparse
import json
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
    run.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. --set initial.u=[-0.1,-0.3]")
    run.add_argument("--debug", action="store_true", help="show tracebacks")

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
        _parser().print_help(sys.stderr)
        return 2
    except ImpactgenError as exc:
        if debug:
            raise
        print(f"impactgen: error: {exc}", file=sys.stderr)
        if wants_json:
            print(json.dumps({"status": "error", "exit_code": exc.exit_code, "message": str(exc)}))
        return exc.exit_code
    except KeyboardInterrupt:
        print("impactgen: interrupted", file=sys.stderr)
        return 130


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
    result = impactgen.simulate(scene, engine=args.engine)
    if args.json:
        print(json.dumps(result.to_json_dict()))
        return 0
    print(format_summary(result))
    return 0


def format_summary(result) -> str:
    s = result.summary
    e = s["energy"]
    lines = [f"{result.scene.name} ({result.engine} engine): {result.status}"
             + (f", {result.message}" if result.message else "")]
    lines.append("phases: " + ", ".join(f"{p.phase} [{p.t0:.4g}, {p.t1:.4g}] s" for p in result.phases))
    if s["impacts"]:
        lines += [
            f"max deformation   delta_m = {s['delta_max']:.4g} m",
            f"permanent         delta_r = {s['delta_r']:.4g} m",
            f"max force         P_m     = {s['P_max']:.4g} N",
            f"unloading radius  R_res   = {s['R_res']:.4g} m",
            f"impact duration           = {s['t_contact']:.4g} s",
        ]
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
