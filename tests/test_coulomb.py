"""Exact Coulomb friction (MODEL section 5): stick and slip by events, no regularization."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import impactgen


def _run(paper_scene, **contact):
    return impactgen.simulate(paper_scene.replace(contact=dataclasses.replace(paper_scene.contact, **contact)))


@pytest.fixture(scope="module")
def stick_case(paper_scene):
    """mu = 2: the tip slips, sticks during restitution, and slips again before it leaves."""
    return _run(paper_scene, friction=2.0, friction_mode="coulomb")


def test_paper_case_reverses_its_slip_during_restitution(paper_scene, paper_result):
    result = _run(paper_scene, friction_mode="coulomb")
    s = result.summary
    assert [(a, b) for _, a, b in result.impacts[0].stick_slip] == [("slip-", "slip+")]
    t_reverse = s["stick_slip"][0]["t"]
    restitution = [p for p in result.phases if p.phase == "restitution"]
    assert restitution[0].t0 < t_reverse < restitution[-1].t1  # v_Bx changes sign in restitution
    # the regularized law with eps = 1e-6 m/s is within its regularization error of the exact law
    np.testing.assert_allclose(s["u_final"], paper_result.summary["u_final"], rtol=1e-6)
    assert s["delta_r"] == pytest.approx(paper_result.summary["delta_r"], rel=1e-8)
    assert abs(s["energy"]["residual"]) < 1e-8 * s["T0"]


def test_stuck_tip_holds_still_within_the_friction_cone(stick_case):
    states = [(a, b) for _, a, b in stick_case.impacts[0].stick_slip]
    assert states == [("slip-", "stick"), ("stick", "slip-")]
    stuck = [p for p in stick_case.phases if p.slip_state == "stick"]
    assert len(stuck) == 1
    inside = (stick_case.t > stuck[0].t0) & (stick_case.t <= stuck[0].t1)
    v_scale = np.max(np.abs(stick_case.v_B))
    assert np.max(np.abs(stick_case.v_Bx[inside])) < 1e-9 * v_scale
    F, F_f = stick_case.F[inside], stick_case.F_f[inside]
    # within the cone, to 1e-9 of the force scale (the last sample is the slip event itself,
    # located to CVODE's root tolerance)
    assert np.all(np.abs(F_f) <= 2.0 * F + 1e-9 * 2.0 * np.max(F))
    # it leaves the stick when the holding force reaches the cone, slipping against it
    assert stuck[0].ended_by == "slip_backward" and F_f[-1] == pytest.approx(2.0 * F[-1], rel=1e-6)
    slipping = ~inside & (stick_case.phase != "free")
    np.testing.assert_allclose(np.abs(stick_case.F_f[slipping]), 2.0 * stick_case.F[slipping], rtol=1e-12)


def test_energy_budget_closes_through_stick_and_slip(stick_case):
    e = stick_case.summary["energy"]
    assert abs(e["residual"]) < 1e-8 * stick_case.summary["T0"]
    assert e["W_friction"] < 0


def test_regularized_friction_converges_to_the_exact_law(paper_scene, stick_case):
    exact = stick_case.summary
    errors = []
    for eps in (1e-4, 1e-6):
        s = _run(paper_scene, friction=2.0, friction_eps=eps).summary
        errors.append(np.max(np.abs(np.subtract(s["u_final"], exact["u_final"]))))
        assert s["delta_T"] == pytest.approx(exact["delta_T"], rel=10 * eps)
    assert errors[1] < errors[0] / 10  # the regularization error shrinks with eps


def test_coulomb_needs_fewer_steps_than_stiff_regularization(paper_scene, stick_case):
    stiff = _run(paper_scene, friction=2.0, friction_eps=1e-10)
    assert stick_case.stats["nsteps"] < stiff.stats["nsteps"]
    assert stiff.stats["nsteps"] < 10 * stick_case.stats["nsteps"]
