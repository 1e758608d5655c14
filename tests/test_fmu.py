"""FMI 2.0 export, checked by an importer nobody here wrote: FMPy validates and simulates the
FMUs (Model Exchange with FMPy's own CVODE, Co-Simulation with CVODE inside), and they agree
with `impactgen run`."""
from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

import impactgen
from impactgen.fmu import build_fmu

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

RTOL = 1e-10
CASES = {"paper": 1e-3, "chain3-free-flight": 0.486}  # scene: stop time past its first impact


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("fmu")
    return {name: build_fmu(impactgen.load_scene(name), folder / f"{name}.fmu") for name in CASES}


class EventLog:
    """The FMU's logEvents messages, "t = ...: from -> to", as (t, from, to)."""

    def __init__(self):
        self.events: list[tuple[float, str, str]] = []
        self.errors: list[str] = []

    def __call__(self, env, instance, status, category, message):
        text = message.decode()
        if category == b"logEvents":
            t, _, change = text.partition(": ")
            a, _, b = change.partition(" -> ")
            self.events.append((float(t.split("=")[1]), a, b))
        elif status >= 3:
            self.errors.append(text)


def run_fmu(path: Path, kind: str, stop: float, interval: float | None = None, **kw):
    log = EventLog()
    md = read_model_description(str(path))
    wanted = [v.name for v in md.modelVariables if v.causality == "output" or v.name[0] in "quW"]
    result = simulate_fmu(str(path), fmi_type=kind, stop_time=stop, relative_tolerance=RTOL,
                          output_interval=interval or stop / 100, debug_logging=True, logger=log,
                          output=wanted, **kw)
    return result, log


def test_fmu_validates_and_exports_only_fmi2(fmus, tmp_path):
    path = fmus["paper"]
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    names = {v.name for v in md.modelVariables}
    assert {"chain.length[1]", "rod.E", "contact.friction", "initial.u[2]", "surface.height_initial",
            "q[1]", "u[2]", "W_normal", "delta", "F", "F_f", "v_B[1]", "v_B[2]", "T[1]", "T", "V",
            "phase", "impacts", "delta_max", "delta_r", "P_max"} <= names
    with zipfile.ZipFile(path) as z:
        so = [n for n in z.namelist() if n.startswith("binaries/") and n.endswith(".so")][0]
        z.extract(so, tmp_path)
        assert "sources/buildDescription.xml" in z.namelist()
    binary = str(tmp_path / so)
    symbols = subprocess.run(["nm", "-D", "--defined-only", binary], capture_output=True, text=True,
                             check=True).stdout.split("\n")
    exported = [line.split()[-1] for line in symbols if line.strip()]
    assert exported and all(name.startswith("fmi2") for name in exported), exported
    if shutil.which("ldd"):
        assert "sundials" not in subprocess.run(["ldd", binary], capture_output=True, text=True).stdout


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
@pytest.mark.parametrize("name", list(CASES))
def test_fmu_agrees_with_impactgen_run(fmus, name, kind):
    stop = CASES[name]
    result, log = run_fmu(fmus[name], kind, stop)
    assert log.errors == []
    run = impactgen.simulate(impactgen.load_scene(name), t_end=stop)
    impact = run.impacts[0]
    last = result[-1]
    for field in ("delta_max", "delta_r", "P_max"):
        assert last[field] == pytest.approx(getattr(impact, field), rel=1e-6), field
    n = run.scene.n
    for i in range(n):
        assert last[f"u[{i + 1}]"] == pytest.approx(run.u[i, -1], rel=1e-6)
        assert last[f"q[{i + 1}]"] == pytest.approx(run.q[i, -1], rel=1e-6)
    assert last["W_normal"] == pytest.approx(run.W_normal[-1], rel=1e-6)
    assert last["W_friction"] == pytest.approx(run.W_friction[-1], rel=1e-6)
    assert last["impacts"] == len(run.impacts)
    # the same phases, switching within 1e-9 s of each other
    expected = [(impact.t_start, "free", "elastic")] if impact.t_start > 0 else []
    expected += impact.switches
    assert [(a, b) for _, a, b in log.events] == [(a, b) for _, a, b in expected]
    np.testing.assert_allclose([t for t, _, _ in log.events], [t for t, _, _ in expected], rtol=0, atol=1e-9)


def test_co_simulation_steps_do_not_change_the_answer(fmus):
    fine, fine_log = run_fmu(fmus["paper"], "CoSimulation", 0.05, interval=1e-3)
    coarse, coarse_log = run_fmu(fmus["paper"], "CoSimulation", 0.05, interval=1e-2)
    assert fine_log.events == coarse_log.events  # the integrator steps across communication points
    for field in ("u[1]", "u[2]", "q[1]", "W_normal", "delta_max", "impacts"):
        assert fine[-1][field] == pytest.approx(coarse[-1][field], rel=1e-12), field


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
def test_half_a_second_of_bouncing_has_the_same_impacts(fmus, kind):
    run = impactgen.simulate(impactgen.load_scene("paper"), t_end=0.5)
    result, log = run_fmu(fmus["paper"], kind, 0.5, interval=1e-3)
    assert result[-1]["impacts"] == len(run.impacts)
    starts = [t for t, a, b in log.events if a == "free"]
    # Model Exchange is integrated by FMPy's own CVODE: late in the chattering its contact
    # times drift by about 2e-6 s (the run's are within 3e-9 s of a run at rtol 1e-13)
    tolerance = 1e-6 if kind == "CoSimulation" else 5e-6
    np.testing.assert_allclose(starts, [i.t_start for i in run.impacts[1:]], rtol=0, atol=tolerance)


def test_a_non_physical_parameter_is_refused_by_name(fmus, tmp_path):
    md = read_model_description(str(fmus["paper"]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = tmp_path / "u"
    with zipfile.ZipFile(fmus["paper"]) as z:
        z.extractall(unzipped)
    messages: list[str] = []

    def logger(env, instance, status, category, message):
        messages.append(message.decode())

    fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="bad")
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2CallbackAllocateMemoryTYPE, \
        fmi2CallbackFreeMemoryTYPE, calloc, free
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu.instantiate(callbacks=callbacks, loggingOn=True)
    for name, value in (("chain.mass[1]", 0.0), ("rod.nu", 0.7), ("contact.friction", -0.1),
                        ("surface.E", float("nan"))):
        with pytest.raises(Exception):
            fmu.setReal([vr[name]], [value])
        assert name in messages[-1], messages[-1]
    assert "%" not in messages[-1] or "%%" not in messages[-1]
    fmu.setReal([vr["chain.mass[1]"]], [2.0])  # a good value is taken
    assert fmu.getReal([vr["chain.mass[1]"]]) == [2.0]
    fmu.freeInstance()


def _cs_run(fmu, vr, stop: float, h: float) -> list[float]:
    fmu.setupExperiment(tolerance=RTOL, startTime=0.0, stopTime=stop)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    t = 0.0
    while t < stop - 1e-12:
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    return fmu.getReal([vr["u[1]"], vr["u[2]"], vr["W_normal"], vr["delta_max"]])


def test_instances_side_by_side_and_reset(fmus, tmp_path):
    md = read_model_description(str(fmus["paper"]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = tmp_path / "u"
    with zipfile.ZipFile(fmus["paper"]) as z:
        z.extractall(unzipped)

    def new(name):
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped),
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        fmu.instantiate()
        return fmu

    alone = new("alone")
    expected = _cs_run(alone, vr, 2e-3, 1e-4)
    a, b = new("a"), new("b")
    b.setReal([vr["initial.u[2]"]], [-0.5])  # a different case beside it
    for fmu in (a, b):
        fmu.setupExperiment(tolerance=RTOL, startTime=0.0, stopTime=2e-3)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
    t = 0.0
    for _ in range(20):  # interleaved steps
        a.doStep(currentCommunicationPoint=t, communicationStepSize=1e-4)
        b.doStep(currentCommunicationPoint=t, communicationStepSize=1e-4)
        t += 1e-4
    assert a.getReal([vr["u[1]"], vr["u[2]"], vr["W_normal"], vr["delta_max"]]) == expected
    assert b.getReal([vr["delta_max"]])[0] != expected[3]
    alone.reset()
    assert _cs_run(alone, vr, 2e-3, 1e-4) == expected  # a reset instance starts afresh
    for fmu in (alone, a, b):
        fmu.terminate()
        fmu.freeInstance()


def test_fmu_command_writes_a_model_exchange_fmu_without_sundials(tmp_path):
    import sys
    out = tmp_path / "chain3.fmu"
    res = subprocess.run([sys.executable, "-m", "impactgen.cli", "fmu", "--links", "3", "--kind", "me",
                          "--out", str(out)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert validate_fmu(str(out)) == []
    md = read_model_description(str(out))
    assert md.modelExchange is not None and md.coSimulation is None
    bad = subprocess.run([sys.executable, "-m", "impactgen.cli", "fmu", "paper", "--links", "2"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "scene or --links" in bad.stderr


def test_a_second_importer_libcosim_runs_the_co_simulation_fmu(fmus):
    """libcosim (the Open Simulation Platform's co-simulation master, through libcosimpy)
    steps the FMU at a fixed 0.1 ms and gets the paper's impact."""
    pytest.importorskip("libcosimpy")
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    execution = CosimExecution.from_step_size(int(1e-4 * 1e9))  # nanoseconds
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=str(fmus["paper"]), instance_name="paper"))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    vr = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    assert execution.simulate_until(int(1e-3 * 1e9))
    names = ["delta_max", "delta_r", "P_max", "u[1]", "u[2]", "W_normal"]
    got = dict(zip(names, observer.last_real_values(index, [vr[n] for n in names])))
    run = impactgen.simulate(impactgen.load_scene("paper"), t_end=1e-3)
    for name in ("delta_max", "delta_r", "P_max"):
        assert got[name] == pytest.approx(getattr(run.impacts[0], name), rel=1e-6), name
    assert [got["u[1]"], got["u[2]"]] == pytest.approx(list(run.u[:, -1]), rel=1e-6)
    assert got["W_normal"] == pytest.approx(run.W_normal[-1], rel=1e-6)


# start values load_scene refuses (issue 37): the FMU refuses them too, at the same boundary
BELOW_SURFACE = [  # (FMU start values, the same as scene overrides, the key named, the link named)
    ({"surface.height_initial": False, "surface.height": 0.0}, {"surface.height": 0.0},
     "surface.height", "link 2"),
    ({"surface.height_initial": False, "surface.height": -0.4397, "initial.q[2]": np.radians(60.0)},
     {"surface.height": -0.4397, "initial.q_deg": [-70.0, 60.0]}, "initial.q", "link 1"),
    ({"initial.q[1]": np.radians(80.0)}, {"initial.q_deg": [80.0, -60.0]}, "initial.q", "link 1"),
]
ON_OR_ABOVE = [  # the same kinds of start, just on the allowed side
    ({"surface.height_initial": False, "surface.height": -1.9}, {"surface.height": -1.9}),
    # (joint 1 just above the surface, {"surface.height": -0.9398, "initial.q_deg": [-70.0, 60.0]},
    # can reach it, and the paper's model has no contact at joint 1: its FMU refuses that start,
    # and the FMU built from those values runs it: tests/test_fmu_points.py)
]


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
@pytest.mark.parametrize("start, overrides, key, link", BELOW_SURFACE)
def test_a_start_below_the_surface_is_refused_as_load_scene_refuses_it(fmus, kind, start, overrides, key,
                                                                          link):
    with pytest.raises(impactgen.SceneError, match=key):
        impactgen.load_scene("paper", overrides=overrides)
    log = EventLog()
    with pytest.raises(Exception):
        simulate_fmu(str(fmus["paper"]), fmi_type=kind, stop_time=1e-3, start_values=start, logger=log,
                     debug_logging=True)
    assert log.errors and key in log.errors[-1] and link in log.errors[-1], log.errors


@pytest.mark.parametrize("start, overrides", ON_OR_ABOVE)
def test_a_start_on_or_above_the_surface_runs(fmus, start, overrides):
    impactgen.load_scene("paper", overrides=overrides)
    log = EventLog()
    simulate_fmu(str(fmus["paper"]), fmi_type="CoSimulation", stop_time=1e-3, start_values=start,
                 logger=log, debug_logging=True)
    assert log.errors == []


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
def test_null_arrays_are_an_error_not_a_crash(fmus, tmp_path, kind):
    """Outside the FMI contract, but as the Reference-FMUs do: fmi2Error, no segfault."""
    import ctypes
    from fmpy.fmi2 import FMU2Model
    md = read_model_description(str(fmus["paper"]))
    with zipfile.ZipFile(fmus["paper"]) as z:
        z.extractall(tmp_path)
    cls, model = (FMU2Model, md.modelExchange) if kind == "ModelExchange" else (FMU2Slave, md.coSimulation)
    fmu = cls(guid=md.guid, unzipDirectory=str(tmp_path), modelIdentifier=model.modelIdentifier,
              instanceName="nulls")
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2CallbackAllocateMemoryTYPE, \
        fmi2CallbackFreeMemoryTYPE, calloc, free
    messages: list[str] = []
    callbacks = fmi2CallbackFunctions()  # its own logger: FMPy's default one may point at a freed one
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, text: messages.append(text))
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu.instantiate(callbacks=callbacks)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    lib = fmu.dll
    buf, ints = (ctypes.c_double * 8)(), (ctypes.c_int * 8)()
    vr = (ctypes.c_uint * 1)(0)
    c = ctypes.c_void_p(fmu.component)
    assert lib.fmi2SetReal(c, None, 1, buf) == 3  # fmi2Error
    assert lib.fmi2SetReal(c, vr, 1, None) == 3
    fmu.exitInitializationMode()
    for name, args in (("fmi2GetReal", (None, 1, buf)), ("fmi2GetReal", (vr, 1, None)),
                       ("fmi2GetInteger", (None, 1, ints)), ("fmi2GetBoolean", (None, 1, ints))):
        assert getattr(lib, name)(c, *args) == 3, name
    if kind == "ModelExchange":
        states = len(md.derivatives)
        for name in ("fmi2GetContinuousStates", "fmi2GetDerivatives", "fmi2GetNominalsOfContinuousStates",
                     "fmi2SetContinuousStates"):
            assert getattr(lib, name)(c, None, states) == 3, name
        assert lib.fmi2GetEventIndicators(c, None, md.numberOfEventIndicators) == 3
        assert lib.fmi2NewDiscreteStates(c, None) == 3
    assert messages and all(b"is NULL" in m for m in messages)
    fmu.freeInstance()


# -- issue 45: the scene's rules across parameters, and times that are not finite or go back ---

def _instance(path: Path, folder: Path, kind: str, messages: list[str]):
    """An instance of the FMU at `path` with a logger that keeps its error messages."""
    from fmpy.fmi2 import FMU2Model, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, \
        fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, calloc, free
    md = read_model_description(str(path))
    if not folder.exists():
        with zipfile.ZipFile(path) as z:
            z.extractall(folder)
    cls, model = (FMU2Model, md.modelExchange) if kind == "ModelExchange" else (FMU2Slave, md.coSimulation)
    fmu = cls(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=model.modelIdentifier, instanceName="x")
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(
        lambda env, name, status, category, text: messages.append(text.decode()) if status >= 3 else None)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu.instantiate(callbacks=callbacks, loggingOn=True)
    fmu._keep = callbacks  # the logger lives as long as the instance
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def _scene_value(key: str) -> float:
    from impactgen.codegen.parameters import BY_NAME
    scene = impactgen.load_scene("paper")
    return next(p for p in BY_NAME.values() if p.key == key).value(scene)


def _rule_breaking_starts():
    """For every rule across parameters (codegen/parameters.py, RULES), values that break it:
    the lower input at, and above, the upper one; the upper one lowered under the lower."""
    from impactgen.codegen.parameters import RULES
    starts = []
    for rule in RULES:
        high = _scene_value(rule.above_key)
        low = _scene_value(rule.key)
        starts += [(rule.key, {rule.key: high}), (rule.key, {rule.key: 1.5 * high}),
                   (rule.key, {rule.above_key: 0.5 * low})]
    return starts


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
@pytest.mark.parametrize("key, start", _rule_breaking_starts())
def test_every_rule_across_parameters_load_scene_applies_is_applied_at_initialization(fmus, tmp_path, kind,
                                                                                       key, start):
    """rod.yield_strength = 3e11 (above rod.E) had passed fmi2SetReal, initialization and
    fmi2DoStep. Now the FMU refuses, at fmi2ExitInitializationMode, what load_scene refuses,
    from the same rule list and naming the same key. fmi2SetReal takes each value (values set
    one at a time may break a rule on the way to a valid start)."""
    with pytest.raises(impactgen.SceneError) as refused:
        impactgen.load_scene("paper", overrides=start)
    assert refused.value.key == key
    messages: list[str] = []
    fmu, vr = _instance(fmus["paper"], tmp_path / "u", kind, messages)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr[k] for k in start], list(start.values()))
    assert messages == []
    with pytest.raises(Exception):
        fmu.exitInitializationMode()
    assert messages and messages[-1].startswith(f"{key} = ") and "is not physical" in messages[-1], messages
    fmu.freeInstance()


def test_a_rule_broken_on_the_way_to_a_valid_start_is_not_refused(fmus, tmp_path):
    """Raise the yield strength above the old modulus first, then the modulus: valid at the end."""
    e_rod = _scene_value("rod.E")
    messages: list[str] = []
    fmu, vr = _instance(fmus["paper"], tmp_path / "u", "CoSimulation", messages)
    fmu.setupExperiment(startTime=0.0, stopTime=1e-4)
    fmu.enterInitializationMode()
    fmu.setReal([vr["rod.yield_strength"]], [2.0 * e_rod])
    fmu.setReal([vr["rod.E"]], [4.0 * e_rod])
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-4)
    assert messages == []
    fmu.freeInstance()


BAD_EXPERIMENTS = [  # fmi2SetupExperiment arguments, and a word of the logged message
    (dict(startTime=float("nan")), "start time"),
    (dict(startTime=float("inf")), "start time"),
    (dict(startTime=0.0, stopTime=float("nan")), "stop time"),
    (dict(startTime=1.0, stopTime=0.5), "stop time"),
    (dict(startTime=0.0, tolerance=float("nan")), "tolerance"),
]


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
@pytest.mark.parametrize("arguments, words", BAD_EXPERIMENTS)
def test_a_start_or_stop_time_that_is_not_finite_is_an_error(fmus, tmp_path, kind, arguments, words):
    messages: list[str] = []
    fmu, _ = _instance(fmus["paper"], tmp_path / "u", kind, messages)
    with pytest.raises(Exception):
        fmu.setupExperiment(**arguments)
    assert messages and words in messages[-1]
    fmu.freeInstance()


def test_a_co_simulation_step_from_a_time_that_is_not_the_current_one_is_an_error(fmus, tmp_path):
    """After a refused fmi2DoStep(5.0, ...), fmi2DoStep(NaN, 1e-4) had returned OK."""
    messages: list[str] = []
    fmu, vr = _instance(fmus["paper"], tmp_path / "u", "CoSimulation", messages)
    fmu.setupExperiment(tolerance=RTOL, startTime=0.0, stopTime=1e-3)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-4)
    for t, h in ((5.0, 1e-4), (float("nan"), 1e-4), (1e-4, float("nan")), (1e-4, float("inf")),
                 (float("-inf"), 1e-4), (0.0, 1e-4), (1e-4, -1e-5), (2e-4, 1e-4)):
        count = len(messages)
        with pytest.raises(Exception):
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        assert len(messages) == count + 1 and "fmi2DoStep" in messages[-1], (t, h, messages[-1:])
    before = fmu.getReal([vr["u[2]"]])
    fmu.doStep(currentCommunicationPoint=1e-4, communicationStepSize=1e-4)  # the right time still steps
    assert fmu.getReal([vr["u[2]"]]) != before
    fmu.freeInstance()


def test_model_exchange_time_that_is_not_finite_or_goes_back_is_an_error(fmus, tmp_path):
    """fmi2SetTime(-1.0) after fmi2SetTime(1e-3), and fmi2SetTime(NaN), had returned OK. An
    integrator may still go back within its step (a retried step, a root search)."""
    messages: list[str] = []
    fmu, _ = _instance(fmus["paper"], tmp_path / "u", "ModelExchange", messages)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.newDiscreteStates()
    fmu.enterContinuousTimeMode()
    fmu.setTime(1e-3)
    for t in (-1.0, float("nan"), float("inf"), -1e-300):
        with pytest.raises(Exception):
            fmu.setTime(t)
        assert "fmi2SetTime" in messages[-1]
    fmu.setTime(5e-4)  # back within the step: allowed
    fmu.setTime(1e-6)
    fmu.completedIntegratorStep()
    with pytest.raises(Exception):
        fmu.setTime(5e-7)  # before the completed step
    assert "before the last completed step" in messages[-1]
    fmu.setTime(2e-6)
    fmu.freeInstance()


# -- issue 44: one event update and one log of a switch for both kinds -------------------------

def test_both_kinds_log_the_same_switches_stick_slip_included(tmp_path):
    """Exact Coulomb friction: the tip's slip reverses within the impact. Model Exchange (the
    FMU's event update) and Co-Simulation (ig_run's switches) log each switch alike, with the
    slip labels of model_machine_slip_name, at the times of `impactgen run`."""
    scene = impactgen.load_scene("coulomb")
    path = build_fmu(scene, tmp_path / "coulomb.fmu")
    run = impactgen.simulate(scene, t_end=1e-3)
    logs = {kind: run_fmu(path, kind, 1e-3)[1] for kind in ("ModelExchange", "CoSimulation")}
    for log in logs.values():
        assert log.errors == []
    me, cs = logs["ModelExchange"].events, logs["CoSimulation"].events
    assert [(a, b) for _, a, b in me] == [(a, b) for _, a, b in cs]
    assert ("slip-", "slip+") in [(a, b) for _, a, b in cs] or ("slip+", "slip-") in [(a, b) for _, a, b in cs]
    phases = [(t, a, b) for t, a, b in cs if not a.startswith(("slip", "stick"))]
    assert [(a, b) for _, a, b in phases] == [(a, b) for _, a, b in run.impacts[0].switches]
    np.testing.assert_allclose([t for t, _, _ in me], [t for t, _, _ in cs], rtol=0, atol=1e-9)
