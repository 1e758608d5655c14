"""`impactgen fit` and `impactgen.fit`: parameters found again from measurements the model made
with known values plus 1 % noise, the true law ranked first, an undeterminable parameter said
to be so, and bad input refused in one line."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import impactgen
from impactgen.cli import main
from impactgen.fitting.solve import covariance
from impactgen.fitting.synthetic import synthetic_measurements

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE_DATA = ROOT / "examples" / "fit" / "paper-impacts.csv"
TRUTH = {"rod.yield_strength": 0.8e9, "contact.friction": 0.25}  # as scripts/make_fit_data.py
FIT = "rod.yield_strength=3e8..1.1e9,contact.friction=0..1"
LOOSE = 1e-6  # the solver's tolerances: the errors found are far larger


@pytest.fixture(scope="module")
def data():
    """Eight impacts of the paper's pendulum at different omega20, made with TRUTH, 1 % noise."""
    return synthetic_measurements("paper", TRUTH, {"initial.u[2]": np.linspace(-0.15, -0.5, 8)},
                                  ("delta_r", "u_final[1]", "u_final[2]"), noise=0.01, seed=3)


@pytest.fixture(scope="module")
def both_laws(data):
    return impactgen.fit("paper", data, FIT, laws="hertz,three-phase", tolerance=LOOSE)


def test_known_values_found_within_two_standard_errors(both_laws):
    fit = next(f for f in both_laws.laws if f.law == "three-phase")
    assert fit.success and fit.determined.all()
    for key, value, stderr in zip((p.key for p in fit.parameters), fit.values, fit.stderr):
        assert abs(value - TRUTH[key]) <= 2 * stderr, key
        assert 0 < stderr < 0.05 * TRUTH[key]  # 1 % noise on 24 values: errors of a few per cent at most
    assert -1 <= fit.correlation[0, 1] <= 1


def test_true_law_ranks_first(both_laws):
    assert [f.law for f in both_laws.laws] == ["three-phase", "hertz"]
    assert both_laws.laws[0].aic < both_laws.laws[1].aic
    assert both_laws.impacts == sum(f.impacts for f in both_laws.laws) > 0


def test_undeterminable_parameter_is_said_to_be_so(both_laws):
    """The elastic law has no yield strength: the data cannot tell its value, and no error
    is made up for it; the friction coefficient it still determines."""
    hertz = next(f for f in both_laws.laws if f.law == "hertz")
    assert list(hertz.determined) == [False, True]
    assert np.isnan(hertz.stderr[0]) and np.isfinite(hertz.stderr[1])
    assert np.isnan(hertz.correlation[0]).all()


def test_covariance_of_singular_and_collinear_jacobians():
    J = np.array([[1.0, 0.0, 2.0], [2.0, 0.0, 1.0], [0.5, 0.0, 1.0], [1.0, 0.0, 0.0]])
    stderr, determined, _ = covariance(J, chi2=4.0, count=4, sigma_given=True)
    assert list(determined) == [True, False, True] and np.isnan(stderr[1])
    collinear = np.column_stack([J[:, 0], 2 * J[:, 0], J[:, 2]])
    _, determined, _ = covariance(collinear, chi2=4.0, count=4, sigma_given=True)
    assert list(determined) == [False, False, True]


def test_cli_on_the_shipped_example(tmp_path, capsys):
    figure = tmp_path / "fit.png"
    assert main(["fit", "paper", str(EXAMPLE_DATA), "--fit", FIT, "--json", "--out", str(figure)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["law"] == "three-phase" and figure.stat().st_size > 10_000
    for key, truth in TRUTH.items():
        parameter = out["parameters"][key]
        assert abs(parameter["value"] - truth) <= 2 * parameter["stderr"], key
    assert len(out["residuals"]) == 20 and set(out["correlations"]) == set(TRUTH)
    assert main(["fit", "paper", str(EXAMPLE_DATA), "--fit", FIT, "--out", str(figure)]) == 0
    text = capsys.readouterr().out
    assert "rod.yield_strength" in text and "+/-" in text and "residuals" in text


def test_cli_reports_an_undetermined_parameter_in_json(tmp_path, capsys):
    assert main(["fit", "paper", str(EXAMPLE_DATA), "--fit", FIT, "--law", "hertz", "--json",
                 "--out", str(tmp_path / "f.png")]) == 0
    parameters = json.loads(capsys.readouterr().out)["parameters"]
    assert parameters["rod.yield_strength"]["stderr"] is None
    assert parameters["rod.yield_strength"]["determined"] is False
    assert parameters["contact.friction"]["stderr"] > 0


def _csv(tmp_path: Path, text: str) -> str:
    path = tmp_path / "data.csv"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("fit, text, message", [
    ("rod.yield_strenght", "initial.u[2],delta_r\n-0.2,1e-5\n", "did you mean 'rod.yield_strength'"),
    ("rod.yield_strength=2e9..1e9", "initial.u[2],delta_r\n-0.2,1e-5\n", "bounds are reversed"),
    ("rod.yield_strength", "initial.u[2],delta_r\n", "has no rows"),
    ("rod.yield_strength", "", "is empty"),
    ("rod.yield_strength", "initial.u[2],dent\n-0.2,1e-5\n", "column 'dent' is neither a scene key"),
    ("rod.yield_strength", "initial.u[2]\n-0.2\n", "no measurement column"),
    ("rod.yield_strength", "initial.u[2],delta_r,sigma:t_contact\n-0.2,1e-5,1\n", "sigma:t_contact has no measurement"),
    ("rod.yield_strength", "initial.u[2],delta_r,sigma:delta_r\n-0.2,1e-5,0\n", "must be a number > 0"),
    ("rod.yield_strength", "initial.u[2],delta_r\n-0.2,1e-5\n0.5,1e-5\n", "cannot run row 2"),
    ("initial.u", "delta_r\n1e-5\n", "not a number"),
    ("initial.u[2]", "initial.u[2],delta_r\n-0.2,1e-5\n", "both a column"),
])
def test_bad_input_is_one_line(fit, text, message, tmp_path, capsys):
    assert main(["fit", "paper", _csv(tmp_path, text), "--fit", fit, "--out", str(tmp_path / "f.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1, err


def test_bad_law_and_missing_file(tmp_path, capsys):
    assert main(["fit", "paper", str(EXAMPLE_DATA), "--fit", FIT, "--law", "nope"]) == 2
    assert "--law: unknown contact law 'nope'" in capsys.readouterr().err
    assert main(["fit", "paper", str(tmp_path / "none.csv"), "--fit", FIT]) == 2
    assert "no such file" in capsys.readouterr().err


def test_without_sigmas_the_errors_come_from_the_residuals():
    """No sigma columns: each column weighed relative to its root mean square, the errors
    scaled by the residual variance. With noise of 1 % of each column's RMS (what that
    weighting assumes), the known values are within two standard errors."""
    columns = ("delta_r", "u_final[1]", "u_final[2]")
    exact = synthetic_measurements("paper", TRUTH, {"initial.u[2]": np.linspace(-0.15, -0.5, 8)}, columns, noise=0.0)
    plain = exact[["initial.u[2]", *columns]].copy()
    rng = np.random.default_rng(5)
    for column in columns:
        rms = np.sqrt(np.mean(plain[column] ** 2))
        plain[column] += 0.01 * rms * rng.standard_normal(len(plain))
    result = impactgen.fit("paper", plain, {"rod.yield_strength": (3e8, 1.1e9), "contact.friction": (0, 1)},
                           tolerance=LOOSE)
    assert not result.sigma_given and result.best.law == "three-phase"
    for key, parameter in result.parameters.items():
        assert parameter["determined"] and abs(parameter["value"] - TRUTH[key]) <= 2 * parameter["stderr"], key


def test_each_law_is_fitted_in_its_own_keys_and_the_true_one_ranks_first():
    """Impacts made by the Hunt-Crossley law (e = 0.6, mu = 0.25): its own key
    contact.restitution is fitted for it and left out of the three-phase fit (a three-phase
    scene refuses it), and the law that made the data ranks first."""
    truth = {"contact.restitution": 0.6, "contact.friction": 0.25}
    made_by = impactgen.load_scene("paper", {"contact.model": "hunt-crossley", "contact.restitution": 0.6})
    data = synthetic_measurements(made_by, truth, {"initial.u[2]": np.linspace(-0.15, -0.5, 6)},
                                  ("t_contact", "u_final[1]", "u_final[2]"), noise=0.01, seed=5)
    result = impactgen.fit("paper", data, "contact.restitution=0.2..0.95,contact.friction=0..1",
                           laws="three-phase,hunt-crossley", tolerance=LOOSE)
    fits = {f.law: f for f in result.laws}
    assert [p.key for p in fits["three-phase"].parameters] == ["contact.friction"]
    assert [f.law for f in result.laws][0] == "hunt-crossley"
    hc = fits["hunt-crossley"]
    for key, value, stderr in zip((p.key for p in hc.parameters), hc.values, hc.stderr):
        assert abs(value - truth[key]) <= 2 * stderr, key


def test_compare_gives_each_law_the_keys_it_reads(capsys):
    """--set of a law's own key goes to the laws that read it, not to the paper's law (which
    would refuse it)."""
    assert main(["compare", "paper", "--laws", "three-phase,hunt-crossley,kelvin-voigt", "--json",
                 "--set", "contact.restitution=0.64", "--set", "contact.stiffness=2e7",
                 "--set", "contact.damping=800"]) == 0
    rows = {row["law"]: row for row in json.loads(capsys.readouterr().out)["rows"]}
    assert set(rows) == {"three-phase", "hunt-crossley", "kelvin-voigt"}
    assert all(row["status"] == "ok" for row in rows.values())
    assert rows["hunt-crossley"]["delta_r"] == 0 < rows["three-phase"]["delta_r"]
