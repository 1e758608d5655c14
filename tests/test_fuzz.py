"""Fuzzing: generated scenes and argument lists end in success or in our own exit codes
2, 3, 4 with a one-line message, never in a traceback, a crash or a hang."""
from __future__ import annotations

import contextlib
import io
import json
import math
import os
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

import impactgen
from impactgen import cli
from impactgen.errors import SceneError
from impactgen.scene import SCHEMA
from conftest import PAPER

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

PAPER_DICT = tomllib.loads(PAPER.read_text())
KEYS = [f"{s}.{k}" if s else k for s, keys in SCHEMA.items() for k in keys]
FUZZ_DIR = Path(tempfile.mkdtemp(prefix="impactgen-fuzz-"))

extreme_floats = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e300, 1e-12, 0.49999, 0.5, -1.0, 2.0, 1e6, 1e12]),
)
values = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20), extreme_floats,
              st.text(max_size=12), st.sampled_from(["initial", "separation", "bdf", "hertz", "coulomb"])),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=6,
)


def _without_none(v):
    if isinstance(v, dict):
        return {k: _without_none(x) for k, x in v.items() if x is not None}
    if isinstance(v, list):
        return [_without_none(x) for x in v if x is not None]
    return v


@st.composite
def mutated_scenes(draw):
    raw = json.loads(json.dumps(PAPER_DICT))
    for _ in range(draw(st.integers(1, 4))):
        key = draw(st.one_of(st.sampled_from(KEYS), st.text(min_size=1, max_size=10)))
        section, _, name = key.rpartition(".")
        target = raw.setdefault(section, {}) if section else raw
        if not isinstance(target, dict):
            continue
        if draw(st.booleans()) and name in target:
            del target[name]
        else:
            target[name] = _without_none(draw(values))
    return raw


@settings(max_examples=1600, deadline=None, suppress_health_check=list(HealthCheck))
@given(mutated_scenes())
def test_scene_loader_accepts_or_names_the_problem(raw):
    try:
        scene = impactgen.scene_from_dict(raw)
    except SceneError as exc:
        message = str(exc)
        assert message and "\n" not in message
        return
    assert scene.n >= 1 and all(math.isfinite(v) for v in scene.chain.length + scene.chain.mass)


@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.one_of(st.binary(max_size=200), st.text(max_size=200).map(str.encode)))
def test_scene_files_of_any_content_fail_cleanly(content):
    path = FUZZ_DIR / "scene.toml"
    path.write_bytes(content)
    try:
        impactgen.load_scene(path)
    except SceneError as exc:
        assert "\n" not in str(exc).strip() or "TOML" in str(exc)


# ----------------------------------------------------------------------------- the CLI

set_values = st.one_of(
    st.sampled_from(["1", "0", "-1", "2", "1e300", "nan", "inf", "-inf", "[1.0]", "[1.0, 2.0]",
                     "[-0.1, -0.3]", '"x"', "hertz", "coulomb", "adams", "[]", "{a=1}", "[[1]]",
                     "1e-300", "true", "0.5", "separation"]),
    st.text(max_size=8),
)


@st.composite
def argument_lists(draw):
    command = draw(st.sampled_from(["run", "run", "run", "generate", "links", "crosscheck", "junk"]))
    if command == "links":
        return ["--links", draw(st.sampled_from(["0", "1", "2", "61", "-3", "x", "1e3", ""]))] + \
            draw(st.sampled_from([[], ["--prefix", "bad name"], ["--prefix", "int"], ["--out", "/proc/forbidden"]]))
    if command == "crosscheck":  # only option values that must be refused (the valid ones are slow)
        return ["crosscheck"] + draw(st.sampled_from([["--links", "x"], ["--links", "0"], ["--rtol", "2"],
                                                      ["--method", "Euler"], ["--random", "-1"], ["--tol", "0"]]))
    if command == "junk":  # --debug asks for the traceback (Hypothesis finds it among the source's strings)
        return draw(st.lists(st.text(max_size=10).filter(lambda a: a != "--debug"), max_size=4))
    scene = draw(st.sampled_from([str(PAPER), str(PAPER), "missing.toml", str(FUZZ_DIR)]))
    args = [command, scene]
    for _ in range(draw(st.integers(0, 4))):
        key = draw(st.one_of(st.sampled_from(KEYS), st.text(max_size=8)))
        args += ["--set", f"{key}={draw(set_values)}"]
    if command == "run":
        args += draw(st.sampled_from([[], ["--json"], ["--engine", "reference"], ["--engine", "x"], ["--method", "RK45"]]))
        # bound the work a valid run can do
        args += ["--set", "solver.max_steps=3000", "--set", "solver.t_end=\"separation\"",
                 "--set", "solver.t_max=0.01", "--set", "chain.links=2"]
    else:
        args += ["--out", str(FUZZ_DIR / "out"), "--set", "chain.links=2"]
    return args


@contextlib.contextmanager
def _inside(folder: Path):
    """Run with `folder` as the working directory: default outputs must not land in the repo."""
    before = os.getcwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(before)


@settings(max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))
@given(argument_lists())
@example(["-\x1e"])  # a record separator, which str.splitlines takes for a line break
def test_cli_ends_in_success_or_our_exit_codes(argv):
    out, err = io.StringIO(), io.StringIO()
    with _inside(FUZZ_DIR), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    assert code in (0, 2, 3, 4), (argv, code, err.getvalue())
    stderr = err.getvalue()
    assert "Traceback" not in stderr
    if code != 0:
        lines = stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("impactgen: error: "), (argv, stderr)
    elif "--json" in argv:
        json.loads(out.getvalue())


# ----------------------------------------------------------------------------- valid extremes

def log_uniform(lo: float, hi: float):
    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: 10.0 ** e)


@st.composite
def extreme_scenes(draw):
    n = draw(st.integers(1, 2))

    def material() -> dict:
        E = draw(log_uniform(1e3, 1e14))
        return {"E": E, "nu": draw(st.floats(-0.99, 0.499)),
                "yield_strength": E * draw(log_uniform(1e-6, 0.9))}  # a yield strain below 1

    raw = {
        "name": "extreme",
        "chain": {"links": n, "length": [draw(log_uniform(1e-3, 1e3)) for _ in range(n)],
                  "mass": [draw(log_uniform(1e-6, 1e6)) for _ in range(n)],
                  "gravity": draw(st.sampled_from([0.0, 9.81, 1e3]))},
        "rod": {**material(), "tip_radius": draw(log_uniform(1e-7, 1.0))},
        "surface": {**material(), "height": "initial"},
        "contact": {"model": draw(st.sampled_from(["three-phase", "hertz"])),
                    "friction": draw(st.sampled_from([0.0, 0.2, 5.0])),
                    "friction_eps": draw(log_uniform(1e-12, 1.0))},
        "initial": {"q": [draw(st.floats(-math.pi, math.pi)) for _ in range(n)],
                    "u": [draw(st.floats(-1e3, 1e3)) for _ in range(n)]},
        "solver": {"max_steps": 3000, "t_max": 0.01, "method": draw(st.sampled_from(["bdf", "adams"]))},
    }
    try:
        return impactgen.scene_from_dict(raw)
    except impactgen.SceneError as exc:  # a chain that starts below the surface is not a scene
        assume(exc.key != "initial.q")
        raise


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(extreme_scenes())
def test_extreme_valid_scenes_end_in_a_finite_result_or_a_solver_error(scene):
    result = impactgen.simulate(scene)
    if result.status == "failed":  # a failure is a result: its reason, and finite samples
        assert "solver failed" in result.message and "\n" not in result.message
        return
    s = result.summary
    assert result.status in ("ok", "no-impact")
    for key in ("T0", "Tf", "delta_T", "delta_max", "delta_r", "P_max", "t_contact"):
        assert math.isfinite(s[key]), key
    assert all(math.isfinite(v) for v in s["u_final"])
