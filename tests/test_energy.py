"""Energy: the work-energy budget closes; free motion conserves T + V."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import impactgen
from impactgen.scene import steel_chain_scene


def test_energy_budget_closes_on_the_paper_case(paper_result):
    s = paper_result.summary
    e = s["energy"]
    assert abs(e["residual"]) < 1e-6
    assert e["W_normal"] < 0 and e["W_friction"] < 0  # both dissipate
    # friction does about two thirds of the loss (MODEL section 7)
    assert 0.55 < e["W_friction"] / (e["W_normal"] + e["W_friction"]) < 0.8
    assert s["delta_T"] == pytest.approx(-(e["W_normal"] + e["W_friction"] + e["W_gravity"]), abs=1e-6)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_chains_of_one_to_six_links_impact_and_balance(n):
    result = impactgen.simulate(steel_chain_scene(n))
    s = result.summary
    assert result.status == "ok"
    assert result.phases[-1].ended_by == "separation"
    assert 0 < s["delta_r"] < s["delta_max"]
    assert abs(s["energy"]["residual"]) < 1e-6 * max(1.0, s["T0"])
    assert np.all(np.isfinite(result.y))


@pytest.mark.parametrize("n", [1, 3, 6])
def test_free_swing_conserves_total_energy(n):
    scene = steel_chain_scene(n)
    scene = scene.replace(surface_height=-100.0,
                          solver=dataclasses.replace(scene.solver, rtol=1e-10, atol=1e-12, t_end=1.0))
    result = impactgen.simulate(scene)
    assert result.impacts == []
    E = result.T + result.V
    assert np.max(np.abs(E - E[0])) < 1e-7 * max(1.0, np.max(np.abs(E)))
    assert result.t[-1] == pytest.approx(1.0)
