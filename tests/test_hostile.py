"""What a hostile user tried (issue 37): each input must end in a correct result or in one
clear line of the project's error family, never in a silent wrong answer or a foreign
exception. docs/safety.md lists the classes and what each gets."""
from __future__ import annotations

import numpy as np
import pytest

import impactgen
from impactgen.errors import ImpactgenError, SceneError


# -- 1. silent wrong answers: dense output and t_eval -----------------------------------------

@pytest.fixture(scope="module")
def bouncing_dense():
    """The issue's run: its method "auto" hands segments from the explicit pair to BDF."""
    scene = impactgen.load_scene("bouncing", overrides={"solver.t_end": 5.0})
    return impactgen.simulate(scene, rtol=1e-8, atol=1e-10, dense_output=True)


def test_dense_output_is_finite_where_the_pair_hands_over_to_bdf(bouncing_dense):
    r = bouncing_dense
    assert r.stats["nstiff"] >= 1  # the pair handed a segment to BDF
    inside = 0.5 * (r.t[:-1] + r.t[1:])  # a time inside every step, the handed-over one among them
    assert np.isfinite(r.sol(inside)).all()
    times = np.linspace(0.0, r.t[-1], 20001)
    assert np.isfinite(r.sol(times)).all()


def test_dense_output_reproduces_every_step(bouncing_dense):
    """Each step's polynomial ends at that step's sample: no step is left without one."""
    r = bouncing_dense
    np.testing.assert_allclose(r.sol(r.t[1:]), r.y[:, 1:], rtol=1e-7, atol=1e-9)


def test_t_eval_around_a_handed_over_step_agrees_with_dense_output(bouncing_dense):
    r0 = bouncing_dense
    k = int(np.argmin(abs(r0.t - 2.530157208020547)))
    ends = r0.t[k - 3:k + 4]
    times = np.sort(np.concatenate([ends, 0.5 * (ends[1:] + ends[:-1])]))
    r = impactgen.simulate(r0.scene, rtol=1e-8, atol=1e-10, t_eval=times)
    assert np.isfinite(r.y).all()
    np.testing.assert_allclose(r.y, r0.sol(times), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_dense_output_outside_the_run_is_refused(paper_scene, engine):
    r = impactgen.simulate(paper_scene, engine=engine, dense_output=True)
    t_final = float(r.t[-1])
    assert np.isfinite(r.sol(0.0)).all() and np.isfinite(r.sol(t_final)).all()
    for bad in (-1.0, t_final + 1.0, [0.0, t_final * 2], float("nan"), np.inf, None):
        with pytest.raises(SceneError, match=r"outside the run \[0, "):
            r.sol(bad)
    with pytest.raises(SceneError, match="expected a time"):
        r.sol("a")


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_t_eval_after_the_end_is_dropped_with_a_warning(paper_scene, engine):
    r = impactgen.simulate(paper_scene, engine=engine, t_eval=[0.0, 1e-4, 1.0])
    assert len(r.t) == 2
    t_final = float(r.trajectory.t[-1])
    notes = [w for w in r.warnings if "t_eval" in w]
    assert len(notes) == 1
    assert "1 of the 3 t_eval times" in notes[0] and f"{t_final:.6g}" in notes[0]
    full = impactgen.simulate(paper_scene, engine=engine, t_eval=[0.0, 1e-4])
    assert not [w for w in full.warnings if "t_eval" in w]


# -- 3. exceptions that are not ours: each is one line of impactgen.errors -------------------

def _paper():
    return impactgen.load_scene("paper")


ENTRY_CALLS = {  # what a hostile caller passed, and a word of the one line it must get
    "simulate(None)": (lambda: impactgen.simulate(None), "simulate() takes a Scene"),
    "simulate({...})": (lambda: impactgen.simulate({"name": "x"}), "simulate() takes a Scene"),
    "simulate(3)": (lambda: impactgen.simulate(3), "simulate() takes a Scene"),
    "load_scene(None)": (lambda: impactgen.load_scene(None), "load_scene takes a scene file"),
    "load_scene(3)": (lambda: impactgen.load_scene(3), "load_scene takes a scene file"),
    "load_scene(b'paper')": (lambda: impactgen.load_scene(b"paper"), "load_scene takes a scene file"),
    "overrides rod.E=10**400": (lambda: impactgen.load_scene("paper", overrides={"rod.E": 10**400}),
                                "beyond what a float holds"),
    "overrides {1: 2}": (lambda: impactgen.load_scene("paper", overrides={1: 2}), "not a string"),
    "overrides [(key, value)]": (lambda: impactgen.load_scene("paper", overrides=[("rod.E", 1e11)]),
                                 "overrides are a mapping"),
    "overrides 'rod.E=1'": (lambda: impactgen.load_scene("paper", overrides="rod.E=1"), "overrides are a mapping"),
    "replace('rod.E=1')": (lambda: _paper().replace("rod.E=1"), "overrides are a mapping"),
    "replace([1, 2])": (lambda: _paper().replace([1, 2]), "overrides are a mapping"),
    "replace(rod_E=1)": (lambda: _paper().replace(rod_E=1), "a scene key goes in overrides"),
    "replace(rod=5)": (lambda: _paper().replace(rod=5), "expected a Material"),
    "replace({'chain.links': 10**400})": (lambda: _paper().replace({"chain.links": 10**400}), "about 400 digits"),
    "load_scene('/dev/zero')": (lambda: impactgen.load_scene("/dev/zero"), "not a file"),
    "scene_from_dict(None)": (lambda: impactgen.scene_from_dict(None), "a scene is a mapping"),
    "sweep(None)": (lambda: impactgen.sweep(None, vary={"initial.u[2]": [-0.3]}), "load_scene takes"),
}


@pytest.mark.parametrize("call", list(ENTRY_CALLS))
def test_a_hostile_argument_is_one_line_of_our_errors(call):
    function, words = ENTRY_CALLS[call]
    with pytest.raises(ImpactgenError) as caught:
        function()
    message = str(caught.value)
    assert words in message and "\n" not in message


def test_simulate_takes_an_example_name_as_load_scene_does(paper_scene):
    by_name = impactgen.simulate("paper")
    assert by_name.summary["delta_r"] == impactgen.simulate(paper_scene).summary["delta_r"]


def _cli(*args, env=None, user=None):
    import os
    import subprocess
    import sys
    command = [sys.executable, "-m", "impactgen.cli", *args]
    if user is not None:
        command = ["setpriv", f"--reuid={user}", f"--regid={user}", "--clear-groups", *command]
    return subprocess.run(command, capture_output=True, text=True, timeout=300,
                          env={**os.environ, **(env or {})})


def test_a_toml_file_nested_500_deep_is_exit_2(tmp_path):
    deep = tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 500 + "]" * 500 + "\n")
    res = _cli("run", str(deep))
    assert res.returncode == 2, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and "nested too deeply" in res.stderr
    res = _cli("run", "paper", "--set", "rod.E=" + "[" * 500 + "]" * 500)
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1, res.stderr


def test_a_read_only_cache_without_the_model_is_exit_3_naming_the_folder():
    import os
    import shutil
    import sys
    import tempfile
    from pathlib import Path
    user = None
    if os.geteuid() == 0:  # root writes anywhere: run as nobody
        if not sys.platform.startswith("linux") or shutil.which("setpriv") is None:
            pytest.skip("needs setpriv to drop root")
        user = 65534
    top = Path(tempfile.mkdtemp(prefix="impactgen-read-only-"))  # reachable by that user (pytest's is not)
    try:
        top.chmod(0o755)
        cache = top / "cache"
        cache.mkdir(mode=0o555)
        cache.chmod(0o555)
        res = _cli("run", "paper", env={"IMPACTGEN_CACHE_DIR": str(cache)}, user=user)
    finally:
        shutil.rmtree(top)
    assert res.returncode == 3, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert str(cache) in res.stderr and "IMPACTGEN_CACHE_DIR" in res.stderr and "lacks this model" in res.stderr


def test_a_rigid_surface_of_any_modulus_gives_the_same_impact_in_both_engines():
    """Eq. 7 is computed as a sum of compliances: a surface of E = 1e300 Pa is a rigid one
    (E* of the rod alone), not an overflow; two such moduli leave no contact constants
    double precision can hold, and both engines say so, naming the modulus."""
    rigid = impactgen.load_scene("paper", {"surface.E": 1e300, "solver.sustained_contact": False})
    c, ref = impactgen.simulate(rigid), impactgen.simulate(rigid, engine="reference")
    assert c.status == ref.status == "ok"
    assert c.summary["delta_max"] == pytest.approx(ref.summary["delta_max"], rel=1e-6)
    assert isinstance(c.warnings, list)
    both = rigid.replace({"rod.E": 1e300})
    for engine in ("c", "reference"):
        with pytest.raises(SceneError, match="double precision") as err:
            impactgen.simulate(both, engine=engine)
        assert err.value.key == "rod.E"


# -- issue 45: messages quote a bounded excerpt of what they refuse ---------------------------

HUGE = 2_000_000  # characters of a hostile value


@pytest.mark.parametrize("call", [
    "scene name", "override key", "override value", "simulate engine", "simulate method", "t_eval word",
    "sweep vary key", "sweep vary spec", "example name", "dense output time",
])
def test_a_message_quotes_an_excerpt_of_a_huge_value(call, paper_scene, tmp_path):
    from impactgen.errors import EXCERPT_CHARS, MESSAGE_CHARS
    big = "n" * HUGE
    calls = {
        "scene name": lambda: paper_scene.replace({"name": big}),
        "override key": lambda: impactgen.load_scene("paper", overrides={big: 1.0}),
        "override value": lambda: impactgen.load_scene("paper", overrides={"solver.method": big}),
        "simulate engine": lambda: impactgen.simulate(paper_scene, engine=big),
        "simulate method": lambda: impactgen.simulate(paper_scene, method=big),
        "t_eval word": lambda: impactgen.simulate(paper_scene, t_eval=[big]),
        "sweep vary key": lambda: impactgen.sweep(paper_scene, vary={big: [1.0]}),
        "sweep vary spec": lambda: impactgen.sweep(paper_scene, vary={"initial.u[2]": big}),
        "example name": lambda: impactgen.load_scene(big[:200]),
        "dense output time": lambda: impactgen.simulate(paper_scene, dense_output=True).sol(big),
    }
    with pytest.raises(ImpactgenError) as caught:
        calls[call]()
    message = str(caught.value)
    assert "\n" not in message and len(message) <= MESSAGE_CHARS + 200, len(message)
    assert "n" * (EXCERPT_CHARS + 1) not in message


def test_the_excerpt_names_the_size_of_what_it_cuts():
    from impactgen.errors import excerpt
    assert excerpt("abc") == "'abc'"
    assert excerpt("x" * 10_000).endswith("... (10000 characters)")
    assert excerpt(list(range(10**6))).endswith("(1000000 items)")
    assert excerpt(np.float64(-1.5)) == "-1.5"
    assert len(excerpt(np.zeros(10**7))) < 200


def test_the_command_line_does_not_repeat_a_2_mb_scene_name(tmp_path):
    import re
    from pathlib import Path
    text = (Path(impactgen.__file__).parents[2] / "scenes" / "paper.toml").read_text()
    scene = tmp_path / "big.toml"
    scene.write_text(re.sub(r"^name = .*$", f'name = "{"n" * HUGE}"', text, count=1, flags=re.M))
    res = _cli("run", str(scene))
    assert res.returncode == 2
    assert len(res.stderr) < 1000 and len(res.stderr.strip().splitlines()) == 1
    assert f"({HUGE + 2} characters)" in res.stderr  # the quote's size is named


# -- issue 45: a sweep's arguments are checked before any case runs; workers are capped -------

SWEEP_VARY = {"initial.u[2]": "uniform(-0.3,-0.2)"}
BAD_SWEEP_ARGUMENTS = {  # what a hostile caller passed, and the argument the one line names
    "seed=-1": (dict(seed=-1), "--seed"),
    "seed='x'": (dict(seed="x"), "--seed"),
    "seed=2.5": (dict(seed=2.5), "--seed"),
    "seed=True": (dict(seed=True), "--seed"),
    "seed=None": (dict(seed=None), "--seed"),
    "trajectories='all'": (dict(trajectories="all"), "--trajectories"),
    "trajectories=[0.5]": (dict(trajectories=[0.5]), "--trajectories"),
    "trajectories=[None]": (dict(trajectories=[None]), "--trajectories"),
    "trajectories={0: 1}": (dict(trajectories={0: 1}), "--trajectories"),
    "trajectories=2.0": (dict(trajectories=2.0), "--trajectories"),
    "out=5": (dict(out=5), "--out"),
    "out=['a']": (dict(out=["a"]), "--out"),
    "out=''": (dict(out=""), "--out"),
    "progress=5": (dict(progress=5), "progress"),
    "progress='bar'": (dict(progress="bar"), "progress"),
    "workers=0": (dict(workers=0), "--workers"),
    "workers=-3": (dict(workers=-3), "--workers"),
    "workers=2.0": (dict(workers=2.0), "--workers"),
    "workers='all'": (dict(workers="all"), "--workers"),
    "scheduler=5": (dict(scheduler=5), "--scheduler"),
    "random=2.5": (dict(random=2.5), "--random"),
}


@pytest.mark.parametrize("call", list(BAD_SWEEP_ARGUMENTS))
def test_a_bad_sweep_argument_is_refused_before_any_case_runs(call, monkeypatch):
    from impactgen.sweep import chunk as sweep_chunk
    ran = []
    monkeypatch.setattr(sweep_chunk, "simulate", lambda *a, **k: ran.append(1))  # no case may start
    arguments, key = BAD_SWEEP_ARGUMENTS[call]
    arguments = {"random": 2, **arguments}
    with pytest.raises(SceneError) as caught:
        impactgen.sweep("paper", vary=SWEEP_VARY, workers=arguments.pop("workers", 1), **arguments)
    assert caught.value.key == key and "\n" not in str(caught.value)
    assert not ran


@pytest.mark.parametrize("asked, cases", [(10**6, 1), (10**6, 3), (48, 2), (10**18, 5)])
def test_workers_beyond_the_limit_are_said_not_started(asked, cases, monkeypatch):
    """A sweep starts at most one worker per case and per usable core, whatever is asked:
    workers=10**6 had forked until the kernel's out-of-memory killer ended the driver."""
    from impactgen.sweep import execute, run as sweep_run
    started = []

    def pool(run_chunk, payload, options, todo, workers):
        started.append(workers)
        return execute.in_process(run_chunk, payload, options, todo)
    monkeypatch.setattr(execute, "process_pool", pool)
    limit = sweep_run.worker_limit(cases)
    assert limit <= min(cases, sweep_run.usable_cores())
    with pytest.warns(impactgen.errors.ImpactgenWarning, match=f"--workers {asked}: starting {limit} worker") as said:
        table = impactgen.sweep("paper", vary={"initial.u[2]": list(np.linspace(-0.3, -0.2, cases))}, workers=asked)
    assert len(table) == cases and (table["status"] == "ok").all()
    assert started in ([], [limit]) and limit < asked  # one process in this process, or a pool of `limit`
    assert said[0].filename == __file__  # the warning points at the caller's line


def test_workers_within_the_limit_start_quietly():
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        table = impactgen.sweep("paper", vary={"initial.u[2]": [-0.3, -0.2]}, workers=1)
    assert len(table) == 2


@pytest.mark.parametrize("args, words", [
    (["--random", "2", "--seed", "-1"], "--seed: expected a whole number >= 0"),
    (["--random", "2", "--workers", "0"], "--workers: expected a whole number"),
])
def test_a_bad_sweep_argument_on_the_command_line_is_exit_2(args, words):
    res = _cli("sweep", "paper", "--vary", "initial.u[2]=uniform(-0.3,-0.2)", *args, "--quiet")
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr and words in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_a_command_line_sweep_of_2_cases_asked_48_workers_starts_at_most_2(tmp_path):
    res = _cli("sweep", "paper", "--vary", "initial.u[2]=[-0.3,-0.2]", "--workers", "48", "--out",
               str(tmp_path / "D"), "--quiet")
    assert res.returncode == 0, res.stderr
    assert "--workers 48: starting" in res.stderr and "Traceback" not in res.stderr
    started = int(res.stderr.split("starting ")[1].split()[0])
    assert 1 <= started <= 2


# -- issue 45: a relative cache folder ---------------------------------------------------------

@pytest.mark.parametrize("given", ["relcache", "./a/../relcache", "relcache/", "~"])
def test_the_cache_root_is_absolute_whatever_the_variable_says(given, tmp_path, monkeypatch):
    import os
    from pathlib import Path
    from impactgen.build import cache_root
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("IMPACTGEN_CACHE_DIR", given)
    root = cache_root()
    assert root.is_absolute()
    assert root == Path(os.path.expanduser(given)).resolve() if given == "~" else root == tmp_path / "relcache"


def test_a_relative_xdg_cache_home_is_ignored_as_the_xdg_spec_says(tmp_path, monkeypatch):
    from pathlib import Path
    from impactgen.build import cache_root
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("IMPACTGEN_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", "relative")
    assert cache_root() == Path.home() / ".cache" / "impactgen"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_root() == tmp_path / "xdg" / "impactgen"


def test_a_run_with_a_relative_cache_folder_builds(tmp_path):
    import subprocess
    import sys
    res = subprocess.run([sys.executable, "-m", "impactgen.cli", "run", "paper", "--json"], capture_output=True,
                         text=True, timeout=600, cwd=tmp_path,
                         env={**__import__("os").environ, "IMPACTGEN_CACHE_DIR": "relcache"})
    assert res.returncode == 0, res.stderr
    assert any((tmp_path / "relcache").iterdir())


# -- issue 45: t_eval takes real times only, of a count that fits in memory; sol unasked -------

NOT_REAL_TIMES = {
    "complex list": [0.0, 1e-4 + 0j],
    "complex array": np.array([0.0, 1e-4 + 1e-9j]),
    "strings of numbers": ["0.0", "1e-4"],
    "a string array": np.array(["0.0", "1e-4"]),
    "one string in floats": [0.0, "1e-4"],
    "bools": [False, True],
    "a bool array": np.array([False, True]),
    "a bool in floats": [0.0, True],
    "a numpy bool in floats": (0.0, np.bool_(True)),
    "an object array with a bool": np.array([0.0, True], dtype=object),
    "None in floats": [0.0, None],
    "bytes": [b"0.0"],
    "datetimes": np.array(["2020-01-01"], dtype="datetime64[D]"),
    "a bare string": "0.0001",
    "a bare bool": True,
    "a set": {0.0, 1e-4},
    "a dict": {0.0: 1e-4},
    "a masked time": np.ma.masked_array([0.0, 1e-4], mask=[False, True]),
}


@pytest.mark.parametrize("name", list(NOT_REAL_TIMES))
@pytest.mark.parametrize("engine", ["c", "reference"])
def test_t_eval_of_what_is_not_a_real_time_is_refused(name, engine, paper_scene):
    with pytest.raises(SceneError) as caught:
        impactgen.simulate(paper_scene, engine=engine, t_eval=NOT_REAL_TIMES[name])
    assert caught.value.key == "t_eval" and "\n" not in str(caught.value)


def test_t_eval_of_real_numbers_in_any_container_still_works(paper_scene):
    from fractions import Fraction
    expected = impactgen.simulate(paper_scene, t_eval=[0.0, 1e-4]).y
    for times in ([0, 1e-4], (0.0, 1e-4), np.array([0.0, 1e-4], dtype=object), [0, Fraction(1, 10000)],
                  [np.float64(0.0), np.float64(1e-4)], np.array([0, 1]) * 1e-4):
        np.testing.assert_array_equal(impactgen.simulate(paper_scene, t_eval=times).y, expected)


@pytest.mark.parametrize("times", [np.broadcast_to(0.0, (10**9,)), range(10**10)])
def test_a_t_eval_beyond_memory_is_refused_up_front_naming_the_size(times, paper_scene):
    """10^8 times had run 15 s and died of numpy's MemoryError; these cost no memory to pass
    (a broadcast view, a range) and would need hundreds of GB of samples."""
    with pytest.raises(SceneError, match=r"times need about [0-9.]+ [kMGT]B for their samples, more than the "
                                         r"[0-9.]+ [kMGT]?B of memory available") as caught:
        impactgen.simulate(paper_scene, t_eval=times)
    assert caught.value.key == "t_eval"


def test_the_memory_estimate_grows_with_the_chain_and_refuses_at_the_limit(paper_scene, monkeypatch):
    from impactgen import engines
    chain6 = impactgen.load_scene("falling-chain")
    assert engines.sample_bytes(chain6) > engines.sample_bytes(paper_scene) > 8 * 20
    times = np.linspace(0.0, 1e-4, 1000)
    monkeypatch.setattr(engines, "available_memory", lambda: 1000 * engines.sample_bytes(paper_scene))
    assert len(impactgen.simulate(paper_scene, t_eval=times).t) == 1000  # just fits
    monkeypatch.setattr(engines, "available_memory", lambda: 999 * engines.sample_bytes(paper_scene))
    with pytest.raises(SceneError, match="1000 times need about"):
        impactgen.simulate(paper_scene, t_eval=times)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_dense_output_not_asked_for_says_how_to_ask(engine, paper_scene):
    r = impactgen.simulate(paper_scene, engine=engine)
    assert not r.sol
    for t in (1e-4, [0.0, 1e-4], None):
        with pytest.raises(SceneError, match=r"no dense output \(it was not asked for\): "
                                             r"simulate\(\.\.\., dense_output=True\)"):
            r.sol(t)
    import pickle
    assert not pickle.loads(pickle.dumps(r)).sol


# -- issue 45: the rules across parameters are one list, for the scene and the generated C -----

def _unchecked(scene, key: str, value: float):
    """`scene` with one material value changed and no checks run (as a caller of the C model,
    or an FMU importer, can have it)."""
    import dataclasses
    section, field = key.split(".")
    field = {"yield_strength": "yield_strength", "E": "E"}[field]
    material = dataclasses.replace(getattr(scene, section), **{field: value})
    return dataclasses.replace(scene, **{section: material})


def _breaking_values(scene):
    from impactgen.codegen.parameters import BY_NAME, RULES
    for rule in RULES:
        low, high = BY_NAME[rule.below].value(scene), BY_NAME[rule.above].value(scene)
        yield rule, rule.key, high  # at the bound
        yield rule, rule.key, 3.0 * high
        yield rule, rule.above_key, 0.9 * low


def test_load_scene_refuses_what_the_rule_list_refuses_in_the_same_words(paper_scene):
    from impactgen.codegen.parameters import broken_rule
    assert broken_rule(paper_scene) is None
    for rule, key, value in _breaking_values(paper_scene):
        with pytest.raises(SceneError) as refused:
            impactgen.load_scene("paper", overrides={key: value})
        found = broken_rule(_unchecked(paper_scene, key, value))
        assert found is not None and found[0] == rule
        assert refused.value.key == rule.key and str(refused.value) == f"{rule.key}: {found[1]}"


def test_the_c_model_refuses_what_the_rule_list_refuses(paper_scene):
    """The generated start check (`model_derive`, which an FMU's initialization runs) prints
    the same rule list: values that never passed load_scene are refused, naming the key."""
    from impactgen.build import compile_model
    from impactgen.engines import model_spec
    from impactgen.model_params import fill_params
    model = compile_model(model_spec(paper_scene))
    fill_params(model, paper_scene)
    for rule, key, value in _breaking_values(paper_scene):
        with pytest.raises(SceneError, match="is not physical") as refused:
            fill_params(model, _unchecked(paper_scene, key, value))
        assert refused.value.key == rule.key
