"""The C engine against the reference engine on free bodies and inclined surfaces (issue 46):
a free steel rod dropped at an angle onto a steel plate (to its first separation, and the
rod-drop example's three impacts, both ends in turn), the rocking-rod example's resting start,
the chain-on-slope example's first impacts, and the paper's pinned chain over a surface
inclined at 15 degrees, compared quantity by quantity as crosscheck.run_case compares
every scene (the tolerance of tests/test_reference.py's fast crosscheck, at its rtol).
"""
from __future__ import annotations

import numpy as np
import pytest

import impactgen
from impactgen import crosscheck

FAST_RTOL = 1e-9
FAST_TOL = 1e-5  # tests/test_reference.py's tolerance at rtol 1e-9

SCENES = {  # name: (the scene it changes, its changes)
    # a steel rod, 0.5 m, 10 mm diameter, its lower end (the tip) 1 cm above the plate, falling
    # at 1 m/s, drifting and turning: the tip strikes first
    "free-rod-drop": ("paper", {
        "chain.links": 1, "chain.length": 0.5, "chain.diameter": 0.01, "rod.material": "steel-a36",
        "surface.material": "steel-a36", "rod.tip_radius": 0.005, "chain.base": "free",
        "initial.base": [0.0, 0.26], "initial.base_velocity": [0.2, -1.0], "initial.q_deg": [-30.0],
        "initial.u": [0.5], "surface.height": 0.0, "contact.friction": 0.2}),
    # the paper's double pendulum over a surface that descends towards +x at 15 degrees
    "inclined-paper": ("paper", {"surface.angle_deg": 15.0}),
    # the example: the base strikes at 0.101 s, the tip at 0.213 s, the base again at 0.226 s (the
    # reference engine simulates every rebound: no sustained contact)
    "rod-drop": ("rod-drop", {"solver.t_end": 0.25, "solver.sustained_contact": False}),
    # a resting start: the rod laid nearly flat, its base end on the plate at rest
    "rocking-rod": ("rocking-rod", {"solver.t_end": 0.005, "solver.sustained_contact": False}),
    # the 3-link chain falling onto a 20 degree slope: joint 1 strikes at 0.083 s, joint 2 at 0.111 s
    "chain-on-slope": ("chain-on-slope", {"solver.t_end": 0.12, "solver.sustained_contact": False}),
}


def _scene(name: str) -> impactgen.Scene:
    base, overrides = SCENES[name]
    return crosscheck.with_tolerance(impactgen.load_scene(base, {**overrides, "name": name}), FAST_RTOL)


@pytest.mark.parametrize("name", SCENES)
def test_engines_agree_on_free_bodies_and_inclined_surfaces(name):
    report = crosscheck.run_case(_scene(name))
    for quantity, value in report.differences.items():
        assert value <= FAST_TOL, f"{quantity} differs by {value:.2e} on {name}"


def test_engines_agree_on_the_free_rods_base_point():
    """crosscheck.compare holds the links' angles and speeds; the base point's position (against
    the rod's length) and velocity (against its largest speed) where the runs end, here."""
    scene = _scene("free-rod-drop")
    c, ref = (impactgen.simulate(scene, engine=engine, warn=False) for engine in ("c", "reference"))
    assert c.success and ref.success, (c.message, ref.message)
    position, velocity = c.base[:, -1] - ref.base[:, -1], ref.base[2:]
    assert np.abs(position[:2]).max() <= FAST_TOL * sum(scene.chain.length)
    assert np.abs(position[2:]).max() <= FAST_TOL * np.abs(velocity).max()


def test_engines_agree_on_random_free_chains():
    """Random free chains (1 to 3 links, level or inclined, the friction modes), as
    `impactgen crosscheck --random` draws them, to their first separation."""
    rng = np.random.default_rng(7)
    for i in range(2):
        scene = crosscheck.random_free_scene(rng, i + 1, f"random-free-{i}", FAST_RTOL)
        report = crosscheck.run_case(scene)
        for quantity, value in report.differences.items():
            assert value <= FAST_TOL, f"{quantity} differs by {value:.2e} on {scene.name}"


def test_a_chain_that_never_moves_is_compared_on_the_chains_own_scales():
    """A pendulum hanging still above the surface ends with speeds and energies of rounding
    size in both engines: its final speeds and delta_T are compared against the chain's own
    scales (a thousandth of sqrt(g L), and the energy at that speed), not against each other."""
    scene = crosscheck.with_tolerance(impactgen.load_scene("paper", {
        "chain.links": 1, "chain.length": 1.0, "chain.mass": 1.0, "initial.q_deg": [-90.0], "initial.u": [0.0],
        "surface.height": -2.0, "solver.t_end": 0.1, "solver.sustained_contact": False}), FAST_RTOL)
    c, ref = (impactgen.simulate(scene, engine=engine, warn=False) for engine in ("c", "reference"))
    assert np.abs(ref.u).max() < 1e-15  # it never moves
    differences = crosscheck.compare(c, ref)
    assert differences["u_final"] <= FAST_TOL and differences["delta_T"] <= FAST_TOL, differences
