"""The C engine against the reference engine on free bodies and inclined surfaces (issue 46):
a free steel rod dropped at an angle onto a steel plate (to its first separation, and the
rod-drop example's three impacts, both ends in turn), the rocking-rod example's first impacts (a damped law),
the chain-on-slope example's first impacts, the paper's pinned chain over a surface
inclined at 15 degrees, compared quantity by quantity as crosscheck.run_case compares
every scene (the tolerance of tests/test_reference.py's fast crosscheck, at its rtol); and a
rod laid flat at delta = 0 that comes to rest in sustained contact (on a level plate, and
stuck on a slope), compared where it rests.
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
    # runs simulate every rebound: no sustained contact)
    "rod-drop": ("rod-drop", {"solver.t_end": 0.25, "solver.sustained_contact": False}),
    # the example's first three impacts under Flores's damped law: the base at 0.032 s, the tip at
    # 0.067 s, the base again at 0.069 s
    "rocking-rod": ("rocking-rod", {"solver.t_end": 0.07, "solver.sustained_contact": False}),
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


SETTLING = {  # the rod laid flat at delta = 0, run with sustained contact (the default)
    "level": {},
    "slope": {"surface.angle_deg": 10.0, "contact.friction": 0.3, "contact.friction_mode": "coulomb"},
}


@pytest.mark.parametrize("case", SETTLING)
def test_engines_agree_on_a_rod_laid_flat_that_comes_to_rest(case):
    """Both ends vibrate on the plate until their reloads peak (1.34 ms), where each engine holds
    them in sustained contact to the end: the same switches at the same times, the same depths,
    forces and works where the rod rests (crosscheck.compare's speed against the run's largest
    is rounding against rounding here: the flat rod does not turn)."""
    scene = crosscheck.with_tolerance(impactgen.load_scene("rod-drop", {
        "initial.q_deg": [0.0], "initial.base": [0.0, 0.0], "solver.t_end": 0.01, **SETTLING[case]}), FAST_RTOL)
    c, ref = (impactgen.simulate(scene, engine=engine, warn=False) for engine in ("c", "reference"))
    assert c.success and ref.success, (c.message, ref.message)
    for impacts in (c.impacts, ref.impacts):
        assert sorted(i.point for i in impacts) == ["base", "tip"]
        assert all(i.t_end is None and i.switches[-1][2] == "sustained" for i in impacts)
    held = {engine: {i.point: i.switches[-1][0] for i in r.impacts} for engine, r in (("c", c), ("ref", ref))}
    for point in ("base", "tip"):
        assert held["c"][point] == pytest.approx(held["ref"][point], rel=FAST_TOL)
    for name in ("delta", "delta_J0", "F", "F_J0"):
        assert c.outputs[name][-1] == pytest.approx(ref.outputs[name][-1], rel=FAST_TOL), name
    assert np.abs(c.base[:2, -1] - ref.base[:2, -1]).max() <= FAST_TOL * c.delta[-1]
    for work in ("W_normal", "W_friction", "W_gravity"):
        a, b = c.summary["energy"][work], ref.summary["energy"][work]
        assert abs(a - b) <= FAST_TOL * abs(c.summary["energy"]["W_gravity"]), work
