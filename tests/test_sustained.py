"""Repeated impacts to a time: chattering ends in sustained contact, a resting tip rests."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import impactgen
from impactgen.scene import steel_chain_scene


def _to_time(scene, t_end, **solver):
    return scene.replace(solver=dataclasses.replace(scene.solver, t_end=t_end, **solver))


@pytest.fixture(scope="module")
def settled(paper_scene):
    """The paper's chain for 3 s with exact Coulomb friction: it chatters, rests, slides, sticks."""
    scene = _to_time(paper_scene, 3.0).replace(
        contact=dataclasses.replace(paper_scene.contact, friction_mode="coulomb"))
    return impactgen.simulate(scene)


def test_chattering_impacts_end_in_sustained_contact(settled):
    sustained = [p for p in settled.phases if p.phase == "sustained"]
    assert sustained and sustained[0].t0 < 1.0  # the chattering starts near t = 0.97 s
    assert [p.slip_state for p in sustained] == ["slip+", "stick"]  # slides, then sticks
    assert sustained[-1].ended_by == "t_end"
    assert settled.warnings == [] or all("chattering" not in w for w in settled.warnings)
    inside = settled.phase == "sustained"
    assert np.all(settled.F[inside] > 0)  # pressed onto the surface throughout
    assert np.max(np.abs(settled.v_By[inside])) < 1e-8  # and held there
    assert settled.T[-1] < 1e-15  # at rest


def test_impact_count_does_not_depend_on_the_tolerance(paper_scene, settled):
    loose = impactgen.simulate(_to_time(paper_scene, 3.0, rtol=1e-8, atol=1e-10).replace(
        contact=dataclasses.replace(paper_scene.contact, friction_mode="coulomb")))
    assert len(loose.impacts) == len(settled.impacts)
    np.testing.assert_allclose(loose.q[:, -1], settled.q[:, -1], atol=1e-5)


def test_resting_chain_is_in_static_equilibrium(settled):
    """At rest, gravity's generalized forces equal those of the tip forces: dV/dq = J_B^T F_B."""
    (m1, m2), (L1, L2), g = settled.scene.chain.mass, settled.scene.chain.length, settled.scene.chain.gravity
    q1, q2 = settled.q[:, -1]
    dV_dq = np.array([(m1 / 2 + m2) * g * L1 * np.cos(q1), m2 / 2 * g * L2 * np.cos(q2)])
    F, F_f = settled.F[-1], settled.F_f[-1]
    tip_forces = np.array([-L1 * np.sin(q1) * F_f + L1 * np.cos(q1) * F,
                           -L2 * np.sin(q2) * F_f + L2 * np.cos(q2) * F])
    np.testing.assert_allclose(tip_forces, dV_dq, rtol=1e-8)
    assert abs(F_f) < settled.scene.contact.friction * F  # inside the friction cone


def test_whole_run_energy_balance(settled):
    T, V, Wn, Wf = settled.T, settled.V, settled.W_normal, settled.W_friction
    residual = (T[-1] - T[0]) - ((Wn[-1] - Wn[0]) + (Wf[-1] - Wf[0]) + (V[0] - V[-1]))
    energy_scale = abs(V[0]) + T[0]  # the budget subtracts potential energies of this size
    assert abs(residual) < 1e-8 * energy_scale
    assert Wf[-1] < 0 and Wn[-1] < 0


def test_without_sustained_contact_the_chattering_is_flagged(paper_scene):
    result = impactgen.simulate(_to_time(paper_scene, 1.0, sustained_contact=False))
    assert "sustained" not in {p.phase for p in result.phases}
    assert any("chattering" in w for w in result.warnings)


def test_a_bar_comes_to_rest_in_compliant_contact_under_half_its_weight():
    """A single bar: the tip settles into the surface without leaving it again; at rest the
    pin and the surface share the weight, F = m g / 2."""
    scene = steel_chain_scene(1)
    result = impactgen.simulate(_to_time(scene, 3.0))
    m, g = scene.chain.mass[0], scene.chain.gravity
    assert result.phases[-1].phase in ("restitution", "reloading") and result.phases[-1].ended_by == "t_end"
    assert result.F[-1] == pytest.approx(m * g / 2, rel=1e-3)
    assert abs(result.u[0, -1]) < 1e-6


def test_lift_off_ends_sustained_contact():
    # a three-link chain that rests, slides without friction for 1.4 s, and is lifted off
    scene = steel_chain_scene(3)
    scene = _to_time(scene, 3.0, rtol=1e-8, atol=1e-10).replace(
        u0=(-1.8352009519918067, 2.296055502946336, -3.728728680036806),
        contact=dataclasses.replace(scene.contact, friction=0.0))
    result = impactgen.simulate(scene)
    held = [p for p in result.phases if p.phase == "sustained"]
    assert [p.ended_by for p in held] == ["lift_off"]
    inside = result.phase == "sustained"
    assert abs(result.F[inside][-1]) < 1e-9 * np.max(result.F[inside])  # the force fell to zero
    after = result.phases[result.phases.index(held[0]) + 1]
    assert after.phase == "free" and after.t0 == held[0].t1
    T, V, Wn = result.T, result.V, result.W_normal
    assert abs((T[-1] - T[0]) - (Wn[-1] - Wn[0] + V[0] - V[-1])) < 1e-6 * (T[0] + abs(V[0]))


def test_a_tip_that_never_separates_says_so():
    from impactgen.crosscheck import random_scene
    rng = np.random.default_rng(2026)
    scenes = [random_scene(rng, int(rng.integers(1, 7)), f"random-{i}", 1e-9) for i in range(19)]
    resting = scenes[18]  # a bar whose tip stays in contact (its random-scene t_max is 0.05 s)
    result = impactgen.simulate(resting)
    assert result.status == "ok" and "came to rest" in result.message
    assert result.impacts[0].t_end is None and result.summary["t_contact"] == 0.0
