"""The Python API as scipy users expect it: shapes, options checked up front, failures as
results, t_eval and dense output, whole runs with their impacts, and scenes that validate."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import impactgen
from impactgen.errors import SceneError
from conftest import PAPER

BOUNCING = {"solver.t_end": 2.0, "solver.rtol": 1e-8, "solver.atol": 1e-10}


@pytest.fixture(scope="module")
def bouncing():
    return impactgen.simulate(impactgen.load_scene(PAPER, overrides=BOUNCING))


def test_shapes_follow_solve_ivp(paper_result):
    r = paper_result
    n_points = len(r.t)
    assert r.y.shape == (2 * r.n + 4, n_points)  # q, u, W_normal, W_friction, P_normal, P_friction
    assert r.q.shape == (2, n_points) and r.u.shape == (2, n_points)
    assert r.v_B.shape == (2, n_points) and r.T_links.shape == (2, n_points)
    assert r.delta.shape == r.F.shape == r.T.shape == (n_points,)
    np.testing.assert_array_equal(r.q[:, 0], r.scene.q0)
    assert r.state_names == ["q1", "q2", "u1", "u2", "W_normal", "W_friction", "P_normal", "P_friction"]
    for name in ("delta", "F", "F_f", "v_B", "T_links", "x_B", "v_Bx", "T", "V", "outputs"):
        assert name in dir(r)
    assert set(r.outputs) >= {"delta", "F", "F_f", "T1", "T2", "T", "V"}


def test_summary_is_computed_once_with_plain_floats(paper_result):
    r = paper_result
    assert r.summary is r.summary and r.warnings is r.warnings
    assert type(r.summary["t_contact"]) is float and type(r.summary["T0"]) is float
    assert r.summary is r.first_impact  # a run to separation is its first impact


def test_summary_keys_are_in_the_order_a_sweep_writes_its_columns(paper_result, bouncing):
    """The sweep names its columns from results' key lists; both engines' summaries, of an
    impact and of a whole run, follow them."""
    from impactgen.results import COEFFICIENTS, ENERGY_TERMS, SUMMARY_LATER, SUMMARY_LEADING
    expected = [*SUMMARY_LEADING, "switches", "stick_slip", "u_final", "q_final", *SUMMARY_LATER, "energy",
                "coefficients"]
    reference = impactgen.simulate(paper_result.scene, engine="reference")
    for summary in (paper_result.summary, reference.summary, bouncing.summary):
        assert list(summary) == expected and list(summary["energy"]) == list(ENERGY_TERMS)
        assert list(summary["coefficients"]) == list(COEFFICIENTS)


def test_a_tallied_summary_gives_each_field_to_its_key():
    """from_tally unpacks Tallied in its field order: each field lands under its own name."""
    from impactgen.results import Tallied
    from impactgen.summaries import from_tally
    values = {name: float(k + 1) for k, name in enumerate(Tallied._fields[:-1])}  # all but y_final, each its own
    values["point_impacts"] = (0, 101, 102)  # by point number: the pivot (no contact point), joint 1, the tip
    tallied = Tallied(**values, y_final=(0.1, 0.2, 0.3, 0.4))
    summary = from_tally(tallied, 2, [])
    flat = {**summary, **summary["energy"]}
    for name in Tallied._fields:
        if name in flat and name != "point_impacts":
            assert flat[name] == getattr(tallied, name), name
    assert summary["point_impacts"] == {"joint 1": 101, "tip": 102}  # by point name
    assert summary["q_final"] == [0.1, 0.2] and summary["u_final"] == [0.3, 0.4]


def test_a_result_pickles_with_its_summary_and_warnings():
    """A result crosses processes (a user's own pool): it holds plain data, no C objects."""
    import pickle
    hard = impactgen.load_scene(PAPER, overrides={"rod.tip_radius": 1e-6})
    result = impactgen.simulate(hard)
    again = pickle.loads(pickle.dumps(result))
    assert again.summary == result.summary and again.warnings == result.warnings
    assert any("contact radius" in w for w in again.warnings)
    # what a result makes on first use (spans, counters, phase names, impact energies) is
    # made before it is pickled: its makers hold the run's C records (t_eval's parameters)
    sampled = impactgen.simulate(hard, t_eval=[0.0, 1e-4, 2e-4])
    again = pickle.loads(pickle.dumps(sampled))
    assert again.phases == sampled.phases and again.stats == sampled.stats
    assert list(again.phase) == list(sampled.phase) and list(again.trajectory.phase) == list(
        sampled.trajectory.phase)
    assert [i.to_dict() for i in again.impacts] == [i.to_dict() for i in sampled.impacts]
    assert math.isfinite(again.impacts[0].T_before) and again.stats["segments"] == len(again.phases)


def test_whole_run_budget_closes_and_reports_the_end_state(bouncing):
    s, first = bouncing.summary, bouncing.first_impact
    assert s["impacts"] == len(bouncing.impacts) > 100
    assert s["t_final"] == pytest.approx(2.0) and 0.9 < s["t_sustained"] < 1.0
    assert s["u_final"] == pytest.approx(bouncing.u[:, -1].tolist())
    assert s["u_final"] != pytest.approx(first["u_final"], rel=1e-2)  # not the first impact's
    energy = s["energy"]
    scale = s["T0"] + abs(float(bouncing.V[0]))
    assert abs(energy["residual"]) < 1e-6 * scale
    assert s["Tf"] == pytest.approx(float(bouncing.T[-1]))
    assert s["delta_max"] == max(i.delta_max for i in bouncing.impacts)


def test_impacts_table_agrees_with_the_phase_spans(bouncing):
    spans = bouncing.phases
    ends_of_free = {p.t1 for p in spans if p.phase == "free"}
    starts_of_free = {p.t0 for p in spans if p.phase == "free"}
    for k, impact in enumerate(bouncing.impacts):
        assert impact.t_start == 0.0 or impact.t_start in ends_of_free
        if impact.t_end is not None:
            assert impact.t_end in starts_of_free
            assert impact.duration == pytest.approx(impact.t_end - impact.t_start)
        inside = [p for p in spans if p.phase != "free" and impact.t_start <= p.t0
                  and (impact.t_end is None or p.t1 <= impact.t_end)]
        switch_times = [t for t, _, _ in impact.switches]
        assert switch_times == [p.t1 for p in inside if p.ended_by != "t_end"][:len(switch_times)]
        assert impact.T_before == pytest.approx(float(bouncing.T[impact.i_start]))
    frame = bouncing.impacts_frame()
    assert len(frame) == len(bouncing.impacts)
    assert {"t_start", "duration", "delta_max", "delta_r", "P_max", "T_before", "T_after",
            "W_normal", "W_friction", "switches"} <= set(frame.columns)
    total = frame["W_normal"].sum() + frame["W_friction"].sum()
    flights = bouncing.summary["energy"]["W_normal"] + bouncing.summary["energy"]["W_friction"]
    assert total == pytest.approx(flights, rel=1e-9)  # the contact forces work only in contact


def test_t_eval_samples_agree_with_the_dense_solution(paper_scene):
    times = np.linspace(0.0, 4.0e-4, 41)
    r = impactgen.simulate(paper_scene, t_eval=times, dense_output=True)
    np.testing.assert_array_equal(r.t, times)
    assert r.y.shape == (8, 41) and len(r.phase) == 41 and r.F.shape == (41,)
    np.testing.assert_allclose(r.sol(times), r.y, rtol=0, atol=1e-15)
    assert r.sol(1e-4).shape == (8,)
    assert set(r.phase) == {"elastic", "elastoplastic", "restitution"}
    # the summary still comes from every step, not from the 41 samples
    assert r.summary["delta_r"] == pytest.approx(5.57e-6, rel=2e-3)


def test_dense_output_is_accurate_between_steps_and_across_switches(paper_scene):
    coarse = impactgen.simulate(paper_scene, rtol=1e-8, atol=1e-10, dense_output=True)
    fine = impactgen.simulate(paper_scene, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(coarse.sol(coarse.t), coarse.y, rtol=0, atol=1e-14)
    t = fine.t[(fine.t > 0) & (fine.t < coarse.t[-1])]
    scale = np.max(np.abs(fine.u))
    assert np.max(np.abs(coarse.sol(t)[2:4] - fine.u[:, (fine.t > 0) & (fine.t < coarse.t[-1])])) < 1e-5 * scale


def test_reference_engine_takes_the_same_options(paper_scene):
    times = np.linspace(0.0, 4.0e-4, 5)
    r = impactgen.simulate(paper_scene, engine="reference", method="lsoda", rtol=1e-8, atol=1e-10,
                           t_eval=times, dense_output=True)
    assert r.stats["method"] == "LSODA" and r.y.shape == (8, 5)
    c = impactgen.simulate(paper_scene, rtol=1e-8, atol=1e-10, t_eval=times)
    np.testing.assert_allclose(r.q, c.q, atol=1e-8)
    np.testing.assert_allclose(r.sol(times), r.y, atol=1e-15)


@pytest.mark.parametrize("options, key", [
    ({"rtoll": 1e-8}, "rtoll"),
    ({"method": "Radau"}, "method"),
    ({"engine": "fortran"}, "engine"),
    ({"rtol": 2.0}, "solver.rtol"),
    ({"t_eval": [2e-4, 1e-4]}, "t_eval"),
    ({"t_eval": [0.0, 50.0]}, "t_eval"),
    ({"dense_output": "yes"}, "dense_output"),
])
def test_bad_options_fail_before_any_build(options, key, monkeypatch):
    import impactgen.build

    def no_build(*_args, **_kwargs):
        raise AssertionError("a model was built for a call that must be refused")
    monkeypatch.setattr(impactgen.build, "compile_model", no_build)
    scene = impactgen.load_scene(PAPER, overrides={"chain.links": 4, "chain.length": 1.0, "chain.mass": 1.0,
                                                   "initial.q_deg": [-70, -60, -60, -60],
                                                   "initial.u": [0.0, 0.0, 0.0, 0.0]})
    with pytest.raises(SceneError) as err:
        impactgen.simulate(scene, **options)
    assert err.value.key == key


@pytest.mark.parametrize("engine, steps", [("c", 5), ("reference", 2)])
def test_a_solver_failure_is_a_result_with_the_partial_trajectory(paper_scene, engine, steps):
    r = impactgen.simulate(paper_scene, engine=engine, max_steps=steps)
    assert r.status == "failed" and r.success is False
    assert "max_steps" in r.message
    assert len(r.t) > 1 and r.t[-1] > 0 and r.y.shape[1] == len(r.t)
    assert np.all(np.isfinite(r.y))
    assert r.to_json_dict()["status"] == "failed"


def test_numpy_values_are_taken_as_plain_numbers():
    scene = impactgen.load_scene(PAPER, overrides={"initial.u": np.array([-0.1, -0.3]),
                                                   "chain.links": np.int64(2),
                                                   "solver.rtol": np.float64(1e-8),
                                                   "solver.sustained_contact": np.bool_(False)})
    assert scene.u0 == (-0.1, -0.3) and type(scene.u0[0]) is float
    assert scene.n == 2 and scene.solver.rtol == 1e-8 and scene.solver.sustained_contact is False
    again = scene.replace({"initial.u[2]": np.float32(-0.25)})
    assert again.u0 == (-0.1, -0.25)


def test_replace_validates_like_load_scene(paper_scene):
    with pytest.raises(SceneError) as err:
        paper_scene.replace(chain=dataclasses.replace(paper_scene.chain, links=3))
    assert err.value.key is not None and "3 values" in str(err.value)
    with pytest.raises(SceneError, match="inside the surface"):
        paper_scene.replace({"surface.height": 0.0})
    changed = paper_scene.replace(solver=dataclasses.replace(paper_scene.solver, rtol=1e-6))
    assert changed.solver.rtol == 1e-6 and changed.q0 == paper_scene.q0


def test_options_run_the_scene_they_make(paper_scene):
    """simulate(scene, rtol=..., method=...) runs without making a new scene; the result's
    scene is the one those settings make (made when asked for), and the run is the one that
    scene gives, bit for bit."""
    import pickle

    from impactgen.scene import with_solver
    settings = {"rtol": 1e-7, "method": "bdf", "t_end": 2e-3}
    result = impactgen.simulate(paper_scene, record_steps=False, **settings)
    made = with_solver(paper_scene, settings)
    assert result.solver == made.solver and result.solver.jacobian == "analytic"
    assert result.scene == made and result.scene.solver is result.solver
    assert result.summary == impactgen.simulate(made, record_steps=False).summary
    assert pickle.loads(pickle.dumps(result)).scene == made
    plain = impactgen.simulate(paper_scene, record_steps=False)
    assert plain.scene is paper_scene and plain.solver is paper_scene.solver


def test_indexed_keys_count_from_one_like_the_links():
    scene = impactgen.load_scene(PAPER, overrides={"initial.u[2]": -0.3, "chain.length[1]": 1.5})
    assert scene.u0 == (-0.1, -0.3) and scene.chain.length == (1.5, 1.0)
    for key, words in (("initial.u[3]", "out of range"), ("initial.u[0]", "numbered from 1"),
                       ("chain.gravity[1]", "not a list"), ("chain.length[x]", "whole number")):
        with pytest.raises(SceneError, match=words.replace("[", r"\[").replace("]", r"\]")) as err:
            impactgen.load_scene(PAPER, overrides={key: 1.0})
        assert err.value.key == key


def test_an_angle_element_may_be_given_in_either_unit(paper_scene):
    in_radians = impactgen.load_scene(PAPER, overrides={"initial.q[2]": -1.0})
    assert in_radians.q0 == pytest.approx((math.radians(-70.0), -1.0))
    from_radians = paper_scene.replace({"initial.q_deg[2]": -55.0})  # to_dict states radians
    assert from_radians.q0 == pytest.approx((math.radians(-70.0), math.radians(-55.0)))


def test_scene_round_trips_through_toml(paper_scene):
    text = paper_scene.to_toml()
    back = impactgen.scene.scene_from_text(text)
    assert back == paper_scene


@pytest.mark.parametrize("q_deg, link", [([20.0, 30.0], 1), ([-70.0, 10.0], 1), ([-60.0, 20.0], 1)])
def test_a_chain_starting_below_the_surface_is_refused(q_deg, link):
    with pytest.raises(SceneError) as err:
        impactgen.load_scene(PAPER, overrides={"initial.q_deg": q_deg, "surface.height": "initial"})
    assert err.value.key == "initial.q" and f"link {link}" in str(err.value)


def test_a_link_below_a_numeric_surface_is_refused():
    # the tip is 1 cm above the surface but the first joint dips below it
    q = [math.radians(-80.0), math.radians(30.0)]
    tip = math.sin(q[0]) + math.sin(q[1])
    with pytest.raises(SceneError, match="link 1 starts below") as err:
        impactgen.load_scene(PAPER, overrides={"initial.q": q, "surface.height": tip - 0.01})
    assert err.value.key == "initial.q"


def test_friction_must_be_stated():
    raw = impactgen.scene.scene_from_text(PAPER.read_text()).to_dict()
    del raw["contact"]["friction"]
    with pytest.raises(SceneError, match="missing required key") as err:
        impactgen.scene_from_dict(raw)
    assert err.value.key == "contact.friction"


def test_shipped_examples_load_by_name():
    from impactgen.examples import example_names
    names = example_names()
    assert {"paper", "chain3-free-flight", "coulomb", "bouncing", "aluminium-on-steel"} <= set(names)
    for name in names:
        scene = impactgen.load_scene(name)
        assert scene.source == f"<example {name}>"
    assert impactgen.load_scene("paper") == impactgen.load_scene(PAPER)


def test_free_flight_example_flies_before_it_hits():
    r = impactgen.simulate(impactgen.load_scene("chain3-free-flight"), rtol=1e-8, atol=1e-10)
    assert r.status == "ok" and r.phases[0].phase == "free" and r.summary["t_impact"] > 0.05
    assert abs(r.summary["energy"]["residual"]) < 1e-6 * r.summary["T0"]


@pytest.mark.parametrize("name, overrides", [
    ("paper", {}),
    ("paper", BOUNCING),  # 2 s of bouncing: many impacts, more segments than one C call holds
    ("coulomb", {"solver.t_end": 0.05}),  # stick and slip
    ("bouncing", {}),  # chattering into sustained contact
])
def test_a_run_without_its_steps_has_the_same_summaries_and_impacts(name, overrides):
    """record_steps=False keeps only the start, the switches and the end; the steps taken are
    the same, so every summary, impact and span is equal to the digit."""
    scene = impactgen.load_scene(name, overrides=overrides)
    full = impactgen.simulate(scene)
    lean = impactgen.simulate(scene, record_steps=False)
    assert lean.status == full.status and lean.message == full.message
    assert lean.summary == full.summary and lean.first_impact == full.first_impact
    assert [i.to_dict() for i in lean.impacts] == [i.to_dict() for i in full.impacts]
    assert [p.to_dict() for p in lean.phases] == [p.to_dict() for p in full.phases]
    assert lean.stats["nsteps"] == full.stats["nsteps"]
    assert len(lean.t) == len(full.phases) + 1 < len(full.t)
    ends = np.searchsorted(full.t, lean.t)  # the switches are samples of the full run, with its states
    np.testing.assert_array_equal(full.y[:, ends], lean.y)
    np.testing.assert_array_equal(full.phase[ends], lean.phase)
    np.testing.assert_array_equal(full.F[ends], lean.F)


def test_record_steps_is_checked():
    with pytest.raises(SceneError, match="record_steps"):
        impactgen.simulate(impactgen.load_scene("paper"), record_steps="no")
