"""The batch entry (native/batch.c, sweep/batch.py): a chunk's cases run in one C call give the
rows the per-case path gives, bit for bit; run_batch; what a finished sweep leaves behind."""
import numpy as np
import pytest

import impactgen
from impactgen.errors import SceneError, ValidityWarning
from impactgen.sweep import batch
from impactgen.sweep.chunk import CaseOptions, ChunkColumns, run_case, run_chunk

CASES = 2000


def _random_cases(count: int, seed: int) -> list[tuple[int, dict]]:
    """The paper's inputs drawn wide: some cases fail (too few steps allowed, below), some are
    refused by the scene (a yield strength above the modulus, a joint starting inside the
    surface), some need the model with joint 1's contact (a first link near level)."""
    rng = np.random.default_rng(seed)
    level = rng.random(count) < 0.05  # the first link near level: joint 1 may reach the surface
    upward = rng.random(count) < 0.05  # the second link rising: joint 1 starts inside the surface
    columns = {
        "initial.q_deg[1]": np.where(level, rng.uniform(-8, -2, count), rng.uniform(-80, -60, count)),
        "initial.q_deg[2]": np.where(upward, rng.uniform(1, 5, count), rng.uniform(-70, -50, count)),
        "initial.u[1]": rng.uniform(-0.3, -0.05, count),
        "initial.u[2]": rng.uniform(-0.5, -0.1, count),
        "rod.yield_strength": rng.choice([1.12e9, 1.0e9, 3e11], count, p=[0.5, 0.45, 0.05]),
    }
    return [(i, {key: float(values[i]) for key, values in columns.items()}) for i in range(count)]


def _same(a: dict, b: dict) -> None:
    assert set(a) == set(b)
    for name in a:
        if name == "wall_s":
            continue
        x, y = a[name], b[name]
        if isinstance(x, np.ndarray) and x.dtype.kind == "f":
            assert np.array_equal(x.view(np.int64), np.asarray(y, dtype=float).view(np.int64)), name
        else:
            assert list(x) == list(y), name


def test_a_batch_gives_the_per_case_rows_bit_for_bit():
    base = impactgen.load_scene("paper", overrides={"solver.max_steps": 160})
    cases = _random_cases(CASES, 48)
    batched = run_chunk(base.to_dict(), cases, CaseOptions())
    one_by_one = ChunkColumns(cases)
    for index, overrides in cases:
        run_case(one_by_one, base, index, overrides)
    _same(batched.columns, one_by_one.rows().columns)
    status = list(batched.columns["status"])
    assert {"ok", "failed", "invalid"} <= set(status), set(status)
    # the cases the batch handed to the per-case path are few, and include those of another model
    plan = batch.plan_for(base, tuple(cases[0][1]))
    values, usable = batch.case_values(plan.keys, [o for _, o in cases])
    ran = batch.run_plan(plan, values, usable)
    assert ran.again.sum() < CASES / 2 and ran.again.any()
    joint_model = [k for k, (_, o) in enumerate(cases) if _model_joints(base, o) not in (None, ())]
    assert joint_model and all(ran.again[k] for k in joint_model)


def _model_joints(base, overrides):
    """The joints with contact code in the model a case needs (None: the scene refuses it)."""
    from impactgen.engines import model_spec
    from impactgen.scene import scene_with
    try:
        return model_spec(scene_with(base, overrides)).joints
    except SceneError:
        return None


def test_run_batch_takes_a_table_and_gives_the_sweep_s_columns():
    pd = pytest.importorskip("pandas")
    cases = pd.DataFrame({"initial.u[2]": [-0.2, -0.4, -0.3], "rod.yield_strength": [1.1e9, 1.2e9, 5e11]})
    table = impactgen.run_batch("paper", cases)
    swept = impactgen.sweep("paper", vary={"initial.u[2]": [-0.2, -0.4]}, workers=1)
    assert list(table["case"]) == [0, 1, 2] and list(table["status"]) == ["ok", "ok", "invalid"]
    assert set(swept.columns) - {"initial.u[2]"} <= set(table.columns)
    single = impactgen.simulate(impactgen.load_scene("paper", overrides={"initial.u[2]": -0.4,
                                                                         "rod.yield_strength": 1.2e9}))
    assert table["delta_r"][1] == single.summary["delta_r"]
    again = impactgen.run_batch("paper", {key: cases[key].tolist() for key in cases})
    assert again["delta_r"][:2].tolist() == table["delta_r"][:2].tolist()


@pytest.mark.parametrize("cases, key", [
    ([1, 2], "cases"),
    ({"initial.nonsense": [1.0]}, "initial.nonsense"),
    ({"initial.u[2]": [-0.1, -0.2], "rod.E": [2e11]}, "cases"),
    ({"initial.u[2]": -0.1}, "initial.u[2]"),
])
def test_run_batch_refuses_what_is_no_table_of_cases(cases, key):
    with pytest.raises(SceneError) as caught:
        impactgen.run_batch("paper", cases)
    assert caught.value.key == key


def test_a_finished_sweep_leaves_no_lock_file(tmp_path):
    impactgen.sweep("paper", vary={"initial.u[2]": [-0.2, -0.3]}, workers=1, out=tmp_path / "run")
    assert not (tmp_path / "run" / ".lock").exists()
    assert (tmp_path / "run" / "sweep.parquet").exists()


@pytest.mark.parametrize("kept", [0, 3], ids=["in C", "per case, trajectories kept"])
def test_a_sweep_s_validity_warnings_are_one_python_warning(kept, tmp_path):
    """Gentle impacts (the elastic limit never reached) in some cases: one ValidityWarning
    that counts them, whatever their number, whether the cases ran in C or one by one
    through simulate (which then must not warn per case)."""
    with pytest.warns(ValidityWarning) as caught:
        table = impactgen.sweep("paper", vary={"initial.u[1]": [0.0], "initial.u[2]": [-0.3, -1e-3, -1e-2]},
                                workers=1, trajectories=kept, out=tmp_path / "sweep" if kept else None)
    warned = int((table["warnings"] != "").sum())
    validity = [w for w in caught if issubclass(w.category, ValidityWarning)]
    assert len(validity) == 1 and warned >= 1
    assert str(validity[0].message).startswith(f"{warned} of 3 cases")


def test_run_batch_s_docstring_example_runs():
    import doctest
    import importlib
    module = importlib.import_module("impactgen.sweep.ensemble")  # (impactgen.sweep is the function)
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0


def test_a_key_that_sets_more_than_its_input_gives_the_per_case_rows():
    """A link's length also sets its mass where the masses come from a diameter: the batch runs
    it as simulate does, not as one input set alone in C (that gave P_max 696.6 N against
    simulate's 717.5 N)."""
    base = impactgen.load_scene("paper", overrides={"chain.diameter": [0.01, 0.01], "rod.density": 7800.0,
                                                     "chain.mass": None})
    table = impactgen.run_batch(base, {"chain.length[1]": [1.0, 1.5]})
    for value, row in zip([1.0, 1.5], table.itertuples()):
        expected = impactgen.simulate(base.replace({"chain.length[1]": value}), record_steps=False, warn=False).summary
        assert row.status == "ok" and row.P_max == expected["P_max"] and row.delta_T == expected["delta_T"]


def test_a_key_is_batched_only_where_it_sets_its_input_alone():
    """The tip's radius is the joints' too where they have none of their own: not one input."""
    assert batch.plan_for(impactgen.load_scene("paper"), ("rod.tip_radius",)) is not None
    assert batch.plan_for(impactgen.load_scene("falling-chain"), ("rod.tip_radius",)) is None
    assert batch.plan_for(impactgen.load_scene("falling-chain", overrides={"contact.joint_radius": 0.004}),
                          ("rod.tip_radius",)) is not None


def test_run_batch_refuses_an_element_beyond_the_scene_s_naming_it():
    with pytest.raises(SceneError, match=r"initial.u\[5\]"):
        impactgen.run_batch("paper", {"initial.u[5]": [-0.2]})


def test_a_huge_integer_value_is_a_row_not_a_traceback():
    table = impactgen.run_batch("paper", {"rod.yield_strength": [10**400]})
    assert table["status"].tolist() == ["invalid"]


def test_run_batch_issues_one_validity_warning():
    with pytest.warns(ValidityWarning) as caught:
        impactgen.run_batch("paper", {"initial.u[1]": [0.0, 0.0], "initial.u[2]": [-1e-3, -1e-2]})
    assert len([w for w in caught if issubclass(w.category, ValidityWarning)]) == 1


def _batched_as_per_case(base, cases: list[tuple[int, dict]]):
    """The cases through the batch: their rows (asserted the per-case path's, bit for bit), and
    what the batch's plan ran (`again`: the cases it left to the per-case path)."""
    batched = run_chunk(base.to_dict(), cases, CaseOptions())
    one_by_one = ChunkColumns(cases)
    for index, case in cases:
        run_case(one_by_one, base, index, case)
    _same(batched.columns, one_by_one.rows().columns)
    plan = batch.plan_for(base, tuple(cases[0][1]))
    assert plan is not None
    values, usable = batch.case_values(plan.keys, [case for _, case in cases])
    return batched, batch.run_plan(plan, values, usable)


def _free_cases(count: int, seed: int) -> list[tuple[int, dict]]:
    """A dropped rod's start drawn wide: its angle, its base point's height (a few below the
    plate: the scene refuses them) and its vertical speed."""
    rng = np.random.default_rng(seed)
    columns = {"initial.q_deg[1]": rng.uniform(5.0, 60.0, count),
               "initial.base[2]": rng.choice([0.05, 0.02, -0.01], count, p=[0.6, 0.3, 0.1]),
               "initial.base_velocity[2]": rng.uniform(-2.0, 0.0, count)}
    return [(i, {key: float(values[i]) for key, values in columns.items()}) for i in range(count)]


@pytest.mark.parametrize("name, overrides", [
    ("rod-drop", {"solver.t_end": "separation"}),
    ("chain-on-slope", {"solver.t_end": "separation"}),
    ("chain-on-slope", {"solver.t_end": "separation", "surface.height": "initial"}),
    ("rod-drop", {}),
], ids=["rod-drop", "chain-on-slope", "chain-on-slope-initial-surface", "rod-drop-three-impacts"])
def test_a_free_chain_s_batch_gives_the_per_case_rows_bit_for_bit(name, overrides):
    """A free chain in C (its base point's position and velocity in the initial state, varied
    as keys; a level or an inclined surface; surface.height given or "initial"): the rows the
    per-case path gives, bit for bit. A case whose base point starts below the surface is a
    row with the scene's message, not a crash; the batch takes most others, of one impact or of
    several (rod-drop's own run: the base point, the tip, the base point again), each impact
    screened for the warnings at its own point."""
    base = impactgen.load_scene(name, overrides=overrides)
    cases = _free_cases(40, 5)
    batched, ran = _batched_as_per_case(base, cases)
    status = np.array(batched.columns["status"])
    warned = np.array(batched.columns["warnings"]) != ""
    assert ran.again[warned].all()  # (a case with a warning is worded by the per-case path)
    assert ran.again.sum() < len(cases) / 4  # the batch took most cases (its screen is wide)
    below = np.array([case["initial.base[2]"] < 0 for _, case in cases])
    if base.surface_height is None:  # "initial": the surface through the lowest point, none below it
        assert (status == "ok").all()
        return
    assert below.any() and (status[below] == "invalid").all() and (status[~below] == "ok").all()
    messages = [m for m, b in zip(batched.columns["message"], below) if b]
    assert all(m.startswith("initial.base: the free chain's base point starts") for m in messages)


def test_a_level_case_of_an_inclined_scene_runs_on_the_level_model():
    """surface.angle_deg varied on an inclined scene: the batch runs the inclined cases (a
    negative angle too), and a level one (another model: gravity has no x component there) on
    the per-case path; the rows are the per-case path's, bit for bit."""
    base = impactgen.load_scene("chain-on-slope", overrides={"solver.t_end": "separation"})
    cases = [(i, {"surface.angle_deg": a, "initial.q_deg[1]": q})
             for i, (a, q) in enumerate([(0.0, -20.0), (10.0, -20.0), (25.0, -25.0), (-10.0, -20.0)])]
    batched, ran = _batched_as_per_case(base, cases)
    assert ran.again.tolist() == [True, False, False, False]
    assert list(batched.columns["status"]) == ["ok"] * 4
