"""The chain's closed-form equations (used beyond KANE_MAX_LINKS links, where Kane's method
costs minutes) against Kane's method (sympy.physics.mechanics) and the reference engine."""
from __future__ import annotations

import pytest
import sympy as sm

import impactgen
from impactgen.codegen.mechanics import KANE_MAX_LINKS, chain_equations, closed_form_chain, derive_chain
from impactgen.scene import steel_chain_scene


def _parts(eq):
    return (list(eq.mass_matrix) + list(eq.forcing) + list(eq.tip_position) + list(eq.tip_velocity)
            + list(eq.kinetic_energy) + [eq.potential_energy])


@pytest.mark.parametrize("n", range(1, 7))
def test_closed_form_equals_kanes_method(n):
    kane, closed = derive_chain(n), closed_form_chain(n)
    for a, b in zip(_parts(kane), _parts(closed), strict=True):
        assert sm.simplify(sm.expand_trig(a - b)) == 0


def test_the_generator_switches_to_the_closed_form_beyond_kanes_range():
    # the same arguments as the generator passes them (lru_cache keys derive_chain(8) and
    # derive_chain(8, False, False) apart)
    pinned_level = (False, False)  # free, inclined
    assert chain_equations(KANE_MAX_LINKS) is derive_chain(KANE_MAX_LINKS, *pinned_level)
    assert chain_equations(KANE_MAX_LINKS + 1) is closed_form_chain(KANE_MAX_LINKS + 1, *pinned_level)
    assert chain_equations(KANE_MAX_LINKS, True, True) is derive_chain(KANE_MAX_LINKS, True, True)


@pytest.mark.slow
def test_a_long_chain_agrees_with_the_reference_engine():
    """12 links (closed form in the C) against the reference engine's own derivation."""
    scene = steel_chain_scene(12)
    c = impactgen.simulate(scene).summary
    ref = impactgen.simulate(scene, engine="reference").summary
    for key in ("delta_max", "delta_r", "P_max", "T0", "Tf"):
        assert c[key] == pytest.approx(ref[key], rel=1e-5), key
    assert c["u_final"] == pytest.approx(ref["u_final"], rel=1e-5, abs=1e-8)


@pytest.mark.parametrize("n, free, inclined", [(1, True, False), (2, True, True), (3, True, False),
                                               (2, False, True), (1, True, True)])
def test_closed_form_of_free_and_inclined_chains_equals_kanes_method(n, free, inclined):
    """A free base point (two more coordinates) and gravity along an inclined surface, in both
    derivations."""
    kane, closed = derive_chain(n, free, inclined), closed_form_chain(n, free, inclined)
    parts = _parts(kane) + list(kane.joint_x) + list(kane.joint_y)
    others = _parts(closed) + list(closed.joint_x) + list(closed.joint_y)
    for a, b in zip(parts, others, strict=True):
        assert sm.simplify(sm.expand_trig(a - b)) == 0
