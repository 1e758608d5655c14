"""The `impactgen` command.

    impactgen --links N [--out DIR] [--prefix P]   generate and compile an N-link steel chain (+ its scene)
    impactgen generate SCENE [--out DIR] [--prefix P]   generate and compile what SCENE needs
    impactgen run SCENE|EXAMPLE [--engine c|reference] [--method M] [--json] [--set KEY=VALUE ...]
                  [--out DIR [--format parquet|csv]]
    impactgen examples [NAME [--out PATH]]     list the shipped example scenes, or copy one out
    impactgen crosscheck [--links 1-6] [--random N] [--seed S] [--json]
    impactgen plot SCENE [--out DIR] [--impact K | --window T0:T1] [--set KEY=VALUE ...]
    impactgen animate SCENE [--out FILE.gif|.mp4] [--fps N] [--seconds S] [--set KEY=VALUE ...]
    impactgen bench [--quick] [--out DIR] [--parts workprecision,rhs,scaling]
    impactgen stability [--quick] [--json] [--out DIR]
    impactgen compare SCENE [--engine c|reference] [--json] [--set KEY=VALUE ...]
    impactgen compare SCENE --laws A,B,... [--speeds LOW..HIGH[:N]] [--out FIG] [--json]
    impactgen sweep SCENE --vary KEY=SPEC [...] [--out DIR]
    impactgen fit SCENE DATA.csv --fit KEY[=LOW..HIGH],... [--law A,B,...] [--json] [--out FIG]
    impactgen fmu SCENE|--links N [--kind me|cs|both] [--out FILE.fmu]
    impactgen paper-table [--engine c|reference] [--json]   the paper's Table 2 beside the published values
    impactgen materials [--json]                the named materials and their sources

The package holds one job per module: `parser` (the arguments), `commands` (one function per
command), `report` (the text `impactgen run` prints) and `generated` (the folder `generate`
writes).

Exit codes: 0 success, 2 bad input, 3 build failure, 4 solver failure. Errors are one line
on stderr; --debug shows the traceback.
"""
from __future__ import annotations

import json
import os
import sys
import warnings
from contextlib import contextmanager
from typing import Iterator, Sequence

from ..errors import ImpactgenError, ImpactgenWarning, SceneError
from .report import format_summary, one_line

__all__ = ["main", "format_summary"]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the `impactgen` command on `argv` (sys.argv's by default) and return its exit code:
    every impactgen error ends in one line on stderr (with --json, also a JSON object)."""
    from .commands import COMMANDS, links
    from .parser import build_parser
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    wants_json = "--json" in argv
    try:
        args = build_parser().parse_args(argv)
        if args.command is not None:
            with _warnings_as_lines():
                return COMMANDS[args.command](args)
        if args.links is not None:
            return links(args)
        raise SceneError(None, "nothing to do: give a command (run, examples, generate, plot, ...) or "
                               "--links N; see 'impactgen --help'")
    except ImpactgenError as exc:
        if debug:
            raise
        message = one_line(str(exc))
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


@contextmanager
def _warnings_as_lines() -> Iterator[None]:
    """impactgen's warnings (a run's validity warnings, say) shown as the command's other
    messages are, one line on stderr, instead of Python's file:line form; other warnings as
    Python shows them."""
    with warnings.catch_warnings():
        python_shows = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, ImpactgenWarning):
                print(f"impactgen: warning: {one_line(str(message))}", file=sys.stderr)
            else:
                python_shows(message, category, filename, lineno, file, line)
        warnings.showwarning = show
        yield
