"""Figures docs/model.md states about the published law, computed again (issue 49)."""
from __future__ import annotations

import pytest

import impactgen
from impactgen.laws import YIELD_ONSET, contact_constants, hertz_force


def test_the_published_law_drops_the_force_by_a_tenth_at_the_switch():
    """At delta = 1.9 delta_c the Jackson-Green law gives 134.1 N where Hertz gives 149.0 N on
    the paper's impact (docs/model.md section 4): the engine's force on either side of the switch."""
    scene = impactgen.load_scene("paper")
    c = contact_constants(scene)
    assert hertz_force(YIELD_ONSET * c.delta_c, c.E_star, c.R) == pytest.approx(149.0, abs=0.05)
    switch = next(p.t1 for p in impactgen.simulate(scene).phases if p.phase == "elastic")
    around = impactgen.simulate(scene, t_eval=[switch - 1e-10, switch + 1e-10])
    assert list(around.phase) == ["elastic", "elastoplastic"]
    before, after = around.F
    assert before == pytest.approx(149.0, abs=0.05) and after == pytest.approx(134.1, abs=0.05)
    assert 1 - after / before == pytest.approx(0.10, abs=0.005)
