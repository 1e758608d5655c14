"""The FMU of a free body (issue 46): rod-drop exported as FMI 2.0, its base point's position
and velocity as state variables (`base[i]`, `base_velocity[i]`) and its start as parameters
(`initial.base[i]`, `initial.base_velocity[i]`), simulated by FMPy in Model Exchange (FMPy's
own CVODE) and Co-Simulation (CVODE inside) past the base's impact, agrees with `impactgen run`."""
from __future__ import annotations

import pytest

import impactgen
from impactgen.fmu import build_fmu

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

RTOL = 1e-10
STOP = 0.12  # s: past the base's impact (0.101 s), before the tip's (0.213 s)
BASE_VARIABLES = ("base[1]", "base[2]", "base_velocity[1]", "base_velocity[2]")


@pytest.fixture(scope="module")
def rod_fmu(tmp_path_factory):
    return build_fmu(impactgen.load_scene("rod-drop"), tmp_path_factory.mktemp("fmu") / "rod-drop.fmu")


def test_the_free_rods_fmu_validates_and_names_its_base_point(rod_fmu):
    assert validate_fmu(str(rod_fmu)) == []
    variables = {v.name: v for v in read_model_description(str(rod_fmu)).modelVariables}
    for name in BASE_VARIABLES:
        assert variables[name].causality in ("local", "output"), name
    for name in ("initial.base[1]", "initial.base[2]", "initial.base_velocity[1]", "initial.base_velocity[2]"):
        assert variables[name].causality == "parameter", name
    assert float(variables["initial.base[2]"].start) == pytest.approx(0.05)


@pytest.mark.parametrize("kind", ["ModelExchange", "CoSimulation"])
def test_the_free_rods_fmu_agrees_with_impactgen_run(rod_fmu, kind):
    result = simulate_fmu(str(rod_fmu), fmi_type=kind, stop_time=STOP, relative_tolerance=RTOL,
                          output_interval=STOP / 100, output=["q[1]", "u[1]", *BASE_VARIABLES])
    run = impactgen.simulate(impactgen.load_scene("rod-drop"), t_end=STOP)
    last = result[-1]
    assert last["q[1]"] == pytest.approx(run.q[0, -1], rel=1e-6)
    assert last["u[1]"] == pytest.approx(run.u[0, -1], rel=1e-6, abs=1e-9)
    for name, value in zip(BASE_VARIABLES, run.base[:, -1]):
        assert last[name] == pytest.approx(value, rel=1e-6, abs=1e-9), name
    assert run.impacts and run.impacts[0].point == "base" and run.impacts[0].t_end < STOP
