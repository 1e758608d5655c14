"""A run's validity warnings reach a Python user through the warnings module, once, and the
command line prints each of them once, as one line (issue 49, item 1)."""
from __future__ import annotations

import warnings

import pytest

import impactgen
from impactgen.errors import ImpactgenWarning, SceneError, ValidityWarning

# A soft aluminium surface under the paper's impact: delta_max about 440 delta_c, beyond the
# 110 delta_c the Jackson-Green fits cover.
SOFT = {"surface.E": 70e9, "surface.yield_strength": 95e6}
BEYOND = "beyond the 110 delta_c that the Jackson-Green fits cover"


@pytest.fixture(scope="module")
def soft_scene():
    return impactgen.load_scene("paper", SOFT)


def test_a_validity_warning_is_issued_to_the_callers_line(soft_scene):
    with pytest.warns(ValidityWarning, match=BEYOND) as said:
        result = impactgen.simulate(soft_scene)
    assert result.status == "ok" and len(result.warnings) == 1 and BEYOND in result.warnings[0]
    assert [str(w.message) for w in said] == [f"{soft_scene.name}: {result.warnings[0]}"]
    assert said[0].filename == __file__  # the user's line, not the library's
    assert issubclass(ValidityWarning, ImpactgenWarning)


def test_the_reference_engine_warns_alike(soft_scene):
    with pytest.warns(ValidityWarning, match=BEYOND):
        result = impactgen.simulate(soft_scene, engine="reference", rtol=1e-8)
    assert BEYOND in result.warnings[0]


def test_warn_false_keeps_the_warnings_in_the_result_only(soft_scene):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = impactgen.simulate(soft_scene, warn=False)
    assert BEYOND in result.warnings[0]


def test_a_run_inside_the_models_range_issues_nothing():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = impactgen.simulate("paper")
    assert result.warnings == []


def test_warn_is_checked():
    with pytest.raises(SceneError, match="warn: expected True or False"):
        impactgen.simulate("paper", warn="no")


@pytest.mark.parametrize("command", [["run"], ["run", "--json"], ["compare"]])
def test_the_command_line_prints_each_warning_once_as_one_line(command, capsys):
    from impactgen.cli import main
    sets = [arg for key, value in SOFT.items() for arg in ("--set", f"{key}={value:g}")]
    assert main([command[0], "paper", *sets, *command[1:]]) == 0
    err = capsys.readouterr().err.splitlines()
    said = [line for line in err if BEYOND in line]
    assert len(said) == 1 and said[0].startswith("impactgen: warning: "), err


def test_t_eval_times_left_out_are_an_impactgen_warning_not_a_validity_one():
    with pytest.warns(ImpactgenWarning, match="t_eval times lie after the run's end") as said:
        result = impactgen.simulate("paper", t_eval=[0.0, 1e-4, 1.0])
    assert [w.category for w in said] == [ImpactgenWarning] and len(result.warnings) == 1
