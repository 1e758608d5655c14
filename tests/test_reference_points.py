"""Contact at every joint (issue 38, items 1 and 6): the scene key contact.joint_radius, and the
reference engine with the joints and the tip as contact points, each with its own laws, phase
and impacts, several of them in contact at once.

Every run to a time here sets solver.sustained_contact = false and simulates each rebound
(the reference engine's sustained contact is tested in tests/test_reference_free.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import impactgen
from impactgen import reference
from impactgen.errors import SceneError
from impactgen.reference import ChainModel, Contact, PointImpact, ReferenceModel
from impactgen.scene import parse_override, scene_from_dict, scene_from_text
from impactgen.validity import energy_warning
from conftest import built_both_ways

RESTING = {"initial.u": [0.0, 0.0], "solver.t_end": 0.05, "solver.sustained_contact": False}
# the issue's 3-link chain: its tip strikes at once, then joint 2 (near t = 0.117 s) and the tip
# strike again and again. 0.3 s covers two impacts of joint 2 in about 2 s of wall time; the
# issue's 2 s takes minutes (0.65 s in a slow test).
THREE_LINKS = {"chain.links": 3, "chain.length": [1, 1, 0.2], "initial.q_deg": [-30, -80, -20],
               "initial.u": [0, 0, -3], "solver.t_end": 0.3, "solver.sustained_contact": False}
# joint 1 and the tip on the surface at t = 0 (link 2 lies on it), both moving into it at 0.866 m/s
TWO_AT_ONCE = {"initial.q_deg": [-30, 0], "initial.u": [-1, 0], "solver.t_end": 0.002,
               "solver.sustained_contact": False}
SETTLED_DEPTH = 3.0  # a settling point stays within this many static Hertz penetrations
BUDGET_CLOSES = 1e-8  # |residual| over the budget's largest term, at the scenes' rtol 1e-10


def _depths(result) -> np.ndarray:
    """How far every point (rows: joint 1..n-1, the tip) lies below the surface at each sample."""
    L = np.array(result.scene.chain.length)[:, None]
    heights = np.cumsum(L * np.sin(result.trajectory.y[:, :result.n].T), axis=0)
    return ReferenceModel.from_scene(result.scene).contact.y_s - heights


def _assert_budget_closes(result) -> None:
    s, e = result.summary, result.summary["energy"]
    terms = (s["T0"], s["Tf"], e["W_normal"], e["W_friction"], e["W_gravity"])
    assert not energy_warning(result.scene, *terms, e["residual"]), e
    assert abs(e["residual"]) <= BUDGET_CLOSES * max(map(abs, terms)), e
    # each point's own works add up to the run's
    works = result.point_works
    assert sum(w["W_normal"] for w in works.values()) == pytest.approx(e["W_normal"], rel=1e-9, abs=1e-15)
    assert sum(w["W_friction"] for w in works.values()) == pytest.approx(e["W_friction"], rel=1e-9, abs=1e-15)


def _static_hertz_penetration(scene) -> float:
    """The tip's static load at the start (the chain at rest, the tip held on the surface) from
    the reference engine's chain, and the Hertz penetration under it."""
    chain = ChainModel.from_scene(scene)
    q, u = np.asarray(scene.q0), np.zeros(scene.n)
    Jy = chain.L * np.cos(q)
    free, loaded = Jy @ chain.accelerations(q, u, 0.0, 0.0), Jy @ chain.accelerations(q, u, 1.0, 0.0)
    contact = Contact.from_scene(scene, 0.0)
    return (3 * (-free / (loaded - free)) / (4 * contact.E_star * math.sqrt(contact.R))) ** (2 / 3)


# ----------------------------------------------------------------------------- the reference engine

def test_the_paper_chain_released_at_rest_settles():
    scene = impactgen.load_scene("paper", RESTING)
    result = reference.simulate(scene)
    assert result.status == "ok", result.message
    assert result.impacts[0].t_start == 0.0 and {i.point for i in result.impacts} == {"tip"}
    assert np.max(_depths(result)) < SETTLED_DEPTH * _static_hertz_penetration(scene)
    _assert_budget_closes(result)


@pytest.fixture(scope="module")
def three_links():
    return reference.simulate(impactgen.load_scene("paper", THREE_LINKS))


def test_the_issues_three_link_chain_rests_its_joint_on_the_surface(three_links):
    """Joint 2 no longer passes through the surface: it strikes it, and no point lies deeper
    than the deepest compression of its own impacts."""
    result = three_links
    assert result.status == "ok", result.message
    assert all(isinstance(i, PointImpact) for i in result.impacts)
    assert {i.point for i in result.impacts} == {"joint 2", "tip"}  # joint 1 cannot reach
    joint = [i for i in result.impacts if i.point == "joint 2"]
    assert 0.11 < joint[0].t_start < 0.12
    depths = _depths(result)
    for k, point in ((2, "joint 2"), (3, "tip")):
        deepest = max(i.delta_max for i in result.impacts if i.point == point)
        assert np.max(depths[k - 1]) <= deepest * (1 + 1e-9), k
        assert deepest < 1e-3  # a contact's depth, not a fall through the surface
    # the joint's own penetration and force are among the outputs
    assert np.max(result.outputs["delta_J2"]) == pytest.approx(max(i.delta_max for i in joint), rel=1e-9)
    assert np.max(result.outputs["F_J2"]) > 0 and "delta_J1" not in result.outputs
    _assert_budget_closes(result)


@pytest.mark.slow
def test_the_three_link_chain_settles_on_joint_2_and_the_tip():
    """Longer: joint 2 and the tip chatter from about 0.59 s on (each point's own chattering
    warning). The issue's full 2 s (953 impacts, 315 of joint 2; the chain comes to rest with
    its budget closing to 6e-11 J) takes several minutes here, so this runs to 0.65 s."""
    result = reference.simulate(impactgen.load_scene("paper", dict(THREE_LINKS, **{"solver.t_end": 0.65})))
    assert result.status == "ok", result.message
    assert np.max(_depths(result)[1:]) <= max(i.delta_max for i in result.impacts) * (1 + 1e-9)
    assert sum(i.point == "joint 2" for i in result.impacts) > 10
    assert any(w.startswith("joint 2: chattering") for w in result.warnings)
    _assert_budget_closes(result)


def test_a_joint_impact_has_its_own_works_and_coefficients(three_links):
    for impact in three_links.impacts:
        row = impact.to_dict()
        assert row["point"] == impact.point in ("joint 2", "tip")
        assert impact.W_normal_point < 0 and 0 < impact.e_N < 1 and 0 < impact.e_E < 1
        assert impact.v_n0 < 0  # its own normal speed at first contact: approaching
    works = three_links.point_works
    assert set(works) == {"joint 1", "joint 2", "tip"} and works["joint 1"] == {"W_normal": 0.0, "W_friction": 0.0}
    assert works["joint 2"]["W_normal"] < 0 and works["tip"]["W_normal"] < 0


def test_two_points_strike_at_once():
    result = reference.simulate(impactgen.load_scene("paper", TWO_AT_ONCE))
    assert result.status == "ok", result.message
    first = [i for i in result.impacts if i.t_start == 0.0]
    assert [i.point for i in first] == ["joint 1", "tip"]
    assert first[0].v_n0 == pytest.approx(first[1].v_n0, rel=1e-12) and first[0].v_n0 < 0
    assert result.phases[0].phase == "joint 1: elastic, tip: elastic"
    assert all(i.t_end is not None and i.W_normal_point < 0 for i in first)
    # while both touch, each impact's W_normal is every force's; its own is a part of it
    assert all(abs(i.W_normal_point) < abs(i.W_normal) for i in first)
    assert not any(w.startswith("chattering") for w in result.warnings)
    _assert_budget_closes(result)


def test_a_run_to_separation_ends_when_no_point_touches():
    scene = impactgen.load_scene("paper", {k: v for k, v in TWO_AT_ONCE.items() if k != "solver.t_end"})
    result = reference.simulate(scene)
    assert result.status == "ok" and len(result.impacts) == 2
    assert result.t[-1] == max(i.t_end for i in result.impacts)
    assert result.phases[-1].phase != "free"  # ended at the last point's separation


def test_a_smaller_joint_radius_dents_deeper():
    overrides = dict(TWO_AT_ONCE, **{"solver.t_end": 6e-4})
    default = reference.simulate(impactgen.load_scene("paper", overrides))
    sharp = reference.simulate(impactgen.load_scene("paper", dict(overrides, **{"contact.joint_radius": 0.001})))
    joint = [next(i for i in r.impacts if i.point == "joint 1") for r in (default, sharp)]
    assert joint[1].delta_max > 1.5 * joint[0].delta_max


def test_exact_coulomb_holds_two_points_together():
    """Both points of a link lying on the surface slip and stick under exact Coulomb
    friction (mu = 2): stuck together, their holding forces are solved jointly."""
    scene = impactgen.load_scene("paper", dict(TWO_AT_ONCE, **{"contact.friction": 2.0,
                                                              "contact.friction_mode": "coulomb"}))
    result = reference.simulate(scene)
    assert result.status == "ok", result.message
    assert any(s for s in (p.slip_state for p in result.phases) if "stick" in s)
    _assert_budget_closes(result)


def test_joints_that_never_touch_change_nothing():
    """Carried joints that stay off the surface leave the run bit for bit as the tip alone
    gives it (the issue's chain to its first separation: joint 2 can reach, but does not)."""
    scene = impactgen.load_scene("paper", {k: v for k, v in THREE_LINKS.items() if k != "solver.t_end"})
    carried = ReferenceModel.from_scene(scene)
    assert [p.index for p in carried.joints] == [2]
    alone = ReferenceModel(carried.chain, carried.contact, carried.n, carried.friction_state)
    a, b = reference.simulate(scene), reference.simulate(scene, model=alone)
    assert np.array_equal(a.trajectory.y, b.trajectory.y) and np.array_equal(a.t, b.t)
    assert a.summary == b.summary


# ----------------------------------------------------------------------------- the scene key

def test_joint_radius_defaults_to_the_tip_radius():
    scene = impactgen.load_scene("paper")
    assert scene.joint_radii == (0.005,) and scene.contact.joint_radius is None
    assert "joint_radius" not in scene.to_dict()["contact"]  # not given: it follows rod.tip_radius
    assert scene.replace({"rod.tip_radius": 0.002}).joint_radii == (0.002,)
    one = impactgen.load_scene("paper", {"chain.links": 1, "chain.length": 1.0, "chain.mass": 1.0,
                                         "initial.q_deg": [-70.0], "initial.u": [-0.1]})
    assert one.joint_radii == ()


def test_joint_radius_round_trips_and_overrides():
    base = impactgen.load_scene("paper", {"chain.links": 3, "chain.length": 1.0, "chain.mass": 1.0,
                                          "initial.q_deg": [-70, -60, -60], "initial.u": [-0.1, -0.2, -0.2]})
    every = base.replace({"contact.joint_radius": 0.003})
    assert every.joint_radii == (0.003, 0.003)
    listed = base.replace({"contact.joint_radius": [0.001, 0.002]})
    assert listed.joint_radii == (0.001, 0.002)
    assert listed.replace({"contact.joint_radius[2]": 0.004}).joint_radii == (0.001, 0.004)
    assert base.replace({"contact.joint_radius[2]": 0.004}).joint_radii == (0.005, 0.004)  # the rest: the tip's
    for scene in (every, listed):
        assert scene_from_text(scene.to_toml()) == scene
        assert scene_from_dict(scene.to_dict()) == scene
    key, value = parse_override("contact.joint_radius[1]=0.0025")
    assert base.replace({key: value}).joint_radii == (0.0025, 0.005)  # as --set gives it


def test_scene_with_gives_the_scene_read_in_full_for_joint_radii():
    base = impactgen.load_scene("paper", {"chain.links": 3, "chain.length": 1.0, "chain.mass": 1.0,
                                          "initial.q_deg": [-70, -60, -60], "initial.u": [-0.1, -0.2, -0.2]})
    cases = [{"contact.joint_radius": 0.002}, {"contact.joint_radius": [0.002, 0.003]},
             {"contact.joint_radius[1]": 0.002}, {"rod.tip_radius": 0.001, "contact.joint_radius[2]": 0.002},
             {"contact.joint_radius[2]": 0.002, "rod.tip_radius": 0.001}, {"contact.joint_radius[3]": 0.002},
             {"contact.joint_radius": [0.002]}, {"contact.joint_radius[1]": -1.0}]
    for overrides in cases:
        outcomes = built_both_ways(base, overrides)
        assert outcomes[0] == outcomes[1], overrides


@pytest.mark.parametrize("key, value, words", [
    ("contact.joint_radius", -0.001, "must be > 0"),
    ("contact.joint_radius", 0.0, "must be > 0"),
    ("contact.joint_radius", [0.001, 0.002], "expected 1 values (one per joint)"),
    ("contact.joint_radius", "sharp", "expected a number"),
    ("contact.joint_radius[2]", 0.001, "out of range"),
    ("contact.joint_radius[0]", 0.001, "numbered from 1"),
    ("contact.joint_radius[1]", math.inf, "finite"),
])
def test_a_bad_joint_radius_names_the_key(key, value, words):
    with pytest.raises(SceneError) as err:
        impactgen.load_scene("paper", {key: value})
    assert err.value.key == key and words in str(err.value)


def test_a_joint_may_start_on_the_surface_but_not_below_it():
    on = impactgen.load_scene("paper", {"initial.q_deg": [-30, 0]})  # link 2 lies on the surface
    assert on.n == 2
    with pytest.raises(SceneError) as err:
        impactgen.load_scene("paper", {"initial.q_deg": [-30, 10]})  # the tip above joint 1
    assert err.value.key == "initial.q"
    assert "link 1 starts below the surface" in str(err.value) and "joint 1" in str(err.value)
