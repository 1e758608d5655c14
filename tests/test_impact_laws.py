"""Impact coefficients (docs/model.md section 9) and the rigid-body laws beside the compliant
contact (impact_laws.py, `impactgen compare`, docs/impact-laws.md)."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import impactgen
from impactgen import reference
from impactgen.errors import ImpactgenError
from impactgen.impact_laws import LAWS, RigidChain, solve_impact
from impactgen.results import COEFFICIENTS
from conftest import PAPER

SINGLE_BAR = {"chain.links": 1, "chain.length": 1.0, "chain.mass": 1.0, "chain.gravity": 0.0,
              "contact.friction": 0.0, "initial.q_deg": [-30.0], "initial.u": [-0.5]}
# Kane and Levinson's kind of case: the paper's chain striking with its tip sliding along -x at
# half its approach speed, e = 0.5, mu = 0.5. Friction stops the slip early in compression;
# Newton's law keeps pushing the tip the same way for the whole impulse and shoots it along +x.
KANE_LEVINSON = dict(q=np.radians([-60.0, -75.0]), u=np.array([-3.232, 2.380]), e=0.5, mu=0.5)


def _coefficients(result) -> dict[str, float]:
    return result.summary["coefficients"]


def test_frictionless_single_bar_coefficients_agree_and_the_rigid_laws_reproduce_it():
    scene = impactgen.load_scene(PAPER, overrides=SINGLE_BAR)
    table = impactgen.compare_laws(scene)
    c = table.iloc[0]
    assert c["e_N"] == pytest.approx(c["e_P"], abs=1e-3) and c["e_N"] == pytest.approx(c["e_E"], abs=1e-3)
    assert 0.5 < c["e_N"] < 0.95  # a plastic steel impact: well below 1
    u_compliant = abs(c["u_after[1]"])
    for _, row in table.iloc[1:].iterrows():
        assert row["du_max"] <= 1e-3 * u_compliant, row["law"]
        assert not row["gains_energy"]


@pytest.mark.parametrize("overrides", [
    {**SINGLE_BAR, "contact.model": "hertz"},
    {"chain.gravity": 0.0, "contact.friction": 0.0, "contact.model": "hertz"},
])
def test_hertz_contact_without_friction_or_gravity_restitutes_fully(overrides):
    result = impactgen.simulate(impactgen.load_scene(PAPER, overrides=overrides))
    for name in ("e_N", "e_P", "e_E"):
        assert _coefficients(result)[name] == pytest.approx(1.0, abs=1e-3), name
    assert _coefficients(result)["friction_share"] == 0.0 and _coefficients(result)["P_t"] == 0.0


def test_coefficients_from_the_c_tallies_equal_the_samples():
    result = impactgen.simulate(impactgen.load_scene(PAPER), t_eval=np.linspace(0.0, 4.6e-4, 4001))
    tallied, impact = _coefficients(result), result.impacts[0]
    assert tallied == pytest.approx(impact.coefficients(), rel=1e-12)  # the same three samples
    # and the impulses as quadratures of the sampled forces, split at maximum compression
    i_max = int(np.argmax(result.delta))
    t, F, F_f = result.t, result.F, result.F_f
    P_c, P_r = np.trapezoid(F[:i_max + 1], t[:i_max + 1]), np.trapezoid(F[i_max:], t[i_max:])
    assert tallied["P_c"] == pytest.approx(P_c, rel=2e-3) and tallied["P_r"] == pytest.approx(P_r, rel=2e-3)
    assert tallied["P_t"] == pytest.approx(np.trapezoid(F_f, t), rel=5e-3)
    assert tallied["e_N"] == pytest.approx(-result.v_By[-1] / result.v_By[0], rel=1e-3)
    # and the reference engine's, integrated by scipy
    ref = impactgen.simulate(result.scene, engine="reference")
    assert _coefficients(ref) == pytest.approx(tallied, rel=1e-6)


def test_coefficients_are_in_the_json_the_impacts_table_and_a_run_without_impact():
    result = impactgen.simulate(impactgen.load_scene(PAPER))
    assert set(COEFFICIENTS) <= set(result.impacts_frame().columns)
    data = json.loads(json.dumps(result.to_json_dict()))
    assert data["impacts"][0]["e_P"] == pytest.approx(_coefficients(result)["e_P"])
    assert data["summary"]["coefficients"]["v_n0"] < 0
    none = impactgen.simulate(impactgen.load_scene(PAPER, overrides={"initial.u": [0.1, 0.2]}))
    assert all(v is None for v in _coefficients(none).values())


def test_the_chains_own_mass_matrix_equals_the_reference_engines():
    rng = np.random.default_rng(3)
    for n in (1, 2, 5):
        scene = impactgen.load_scene(PAPER, overrides={"chain.links": n, "chain.length": list(rng.uniform(0.2, 2, n)),
                                                       "chain.mass": list(rng.uniform(0.1, 5, n)),
                                                       "initial.q_deg": [-60.0] * n, "initial.u": [-0.1] * n})
        q = rng.uniform(-3, 3, n)
        ours = RigidChain.from_scene(scene).mass_matrix(q)
        np.testing.assert_allclose(ours, reference.ChainModel.from_scene(scene).mass_matrix(q), rtol=1e-13)


def test_newtons_law_with_friction_gains_energy_where_the_energetic_law_does_not():
    chain, case = RigidChain((1.0, 1.0), (1.0, 1.0)), KANE_LEVINSON
    newton = solve_impact(chain, case["q"], case["u"], "newton", case["e"], case["mu"])
    energetic = solve_impact(chain, case["q"], case["u"], "energetic", case["e"], case["mu"])
    assert newton.energy_change > 0.5 * newton.T_before  # 4.19 J before, 7.07 J after
    assert energetic.energy_change < 0
    assert energetic.v_after[0] == pytest.approx(0.0, abs=1e-12)  # the tip sticks
    assert newton.v_after[1] == pytest.approx(-case["e"] * newton.v_before[1], rel=1e-12)


@st.composite
def impacts(draw):
    n = draw(st.integers(1, 6))
    floats = lambda lo, hi: st.floats(lo, hi, allow_nan=False, allow_infinity=False)  # noqa: E731
    chain = RigidChain(tuple(draw(floats(0.1, 2.0)) for _ in range(n)), tuple(draw(floats(0.05, 10.0)) for _ in range(n)))
    q = np.array([draw(floats(-math.pi, math.pi)) for _ in range(n)])
    u = np.array([draw(floats(-10.0, 10.0)) for _ in range(n)])
    return chain, q, u, draw(floats(0.0, 1.0)), draw(floats(0.0, 2.0))


@settings(max_examples=300, deadline=None)
@given(impacts())
def test_the_energetic_law_never_gains_energy(case):
    chain, q, u, e, mu = case
    if not chain.tip_jacobian(q)[1] @ u < -1e-6:
        return  # the tip does not approach the surface
    try:
        out = solve_impact(chain, q, u, "energetic", e, mu)
    except ImpactgenError as exc:
        assert "jams" in str(exc)  # Painleve's paradox: no solution, said so
        return
    assert out.energy_change <= 1e-10 * out.T_before
    assert out.v_after[1] >= -1e-9 * abs(out.v_before[1])  # the tip leaves (or rests on) the surface


def test_bad_law_input_is_one_clear_error():
    chain = RigidChain((1.0,), (1.0,))
    with pytest.raises(ImpactgenError, match="unknown impact law"):
        solve_impact(chain, [-0.5], [-1.0], "hooke", 0.5, 0.0)
    with pytest.raises(ImpactgenError, match=">= 0"):
        solve_impact(chain, [-0.5], [-1.0], "newton", -0.5, 0.0)
    with pytest.raises(ImpactgenError, match="does not approach"):
        solve_impact(chain, [-0.5], [1.0], "poisson", 0.5, 0.0)
    assert set(LAWS) == {"newton", "poisson", "energetic"}


def test_compare_cli_prints_the_compliant_run_and_each_law():
    run = subprocess.run([sys.executable, "-m", "impactgen.cli", "compare", "paper"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0].startswith("compliant impact: e_N = ")
    assert [line.split()[0] for line in lines[2:]] == ["compliant", "newton", "poisson", "energetic"]
    data = json.loads(subprocess.run([sys.executable, "-m", "impactgen.cli", "compare", "paper", "--json"],
                                     capture_output=True, text=True, check=True).stdout)
    assert [r["law"] for r in data["rows"]] == ["compliant", "newton", "poisson", "energetic"]
