"""The C engine's methods: CVODE BDF (the default), CVODE Adams, and ARKODE's explicit
Runge-Kutta pair (method "erk"), which must give the same physics."""
from __future__ import annotations

import numpy as np
import pytest

import impactgen


@pytest.mark.parametrize("name", ["paper", "coulomb", "chain3-free-flight"])
def test_the_explicit_pair_gives_the_same_impact(name):
    scene = impactgen.load_scene(name)
    bdf, erk = impactgen.simulate(scene), impactgen.simulate(scene, method="erk")
    assert erk.success, erk.message
    assert [p.phase for p in erk.phases] == [p.phase for p in bdf.phases]
    assert [(a, b) for _, a, b in erk.impacts[0].stick_slip] == [(a, b) for _, a, b in bdf.impacts[0].stick_slip]
    a, b = bdf.summary, erk.summary
    for key in ("delta_max", "delta_r", "P_max", "t_contact", "T0", "Tf"):
        assert b[key] == pytest.approx(a[key], rel=1e-6), key
    np.testing.assert_allclose(b["u_final"], a["u_final"], rtol=1e-6, atol=1e-9)
    assert abs(b["energy"]["residual"]) < 1e-8 * b["T0"]


def test_the_explicit_pair_ignores_an_analytic_jacobian_and_keeps_dense_output():
    scene = impactgen.load_scene("paper", overrides={"solver.jacobian": "analytic"})
    r = impactgen.simulate(scene, method="erk", t_eval=np.linspace(0.0, 4e-4, 41), dense_output=True)
    assert r.success, r.message
    np.testing.assert_allclose(r.sol(r.sampled.t), r.sampled.y.T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.sol(r.t), r.y, rtol=0, atol=1e-12)
