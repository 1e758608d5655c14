"""The `impactgen` command line: its arguments, one sub-parser per command."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..bench import DEFAULT_PARTS
from ..errors import SceneError
from .generated import MAX_PREFIX_LENGTH

SET_HELP = "override a scene value (TOML), e.g. --set initial.u=[-0.1,-0.3] or --set initial.u[2]=-0.3"
SCENE_HELP = "a scene file (TOML), or the name of a shipped example (see 'impactgen examples')"


PREFIX_HELP = ("C name prefix of the generated files and functions (default model): a C identifier "
               f"from a letter, at most {MAX_PREFIX_LENGTH} characters")
FORCE_HELP = "write into --out even if it holds files impactgen did not write there (they are replaced)"


class _Parser(argparse.ArgumentParser):
    """argparse that raises SceneError (exit 2, one line) instead of printing usage."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise SceneError(None, f"{message} (see 'impactgen --help')")


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command (each with --help text, which a test checks)."""
    from .. import __version__
    p = _Parser(prog="impactgen", description="Generate fast C for an n-link pendulum impact "
                "and simulate it (MODEL: Hertz, Jackson-Green, restitution, friction).",
                epilog="Exit codes: 0 success, 2 bad input, 3 build failure, 4 solver failure.")
    p.add_argument("--version", action="version", version=f"impactgen {__version__}")
    p.add_argument("--links", type=int, metavar="N", help="generate and compile an N-link "
                   "steel chain (the paper's materials), write its scene, and print where the files are")
    p.add_argument("--out", type=Path, help="folder for the generated C and scene (with --links; "
                   "default generated/chainN)")
    p.add_argument("--prefix", default="model", help=PREFIX_HELP)
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
    cc.add_argument("--random", type=int, default=0, metavar="N", help="N random scenes (a third of them free chains)")
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
    cmp = sub.add_parser("compare", help="the rigid-body impact laws beside the compliant run, or the "
                                         "contact laws side by side (--laws)",
                         description="Simulate a scene's first impact, then give its pre-impact state to "
                                     "Newton's, Poisson's and Stronge's energetic law with the coefficients "
                                     "of restitution the compliant run produced (docs/impact-laws.md). With "
                                     "--laws: the first impact under each contact law (contact.model), with "
                                     "e_N, e_E, delta_max, the permanent set delta_r, P_max and the contact "
                                     "time; --speeds sweeps the normal impact speed (docs/fitting.md).")
    cmp.add_argument("scene", type=Path, help=SCENE_HELP)
    cmp.add_argument("--engine", choices=("c", "reference"), default="c", help="engine (default c)")
    cmp.add_argument("--laws", default=None, metavar="A,B,...",
                     help="contact laws to run side by side, e.g. three-phase,hertz (any contact.model)")
    cmp.add_argument("--speeds", default=None, metavar="LOW..HIGH[:N]",
                     help="sweep the tip's normal impact speed over N (default 10) speeds in m/s and draw "
                          "e_N, delta_max and the contact time against it (the scene's law without --laws)")
    cmp.add_argument("--out", type=Path, default=None, metavar="FIG",
                     help="the --speeds figure (PNG; default <scene name>-laws.png)")
    cmp.add_argument("--json", action="store_true", help="print the rows as one JSON object")
    cmp.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    cmp.add_argument("--debug", action="store_true", help="show tracebacks")

    fit = sub.add_parser("fit", help="fit scene parameters to measured impacts (least squares, with error bars)",
                         description="Fit scene keys to the impacts measured in DATA.csv by least squares with "
                                     "the compiled model (docs/fitting.md). DATA.csv has one row per impact: "
                                     "columns named by scene keys are its inputs (initial.u[2]), columns named "
                                     "as a sweep's result columns its measurements (delta_r, t_contact, "
                                     "u_final[2], coefficients.e_N), sigma:NAME their standard deviations.")
    fit.add_argument("scene", type=Path, help=SCENE_HELP)
    fit.add_argument("data", type=Path, metavar="DATA.csv", help="the measured impacts, one row each")
    fit.add_argument("--fit", required=True, metavar="KEY[=LOW..HIGH],...",
                     help="the scene keys to fit, each with optional bounds, e.g. "
                          "rod.yield_strength=3e8..1.1e9,contact.friction=0..1")
    fit.add_argument("--law", default=None, metavar="A,B,...",
                     help="contact laws (contact.model) to fit each and rank by AIC (default the scene's)")
    fit.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    fit.add_argument("--out", type=Path, default=None, metavar="FIG",
                     help="the figure of measured against fitted values (PNG; default <scene name>-fit.png)")
    fit.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    fit.add_argument("--debug", action="store_true", help="show tracebacks")

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
    bench.add_argument("--parts", default=",".join(DEFAULT_PARTS),
                       help=f"which benchmarks, comma-separated ({', '.join(DEFAULT_PARTS)}; batch, not by "
                            "default: a million sweep cases against the C loop, minutes)")
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

    mat = sub.add_parser("materials", help="list the named materials a scene may give (rod.material, surface.material)",
                         description="The named materials with their Young's modulus, Poisson's ratio, yield "
                         "strength, density and source. A scene names one with rod.material = \"NAME\" or "
                         "surface.material = \"NAME\"; a key given beside it overrides its value.")
    mat.add_argument("--json", action="store_true", help="print the table as one JSON object")
    mat.add_argument("--debug", action="store_true", help="show tracebacks")

    paper = sub.add_parser("paper-table", help="the paper's Table 2 computed again, beside the published values",
                           description="Run the paper's case for each omega20 of its Table 2 and print delta_r "
                           "and Delta T (with the physical friction and with friction_mode = \"frozen\") beside "
                           "the published values, with their relative errors (impactgen.paper.paper_table).")
    paper.add_argument("--engine", choices=("c", "reference"), default="c", help="engine (default c)")
    paper.add_argument("--json", action="store_true", help="print the rows as one JSON object")
    paper.add_argument("--debug", action="store_true", help="show tracebacks")

    gen = sub.add_parser("generate", help="generate and compile the C a scene needs")
    gen.add_argument("scene", type=Path, help=SCENE_HELP)
    gen.add_argument("--out", type=Path, help="folder for the C files (default generated/<name>)")
    gen.add_argument("--prefix", default="model", help=PREFIX_HELP)
    gen.add_argument("--force", action="store_true", help=FORCE_HELP)
    gen.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)
    gen.add_argument("--debug", action="store_true", help="show tracebacks")
    return p
