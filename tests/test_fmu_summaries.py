"""The FMU's summary outputs (first_impact.*, run.*) and its default experiment: an FMPy run
with the FMU's own defaults gives the first impact's summary of `impactgen run`, field for field
under the names `impactgen run --json` and the sweep use, in both kinds of FMU."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

import impactgen
from impactgen.fmu import build_fmu
from impactgen.codegen.spec import point_name
from impactgen.fmu.variables import summary_fields

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

SCENES = ("paper", "chain3-free-flight")  # an impact from the start; one after free flight
KINDS = ("ModelExchange", "CoSimulation")
RTOL = 1e-6  # the FMU against impactgen run, both at the scene's rtol 1e-10 (docs/embedding.md)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("fmu_summaries")
    return {name: build_fmu(impactgen.load_scene(name), folder / f"{name}.fmu") for name in SCENES}


def summary_value(summary: dict, name: str, n: int) -> float:
    """A summary's field by its flat name (`energy.W_normal`, `u_final[2]`, `n_switches`), as the
    sweep's columns name them; `point_impacts[k]` by the point's number k, as the FMU names it."""
    if name in ("n_switches", "n_stick_slip"):
        return len(summary["switches" if name == "n_switches" else "stick_slip"])
    if "[" in name:
        key, index = name[:-1].split("[")
        if key == "point_impacts":
            return summary[key][point_name(int(index), n)]
        return summary[key][int(index) - 1]
    group, _, key = name.partition(".")
    value = summary[group][key] if key else summary[name]
    return math.nan if value is None else value


def assert_summary(fmu_last, kind: str, summary: dict, n: int, dof: int | None = None) -> None:
    """Every field of one summary (kind: first_impact or run) at the FMU's last output point."""
    scale = max(summary["T0"], summary["Tf"])  # the energies'
    for name, *_ in summary_fields(n, dof):
        got, want = float(fmu_last[f"{kind}.{name}"]), summary_value(summary, name, n)
        if math.isnan(want):
            assert math.isnan(got), name
        else:  # the energy residual is a difference of energies: held to the energies' scale
            assert got == pytest.approx(want, rel=RTOL, abs=RTOL * scale if name == "energy.residual" else 0), name


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", SCENES)
def test_the_fmus_defaults_give_impactgen_runs_first_impact(fmus, name, kind):
    path = str(fmus[name])
    md = read_model_description(path)
    outputs = [v.name for v in md.modelVariables if v.name.startswith(("first_impact.", "run."))]
    result = simulate_fmu(path, fmi_type=kind, output=outputs)  # the default experiment: stop and tolerance
    scene = impactgen.load_scene(name)
    run = impactgen.simulate(scene)  # to separation: its summary is the first impact's
    last = result[-1]
    assert_summary(last, "first_impact", run.summary, scene.n)
    # run.*: the run from its start to the stop time, as impactgen run's to that time
    stop = result["time"][-1]
    timed = impactgen.simulate(scene, t_end=float(stop)).summary
    assert_summary(last, "run", timed, scene.n)


@pytest.mark.parametrize("kind", KINDS)
def test_a_free_rods_first_impact_is_its_base_s_as_the_c_engine_has_it(tmp_path, kind):
    """rod-drop to separation: its first impact is the base point's (point 0), in the FMU's
    first_impact.* as in impactgen run's summary, field for field."""
    scene = impactgen.load_scene("rod-drop", {"solver.t_end": None})
    path = str(build_fmu(scene, tmp_path / f"rod-{kind}.fmu"))
    outputs = [v.name for v in read_model_description(path).modelVariables if v.name.startswith("first_impact.")]
    last = simulate_fmu(path, fmi_type=kind, output=outputs)[-1]
    summary = impactgen.simulate(scene).summary
    assert summary["first_point"] == 0 and summary["delta_max"] > 0
    assert last["first_impact.first_point"] == 0 and last["first_impact.point_impacts[0]"] == 1
    assert_summary(last, "first_impact", summary, scene.n, scene.dof)


@pytest.mark.parametrize("name", SCENES)
def test_the_default_experiment_is_the_scenes(fmus, name):
    scene = impactgen.load_scene(name)
    first = impactgen.simulate(scene).first_impact
    experiment = read_model_description(str(fmus[name])).defaultExperiment
    assert float(experiment.tolerance) == scene.solver.rtol
    end = first["t_impact"] + first["t_contact"]  # the scene stops at this separation
    assert end < float(experiment.stopTime) <= end + 0.2 * first["t_contact"]
    assert validate_fmu(str(fmus[name])) == []


def test_a_scene_run_to_a_time_stops_there(tmp_path):
    scene = impactgen.load_scene("paper", overrides={"solver.t_end": 0.02})
    path = build_fmu(scene, tmp_path / "timed.fmu", kind="me")
    assert float(read_model_description(str(path)).defaultExperiment.stopTime) == 0.02


@pytest.mark.slow  # half a second of chattering impacts
def test_after_many_impacts_the_first_impacts_outputs_are_still_the_first(fmus):
    """The issue's run: to 0.5 s, `delta_r` is the latest impact's, `first_impact.delta_r` the
    first's, and run.* is the whole run's."""
    scene = impactgen.load_scene("paper")
    first = impactgen.simulate(scene).summary
    whole = impactgen.simulate(scene, t_end=0.5)
    result = simulate_fmu(str(fmus["paper"]), fmi_type="CoSimulation", stop_time=0.5, output_interval=1e-3,
                          output=["delta_r", "first_impact.delta_r", "first_impact.t_contact", "run.impacts",
                                  "run.delta_max", "run.t_contact"])
    last = result[-1]
    assert last["first_impact.delta_r"] == pytest.approx(first["delta_r"], rel=RTOL)
    assert last["first_impact.t_contact"] == pytest.approx(first["t_contact"], rel=RTOL)
    assert last["delta_r"] == pytest.approx(whole.impacts[-1].delta_r, rel=1e-3)
    assert last["delta_r"] < 0.1 * last["first_impact.delta_r"]
    assert last["run.impacts"] == whole.summary["impacts"]
    assert last["run.delta_max"] == pytest.approx(whole.summary["delta_max"], rel=RTOL)
    assert last["run.t_contact"] == pytest.approx(whole.summary["t_contact"], rel=1e-5)


def test_without_the_c_engine_the_stop_time_comes_from_the_reference_engine(monkeypatch):
    """A Model Exchange FMU needs no SUNDIALS: where the C engine cannot be built, the scene's
    separation is found by the reference engine, to the same default stop time."""
    from impactgen.errors import BuildError
    from impactgen.fmu import package

    scene = impactgen.load_scene("paper")
    expected = package.default_stop_time(scene)
    engines = []

    def simulate(scene, engine="c", **kw):
        engines.append(engine)
        if engine == "c":
            raise BuildError("no SUNDIALS here")
        return impactgen.simulate(scene, engine=engine, **kw)

    monkeypatch.setattr(package, "simulate", simulate)
    assert package.default_stop_time(scene) == expected
    assert engines == ["c", "reference"]
