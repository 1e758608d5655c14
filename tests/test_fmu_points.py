"""Contact at the joints, embedded (issue 38 item 7): the FMU of a model with contact at a joint
names each point's outputs, has each point's events as event indicators, and simulates, in
Model Exchange (FMPy's CVODE) and Co-Simulation (ig_run inside), to `impactgen run`'s impacts
at every point; values that would let a joint the model was pruned of reach the surface are
refused, naming the joint; the pure-C driver lists the impacts by point."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import impactgen
from impactgen.codegen.emit import generate_model
from impactgen.engines import model_spec, reachable_joints
from impactgen.fmu import build_fmu

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

RTOL = 1e-10  # as tests/test_fmu.py: values within 1e-6 relative, switches within 1e-9 s
# a 3-link chain whose second joint strikes the surface at about t = 0.126 s, between the tip's
# impacts (joint 1 cannot reach: pruned)
JOINT2 = {"chain.links": 3, "chain.length": [1, 1, 0.2], "chain.mass": [1, 1, 0.2],
          "initial.q_deg": [-30, -80, -20], "initial.u": [0, 0, -3], "solver.t_end": 0.3}
JOINT2_STOP = 0.2  # the tip's first three impacts and joint 2's first
# joint 1 and the tip both start on the surface, moving into it
BOTH_AT_ONCE = {"initial.q_deg": [-30, 0], "initial.u": [-1, 0], "surface.height": "initial",
                "solver.t_end": 0.01}
BOTH_STOP = 1e-3
# a 4-link chain over a surface every joint can reach: joint 3, then joint 2 strike between the
# tip's impacts
THREE_JOINTS = {"chain.links": 4, "chain.length": [0.5] * 4, "chain.mass": [1] * 4,
                "initial.q_deg": [-10] * 4, "initial.u": [-2, 0, 0, 0], "surface.height": -0.4,
                "solver.t_end": 0.15}
POINT_OUTPUTS = ("delta", "delta_rate", "v_x", "v_y", "F", "F_f")
POINT_DISCRETE = ("phase", "impacts", "delta_max", "delta_r", "P_max")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("fmu-points")
    return {"joint2": build_fmu(impactgen.load_scene("paper", JOINT2), folder / "joint2.fmu"),
            "both": build_fmu(impactgen.load_scene("paper", BOTH_AT_ONCE), folder / "both.fmu"),
            "three": build_fmu(impactgen.load_scene("paper", THREE_JOINTS), folder / "three.fmu")}


class Log:
    """The FMU's logEvents switches as (t, point, from, to), and its error messages."""

    SWITCH = re.compile(r"t = (\S+): (?:(joint \d+): )?(\w+) -> (\w+)$")

    def __init__(self):
        self.switches: list[tuple[float, str, str, str]] = []
        self.errors: list[str] = []

    def __call__(self, env, instance, status, category, message):
        text = message.decode()
        if category == b"logEvents":
            t, point, a, b = self.SWITCH.match(text).groups()
            self.switches.append((float(t), point or "tip", a, b))
        elif status >= 3:
            self.errors.append(text)


def expected_switches(run) -> list[tuple[float, str, str, str]]:
    """`impactgen run`'s switches at every point, as the FMU logs them, in time order."""
    out = []
    for impact in run.impacts:
        if impact.t_start > 0:
            out.append((impact.t_start, impact.point, "free", "elastic"))
        out += [(t, impact.point, a, b) for t, a, b in impact.switches]
    return sorted(out)


def simulate(path: Path, kind: str, stop: float, **kw):
    log = Log()
    md = read_model_description(str(path))
    wanted = [v.name for v in md.modelVariables if v.causality == "output" or v.name[0] in "quW"]
    result = simulate_fmu(str(path), fmi_type=kind, stop_time=stop, relative_tolerance=RTOL,
                          output_interval=stop / 100, debug_logging=True, logger=log, output=wanted, **kw)
    return result, log


def test_each_point_has_its_outputs_events_and_radius(fmus):
    path = fmus["joint2"]
    assert validate_fmu(str(path)) == []  # FMPy takes the structured names contact[2].delta, ...
    md = read_model_description(str(path))
    variables = {v.name: v for v in md.modelVariables}
    scene = impactgen.load_scene("paper", JOINT2)
    assert reachable_joints(scene) == (2,)
    for name in POINT_OUTPUTS + POINT_DISCRETE:
        v = variables[f"contact[2].{name}"]
        assert v.causality == "output", name
        assert v.variability == ("continuous" if name in POINT_OUTPUTS else "discrete"), name
        assert f"contact[1].{name}" not in variables  # joint 1 cannot reach: pruned
    assert variables["contact[2].delta"].unit == "m" and variables["contact[2].F"].unit == "N"
    radius = variables["contact.joint_radius[2]"]
    assert radius.causality == "parameter" and float(radius.start) == scene.tip_radius
    # the tip's keep their names
    assert {"delta", "F", "F_f", "v_B[1]", "v_B[2]", "phase", "impacts", "delta_max"} <= set(variables)
    # the event indicators are the model's events: the tip's and joint 2's copy of them
    events = generate_model(model_spec(scene)).event_names
    assert md.numberOfEventIndicators == len(events) and "contact_J2" in events


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
def test_a_joint_strikes_in_the_fmu_as_in_impactgen_run(fmus, kind):
    result, log = simulate(fmus["joint2"], kind, JOINT2_STOP)
    assert log.errors == []
    run = impactgen.simulate(impactgen.load_scene("paper", JOINT2), t_end=JOINT2_STOP)
    joint = [i for i in run.impacts if i.point == "joint 2"]
    tip = [i for i in run.impacts if i.point == "tip"]
    assert len(joint) == 1 and len(tip) == 3 and 0.12 < joint[0].t_start < 0.13
    last = result[-1]
    assert last["contact[2].impacts"] == 1 and last["impacts"] == 3
    assert last["contact[2].phase"] == 0 and last["phase"] == 0
    for field in ("delta_max", "delta_r", "P_max"):  # joint 2's impact and the tip's last
        assert last[f"contact[2].{field}"] == pytest.approx(getattr(joint[0], field), rel=1e-6), field
        assert last[field] == pytest.approx(getattr(tip[-1], field), rel=1e-6), field
    for i in range(3):
        assert last[f"u[{i + 1}]"] == pytest.approx(run.u[i, -1], rel=1e-6)
        assert last[f"q[{i + 1}]"] == pytest.approx(run.q[i, -1], rel=1e-6)
    assert last["W_normal"] == pytest.approx(run.W_normal[-1], rel=1e-6)
    # every switch of every point, the joint's named, within 1e-9 s of impactgen run's
    expected = expected_switches(run)
    assert [s[1:] for s in log.switches] == [s[1:] for s in expected]
    np.testing.assert_allclose([s[0] for s in log.switches], [s[0] for s in expected], rtol=0, atol=1e-9)
    first = next(s for s in log.switches if s[1] == "joint 2")
    assert first[2:] == ("free", "elastic") and first[0] == pytest.approx(joint[0].t_start, abs=1e-9)
    # the joint's outputs while it flies: its height above the surface, no force
    t = result["time"]
    before = result[t < 0.12][-1]
    assert before["contact[2].delta"] < 0 and before["contact[2].F"] == 0.0


def test_a_joint_has_its_own_radius(fmus):
    """contact.joint_radius[2] sets joint 2's contact alone: a blunter joint dents the surface
    less, and the tip's impacts before it do not change."""
    base, _ = simulate(fmus["joint2"], "CoSimulation", 0.13)
    blunt, log = simulate(fmus["joint2"], "CoSimulation", 0.13, start_values={"contact.joint_radius[2]": 0.05})
    assert log.errors == []
    assert blunt[-1]["contact[2].impacts"] == base[-1]["contact[2].impacts"] == 1
    assert blunt[-1]["contact[2].delta_max"] < 0.7 * base[-1]["contact[2].delta_max"]
    early = base["time"] < 0.12
    for field in ("delta_max", "u[1]", "q[3]"):
        assert np.array_equal(blunt[early][field], base[early][field]), field


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
def test_two_points_that_start_on_the_surface_strike_together(fmus, kind):
    result, log = simulate(fmus["both"], kind, BOTH_STOP)
    assert log.errors == []
    run = impactgen.simulate(impactgen.load_scene("paper", BOTH_AT_ONCE), t_end=BOTH_STOP)
    by_point = {i.point: i for i in run.impacts}
    assert set(by_point) == {"tip", "joint 1"} and all(i.t_start == 0.0 for i in run.impacts)
    last = result[-1]
    assert last["impacts"] == 1 and last["contact[1].impacts"] == 1
    for field in ("delta_max", "delta_r", "P_max"):
        assert last[field] == pytest.approx(getattr(by_point["tip"], field), rel=1e-6), field
        assert last[f"contact[1].{field}"] == pytest.approx(getattr(by_point["joint 1"], field), rel=1e-6), field
    expected = expected_switches(run)
    assert [s[1:] for s in log.switches] == [s[1:] for s in expected]
    np.testing.assert_allclose([s[0] for s in log.switches], [s[0] for s in expected], rtol=0, atol=1e-9)


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
def test_three_joints_each_strike_by_name(fmus, kind):
    scene = impactgen.load_scene("paper", THREE_JOINTS)
    assert reachable_joints(scene) == (1, 2, 3)
    result, log = simulate(fmus["three"], kind, 0.15)
    assert log.errors == []
    run = impactgen.simulate(scene)
    assert [i.point for i in run.impacts] == ["tip", "joint 3", "tip", "joint 2"]
    starts = [(t, point) for t, point, a, b in log.switches if a == "free"]
    assert [point for _, point in starts] == [i.point for i in run.impacts]
    # FMPy's own CVODE (Model Exchange) finds these roots within a few 1e-9 s
    np.testing.assert_allclose([t for t, _ in starts], [i.t_start for i in run.impacts], rtol=0,
                               atol=1e-9 if kind == "CoSimulation" else 1e-8)
    last = result[-1]
    assert [last[f"contact[{j}].impacts"] for j in (1, 2, 3)] == [0, 1, 1] and last["impacts"] == 2
    for j, impact in ((3, run.impacts[1]), (2, run.impacts[3])):
        assert last[f"contact[{j}].delta_max"] == pytest.approx(impact.delta_max, rel=1e-6)


# values that let joint 1, pruned from the JOINT2 model, reach the surface: the FMU's start
# values, and the same as scene overrides (which give the model with joint 1)
REACHING = [
    ({"initial.q[2]": np.radians(-10.0)}, {"initial.q_deg": [-30, -10, -20]}),  # the tip's surface rises
    ({"chain.length[1]": 3.0}, {"chain.length": [3, 1, 0.2]}),
    ({"surface.height_initial": False, "surface.height": -0.99, "initial.q[2]": np.radians(-10.0)},
     {"surface.height": -0.99, "initial.q_deg": [-30, -10, -20]}),
]


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
@pytest.mark.parametrize("start, overrides", REACHING)
def test_values_that_let_a_pruned_joint_reach_are_refused_naming_it(fmus, kind, start, overrides):
    assert 1 in reachable_joints(impactgen.load_scene("paper", {**JOINT2, **overrides}))
    log = Log()
    with pytest.raises(Exception):
        simulate_fmu(str(fmus["joint2"]), fmi_type=kind, stop_time=1e-3, start_values=start, logger=log,
                     debug_logging=True)
    assert log.errors and "joint 1" in log.errors[-1] and "no contact at joint 1" in log.errors[-1], log.errors
    assert "impactgen fmu" in log.errors[-1]


def test_values_that_keep_the_pruned_joint_away_run(fmus):
    start, overrides = {"chain.length[1]": 1.2}, {"chain.length": [1.2, 1, 0.2]}
    assert reachable_joints(impactgen.load_scene("paper", {**JOINT2, **overrides})) == (2,)
    log = Log()
    simulate_fmu(str(fmus["joint2"]), fmi_type="CoSimulation", stop_time=1e-3, start_values=start, logger=log,
                 debug_logging=True)
    assert log.errors == []


def test_a_model_without_joints_refuses_a_joint_at_the_surface(tmp_path):
    """The paper's model has no contact at joint 1 (it cannot reach at the paper's values);
    with joint 1 put just above a surface it can reach, its FMU refuses the start, and the FMU
    built from those values (which has joint 1's contact) runs it."""
    start = {"surface.height_initial": False, "surface.height": -0.9398, "initial.q[2]": np.radians(60.0)}
    overrides = {"surface.height": -0.9398, "initial.q_deg": [-70.0, 60.0]}
    paper = impactgen.load_scene("paper")
    assert reachable_joints(paper) == ()
    log = Log()
    with pytest.raises(Exception):
        simulate_fmu(str(build_fmu(paper, tmp_path / "paper.fmu", kind="me")), fmi_type="ModelExchange",
                     stop_time=1e-3, start_values=start, logger=log, debug_logging=True)
    assert log.errors and "joint 1" in log.errors[-1], log.errors
    scene = impactgen.load_scene("paper", overrides)
    assert reachable_joints(scene) == (1,)
    log = Log()
    result = simulate_fmu(str(build_fmu(scene, tmp_path / "joint1.fmu", kind="me")), fmi_type="ModelExchange",
                          stop_time=1e-3, relative_tolerance=RTOL, logger=log, debug_logging=True,
                          output=["contact[1].delta"])
    assert log.errors == [] and -1e-4 < result[-1]["contact[1].delta"] < 0  # joint 1 nears the surface


def test_the_c_driver_lists_the_impacts_by_point(tmp_path, c_driver):
    scene = impactgen.load_scene("paper", JOINT2)
    path = tmp_path / "joint2.toml"
    path.write_text(scene.to_toml())
    folder = tmp_path / "model"
    subprocess.run([sys.executable, "-m", "impactgen.cli", "generate", str(path), "--out", str(folder)],
                   check=True, capture_output=True, text=True)
    out = subprocess.run([str(c_driver(folder))], capture_output=True, text=True, check=True).stdout
    printed = dict(line.split(" ", 1) for line in out.splitlines())
    run = impactgen.simulate(scene)
    assert printed["status"] == "ok" and len(run.impacts) == 6
    for k, impact in enumerate(run.impacts, start=1):
        assert printed[f"impact[{k}].point"] == impact.point
        for field in ("t_start", "t_end", "delta_max", "delta_r", "P_max"):
            assert float(printed[f"impact[{k}].{field}"]) == pytest.approx(getattr(impact, field), rel=1e-8), field
    assert f"impact[{len(run.impacts) + 1}].point" not in printed
    assert [printed[f"impact[{k}].point"] for k in (1, 2, 3)] == ["tip", "tip", "joint 2"]


@pytest.mark.parametrize("overrides", [JOINT2, {}], ids=["joint2-model", "paper-model"])
def test_the_c_reach_test_is_pythons_rule(overrides):
    """model_pruned_reach (generated C, what the FMU and the C driver call) answers as
    reachable_joints (Python, which picks the model) on random lengths, surfaces and angles:
    the first joint the model lacks that the values let reach, or 0."""
    from impactgen.build import compile_model
    from impactgen.model_params import fill_params
    base = impactgen.load_scene("paper", overrides)
    model = compile_model(model_spec(base))
    ffi, lib, n = model.ffi, model.lib, base.n
    rng = np.random.default_rng(38)
    checked = reaching = 0
    while checked < 200:
        q = rng.uniform(-np.pi / 2, np.pi / 2 if n > 2 else 0.0, n)
        lengths = rng.uniform(0.2, 2.0, n)
        height = "initial" if rng.random() < 0.5 else float(-rng.uniform(0.1, 1.2) * lengths.sum())
        try:
            scene = impactgen.load_scene("paper", {**overrides, "chain.length": list(lengths),
                                                   "initial.q": list(q), "surface.height": height})
        except impactgen.SceneError:  # a start below the surface: refused before any of this
            continue
        checked += 1
        missing = [j for j in reachable_joints(scene) if j not in model.spec.joints]
        y0 = ffi.new("double[]", list(scene.q0) + list(scene.u0) + [0.0] * (model.nstate - 2 * n))
        assert lib.model_pruned_reach(fill_params(model, scene), y0) == (missing[0] if missing else 0), (
            lengths, q, height)
        reaching += bool(missing)
    assert 20 < reaching < 180  # both answers were met
