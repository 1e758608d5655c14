"""Contact at the joints in the generated C (issue 38): every joint that can reach the surface
has the tip's contact laws on a state of its own; the others are pruned from the model."""
from __future__ import annotations

import numpy as np
import pytest

import impactgen
from impactgen.codegen.spec import ModelSpec
from impactgen.engines import model_spec, reachable_joints

# The issue's 3-link chain (the paper's bars of 1 kg): the tip starts on the surface, joint 2
# lands near t = 0.117 s.
THREE_LINKS = {"chain.links": 3, "chain.length": [1, 1, 0.2], "initial.q_deg": [-30, -80, -20],
               "initial.u": [0, 0, -3], "solver.t_end": 2}
# Released at rest with joint 2 1.5 cm above the surface: it lands first and comes to rest on it.
JOINT_LANDS = {"chain.links": 3, "chain.length": [1, 1, 0.2], "initial.q_deg": [-30, -80, 60],
               "initial.u": [0, 0, 0], "surface.height": -1.5, "solver.t_end": 1}
CONTACT_DEPTH = 1e-3  # m: far deeper than any of these impacts dents (0.2 mm at most)


def _budget_closes(result) -> bool:
    energy = result.summary["energy"]
    scale = max(abs(energy["W_normal"]), abs(energy["W_gravity"]), result.summary["T0"])
    return abs(energy["residual"]) < 1e-6 * scale


def _points(result) -> set[str]:
    return {impact.point for impact in result.impacts}


def test_only_the_joints_that_can_reach_the_surface_get_contact_code():
    paper = impactgen.load_scene("paper")
    assert reachable_joints(paper) == () and model_spec(paper).joints == ()
    assert model_spec(impactgen.load_scene("paper", THREE_LINKS)).joints == (2,)
    # a change of numbers that lets a joint reach the surface gets the model that has it
    higher = paper.replace({"initial.q_deg": [-10, -45]})  # the surface at the tip, now 0.88 m below the pivot
    assert model_spec(higher).joints == (1,)
    assert model_spec(higher).slug.endswith("-joints1")
    assert ModelSpec(2).to_json() == ModelSpec(2, joints=()).to_json()  # a tip-only model keeps its key


def test_the_issues_three_link_chain_lands_on_joint_2_and_stays_above_the_floor():
    result = impactgen.simulate(impactgen.load_scene("paper", THREE_LINKS))
    assert result.status == "ok", result.message
    assert _points(result) == {"tip", "joint 2"}
    joint = [impact for impact in result.impacts if impact.point == "joint 2"]
    assert 0.11 < joint[0].t_start < 0.12 and joint[0].delta_max > 0
    outputs = result.trajectory.outputs
    assert 0 < np.max(outputs["delta_J2"]) < CONTACT_DEPTH
    assert np.max(outputs["delta_J2"]) == pytest.approx(max(i.delta_max for i in joint), rel=1e-6)
    assert np.max(outputs["delta"]) < CONTACT_DEPTH
    assert _budget_closes(result)
    # the summary is every point's: all impacts counted, and per point
    assert result.summary["impacts"] == len(result.impacts)
    assert result.summary["point_impacts"] == {"joint 1": 0, "joint 2": len(joint), "tip": len(result.impacts) - len(joint)}
    assert result.summary["delta_max"] == max(i.delta_max for i in result.impacts)


def test_a_joint_that_lands_first_comes_to_rest_on_the_surface():
    result = impactgen.simulate(impactgen.load_scene("paper", JOINT_LANDS))
    assert result.status == "ok", result.message
    first = result.impacts[0]
    assert first.point == "joint 2" and 0.05 < first.t_start < 0.065
    last = [impact for impact in result.impacts if impact.point == "joint 2"][-1]
    assert last.t_end is None and last.switches[-1][2] == "sustained"  # chattering ends held on the surface
    F = result.trajectory.outputs["F_J2"]
    assert F[-1] > 0 and np.max(result.trajectory.outputs["delta_J2"]) < CONTACT_DEPTH
    assert _budget_closes(result)


def test_two_points_hitting_at_once_both_begin_contact():
    """Joint 1 and the tip start on the surface, both moving into it at the same speed."""
    scene = impactgen.load_scene("paper", {"initial.q_deg": [-30, 0], "initial.u": [-1, 0],
                                           "surface.height": "initial", "solver.t_end": 0.01})
    result = impactgen.simulate(scene)
    assert result.status == "ok", result.message
    starts = {impact.point: impact.t_start for impact in result.impacts[:2]}
    assert starts == {"tip": 0.0, "joint 1": 0.0}
    outputs = result.trajectory.outputs
    assert outputs["delta_rate"][0] == pytest.approx(outputs["delta_rate_J1"][0])  # the same normal speed
    assert all(impact.t_end is not None for impact in result.impacts[:2])  # both rebound
    assert _budget_closes(result)


def test_each_impact_names_its_point_in_the_tables():
    result = impactgen.simulate(impactgen.load_scene("paper", dict(THREE_LINKS, **{"solver.t_end": 0.3})))
    rows = [impact.to_dict() for impact in result.impacts]
    assert [row["point"] for row in rows[:3]] == ["tip", "tip", "joint 2"]
    assert set(result.impacts_frame()["point"]) == {"tip", "joint 2"}


@pytest.mark.parametrize("mu", [0.5, 2.0])
def test_exact_coulomb_friction_sticks_and_slips_at_the_joints_too(mu):
    """A joint comes to rest on the surface stuck and slipping by the tip's rules; where the
    last link lies flat, its two ends share the holding force and neither is left stuck
    beyond mu F (the run would fail naming the missed slip)."""
    scene = impactgen.load_scene("paper", dict(JOINT_LANDS, **{"contact.friction_mode": "coulomb",
                                                                "contact.friction": mu}))
    result = impactgen.simulate(scene)
    assert result.status == "ok", result.message
    joint = [impact for impact in result.impacts if impact.point == "joint 2"]
    labels = {to for impact in joint for _, _, to in impact.stick_slip}
    assert "stick" in labels and labels & {"slip+", "slip-"}
    outputs = result.trajectory.outputs
    held = outputs["F_J2"] > 0
    assert np.all(np.abs(outputs["F_f_J2"][held]) <= mu * outputs["F_J2"][held] * (1 + 1e-6) + 1e-9)
    assert _budget_closes(result)


def test_each_point_has_its_own_works_and_they_add_up_to_the_budgets():
    result = impactgen.simulate("falling-chain", record_steps=False)
    assert result.status == "ok", result.message
    works = result.point_works
    assert set(works) == {"tip", "joint 1", "joint 2", "joint 3", "joint 4", "joint 5"}
    assert all(w["W_normal"] < 0 and w["W_friction"] < 0 for w in works.values())  # each point takes energy
    energy = result.summary["energy"]
    for kind in ("W_normal", "W_friction"):
        assert sum(w[kind] for w in works.values()) == pytest.approx(energy[kind], rel=1e-12)
    counts = result.summary["point_impacts"]
    assert sum(counts.values()) == result.summary["impacts"] == len(result.impacts)
    assert sum(count for point, count in counts.items() if point != "tip") > 0
    assert result.summary["first_point"] in range(1, 7)
    assert _budget_closes(result)


def test_the_engines_agree_on_several_contact_points():
    """The C engine against the independent reference engine on scenes where joints strike:
    every impact of every point, the final state and the trajectory, to the single-point
    crosscheck's tolerance (1e-7 at rtol 1e-11; here 1e-10)."""
    from impactgen import crosscheck
    reports = crosscheck.run(crosscheck.points_scenes(1e-10))
    for report in reports:
        assert max(report.differences.values()) < 1e-7, (report.scene.name, report.differences)


def test_each_point_is_judged_by_its_own_contact_constants():
    """A joint's impacts are checked against the constants of its own radius (here 0.5 m:
    its dents stay elastic, where the tip's 5 mm would have yielded), as the C model derived
    them, and as the scene gives them."""
    from impactgen.validity import point_constants, validity_warnings
    scene = impactgen.load_scene("paper", {**JOINT_LANDS, "solver.t_end": 0.3, "contact.joint_radius": [0.005, 0.5]})
    result = impactgen.simulate(scene, record_steps=False)
    assert result.status == "ok", result.message
    joint = point_constants(scene, "joint 2")
    assert result.contact["joint 2"].R == 0.5
    assert result.contact["joint 2"].delta_c == pytest.approx(joint.delta_c, rel=1e-12)
    assert result.contact["tip"].delta_c == pytest.approx(point_constants(scene, "tip").delta_c, rel=1e-12)
    first_joint = next(i for i in result.impacts if i.point == "joint 2")
    assert first_joint.delta_max < joint.delta_c < first_joint.delta_max * 100  # elastic for its radius, not the tip's
    assert any("at joint 2, the elastic limit was never reached" in w for w in result.warnings), result.warnings
    assert validity_warnings(result.scene, result.impact_records) == result.warnings


def test_chattering_is_judged_point_by_point():
    """Two points' impacts overlap in time without either point chattering; one point whose
    flights shrink is named."""
    from impactgen.results import Impact
    from impactgen.validity import chattering_by_point

    def impact(point, t0, t1):
        found = Impact(t0, 0, t1, 0)
        found.point = point
        return found
    apart = [impact("joint 2", 0.0, 0.01), impact("tip", 0.011, 0.02), impact("joint 2", 0.5, 0.51),
             impact("tip", 0.6, 0.61)]
    assert chattering_by_point(sorted(apart, key=lambda i: i.t_start)) == []
    settling = apart + [impact("tip", 0.611, 0.62)]
    found = chattering_by_point(sorted(settling, key=lambda i: i.t_start))
    assert len(found) == 1 and found[0].startswith("tip: chattering from impact 2 on")


def test_every_point_has_its_own_works_impulses_and_coefficients():
    """Each joint's own works and impulses are integrated (W_normal_J2, P_normal_J2, ...), so a
    joint's impact has its coefficients of restitution as the tip's has (the crosscheck holds
    them to the reference engine's); each point's impacts' own works add up to its works
    over the run."""
    scene = impactgen.load_scene("paper", {**THREE_LINKS, "solver.t_end": 0.3, "solver.sustained_contact": False})
    result = impactgen.simulate(scene)
    assert result.status == "ok", result.message
    assert {"W_normal_J2", "W_friction_J2", "P_normal_J2", "P_friction_J2"} <= set(result.state_names)
    for point, works in result.point_works.items():
        own = [i for i in result.impacts if i.point == point]
        assert own and all(0 < i.e_N < 1 and 0 < i.e_P < 1 and 0 < i.e_E < 1 for i in own if i.t_end is not None)
        assert sum(i.W_normal_point for i in own) == pytest.approx(works["W_normal"], rel=1e-9)
        assert sum(i.W_friction_point for i in own) == pytest.approx(works["W_friction"], rel=1e-9)
    first_tip = next(i for i in result.impacts if i.point == "tip")
    assert result.summary["coefficients"]["e_N"] == pytest.approx(first_tip.e_N, rel=1e-12)


@pytest.mark.parametrize("mu", [0.3, 0.5])
def test_each_points_stick_slip_records_follow_on_from_each_other(mu):
    """Every stick-slip switch of a point starts from where its last one left it, also when
    the switch of another point releases it (a stuck point pushed beyond mu F): at mu 0.3
    and 0.5 joint 2 is released so at 0.60 s and 0.53 s, and its record named the state of
    an earlier switch."""
    scene = impactgen.load_scene("paper", {**JOINT_LANDS, "solver.t_end": 0.7, "contact.friction_mode": "coulomb",
                                           "contact.friction": mu})
    result = impactgen.simulate(scene, record_steps=False)
    assert result.status == "ok", result.message
    links = [(a, b) for impact in result.impacts for a, b in zip(impact.stick_slip, impact.stick_slip[1:])]
    assert len(links) > 30 and all(a[2] == b[1] for a, b in links), [(a, b) for a, b in links if a[2] != b[1]]


def test_the_switch_records_are_one_stream_each_naming_its_point(monkeypatch):
    """C writes, at a switch, one record per point whose switch acted, in point order, each
    once, each with that point's own states; none at the end time. Each point's records follow
    on from each other, and the run's segments are its switches plus the one the end time ended."""
    from impactgen.session import EngineSession
    runs = []
    run = EngineSession.run
    monkeypatch.setattr(EngineSession, "run", lambda self, *a, **k: runs.append(run(self, *a, **k)) or runs[-1])
    scene = impactgen.load_scene("paper", {**JOINT_LANDS, "solver.t_end": 0.7, "contact.friction_mode": "coulomb",
                                           "contact.friction": 0.3})
    result = impactgen.simulate(scene, record_steps=False)
    assert result.status == "ok", result.message
    records = runs[-1].records
    assert {rec.point for rec in records} == {2, 3} and all(rec.act for rec in records)
    assert all(rec.event >= 0 for rec in records)  # every record is a switch's: none at the end time
    switches: dict[int, list[int]] = {}
    for rec in records:
        switches.setdefault(rec.sample, []).append(rec.point)
    assert list(switches) == sorted(switches)
    assert all(points == sorted(set(points)) for points in switches.values())  # point order, each once
    assert any(len(points) > 1 for points in switches.values())  # (a switch of both points is among them)
    last: dict[int, tuple] = {}
    for rec in records:
        if rec.point in last:
            assert (rec.state, rec.slip) == last[rec.point]
        last[rec.point] = (rec.next_state, rec.next_slip)
    assert result.stats["segments"] == len(switches) + 1 == len(result.phases)
    assert result.phases[-1].ended_by == "t_end"
