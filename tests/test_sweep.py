"""Sweeps: rows equal single simulations, failures are rows, bad specifications are named,
a result folder resumes and is not shared by two sweeps."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import impactgen
from impactgen.errors import SceneError
from impactgen.paper import PUBLISHED
from impactgen.sweep.run import OutputFolder
from impactgen.sweep.spec import SweepSpec
from conftest import PAPER

pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

# omega20 (rad/s), published delta_r (m): MODEL section 7, as impactgen.paper states it
PAPER_TABLE = [(row.omega20, row.delta_r) for row in PUBLISHED]


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


def _flattened(summary: dict) -> dict:
    """A summary as a table row spells it, written out independently of the sweep's code."""
    row = {}
    for key, value in summary.items():
        if key in ("switches", "stick_slip"):
            row[f"n_{key}"] = len(value)
        elif isinstance(value, list):
            row.update({f"{key}[{i}]": v for i, v in enumerate(value, start=1)})
        elif isinstance(value, dict):
            row.update({f"{key}.{k}": v for k, v in value.items()})
        else:
            row[key] = value
    return row


def test_a_chunk_s_summary_columns_are_the_summaries_of_its_cases():
    """Columns made at once from the tallied summaries of a chunk's cases: named and valued as
    each case's `summary`, NaN for a refused case and beyond a case's own link count."""
    from impactgen.sweep.chunk import ChunkRows, CaseOptions, run_chunk
    cases = [{"initial.u[2]": -0.3},
             {"chain.links": 3, "chain.length": 0.7, "chain.mass": 1.0, "initial.q_deg": [-70, -60, -60],
              "initial.u": [-0.1, -0.2, -0.2]},
             {"rod.E": 1e9}, {"solver.t_end": 0.2}]
    base = impactgen.load_scene(PAPER)
    chunk = run_chunk(base.to_dict(), list(enumerate(cases)), CaseOptions())
    assert isinstance(chunk, ChunkRows) and list(chunk.columns["status"]) == ["ok", "ok", "invalid", "ok"]
    inputs = {key for case in cases for key in case}
    names = [n for n in chunk.columns if n not in ("case", "status", "message", "warnings", "wall_s", *inputs)]
    assert "u_final[3]" in names and "energy.residual" in names
    for k, overrides in enumerate(cases):
        if k == 2:
            assert all(np.isnan(chunk.columns[n][k]) for n in names)
            continue
        row = _flattened(impactgen.simulate(base.replace(overrides)).summary)
        for name in names:
            value = chunk.columns[name][k]
            expected = row.get(name)
            if expected is None:
                assert np.isnan(value), (k, name)
            else:
                assert value == expected, (k, name, value, expected)
        assert set(row) <= set(names), set(row) - set(names)


def test_a_chunk_of_two_models_keeps_its_counts_integers():
    """Counts stay integers when every case of a chunk has them, whatever models the cases
    ran on (a chunk of a sweep over chain.links), as in a chunk of one model."""
    from impactgen.sweep.chunk import CaseOptions, run_chunk
    cases = [{"initial.u[2]": -0.3},
             {"chain.links": 3, "chain.length": 0.7, "chain.mass": 1.0, "initial.q_deg": [-70, -60, -60],
              "initial.u": [-0.1, -0.2, -0.2]}]
    columns = run_chunk(impactgen.load_scene(PAPER).to_dict(), list(enumerate(cases)), CaseOptions()).columns
    assert all(columns[name].dtype == np.int64 for name in ("n_switches", "n_stick_slip", "impacts"))
    assert np.isnan(columns["u_final[3]"][0]) and not np.isnan(columns["u_final[3]"][1])


def test_a_sweep_freezes_the_callers_heap_only_while_it_runs():
    """The heap is frozen for the collector during a sweep (its workers fork from it) and
    handed back as it was: unfrozen, or frozen by the caller and left so."""
    import gc
    from impactgen.sweep.execute import frozen_heap
    seen = []
    impactgen.sweep("paper", vary={"initial.u[2]": [-0.3]}, workers=1,
                    progress=lambda n: seen.append(gc.get_freeze_count()))
    assert seen and seen[0] > 0 and gc.get_freeze_count() == 0 and gc.isenabled()
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        with frozen_heap():
            pass
        assert gc.get_freeze_count() == frozen  # the caller's own freeze is kept
    finally:
        gc.unfreeze()


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
    ({"contact.friction": [0.2, "a"]}, 0, "contact.friction", "expected a number"),
    ({"contact.model": ["hertz", "rigid"]}, 0, "contact.model", "not one of"),
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
    assert b"linspace" not in meta[b"impactgen.sweep"]  # the grid is stored as its values
    assert meta[b"impactgen.sweep"].startswith(b"--vary initial.u[2]=")
    parts = sorted((tmp_path / "_parts").iterdir())
    # a resume computes nothing again: no new part, the same rows
    calls = []
    again = impactgen.sweep("paper", vary=vary, workers=1, out=tmp_path, progress=calls.append)
    assert sorted((tmp_path / "_parts").iterdir()) == parts and calls == [3]
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


# ----------------------------------------------------------------------------- execution

import json  # noqa: E402
import os  # noqa: E402
import signal  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

CLI = [sys.executable, "-m", "impactgen.cli"]
GRID = {"initial.u[2]": "linspace(-0.5,-0.1,6)", "contact.friction": [0.0, 0.3]}


def _comparable(frame):
    return frame.drop(columns=["wall_s"]).reset_index(drop=True)


@pytest.fixture(scope="module")
def pool_table():
    return impactgen.sweep("paper", vary=GRID, workers=2)


def _start(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen(args, stdout=log.open("w"), stderr=subprocess.STDOUT, start_new_session=True)


@pytest.mark.slow
def test_local_cluster_gives_the_pool_s_table(pool_table):
    pytest.importorskip("distributed")
    on_cluster = impactgen.sweep("paper", vary=GRID, scheduler="local", workers=2)
    assert _comparable(on_cluster).equals(_comparable(pool_table))


@pytest.fixture
def dask_cluster(tmp_path):
    """A `dask scheduler` and two `dask worker` processes started separately on localhost;
    yields the scheduler's address and the worker processes."""
    pytest.importorskip("distributed")
    address_file = tmp_path / "scheduler.json"
    scheduler = _start([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                        "--port", "0", "--no-dashboard", "--scheduler-file", str(address_file)],
                       tmp_path / "scheduler.log")
    workers = []
    try:
        for _ in range(300):
            if address_file.exists() and address_file.stat().st_size:
                break
            time.sleep(0.1)
        worker = [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(address_file),
                  "--nthreads", "1", "--no-dashboard"]
        workers = [_start(worker, tmp_path / f"worker{k}.log") for k in range(2)]
        address = json.loads(address_file.read_text())["address"]
        from distributed import Client
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address, workers
    finally:
        for process in [scheduler, *workers]:
            try:
                os.killpg(process.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for process in [scheduler, *workers]:
            process.wait(timeout=30)


@pytest.mark.slow
def test_separately_started_scheduler_and_workers_give_the_pool_s_table(pool_table, dask_cluster):
    address, _ = dask_cluster
    table = impactgen.sweep("paper", vary=GRID, scheduler=address)
    assert _comparable(table).equals(_comparable(pool_table))


@pytest.mark.slow
def test_a_dask_worker_killed_mid_sweep_loses_no_row(dask_cluster, tmp_path):
    address, workers = dask_cluster
    out = tmp_path / "dask-killed"
    process = subprocess.Popen(CLI + ["sweep", "paper", *SLOW_CASES, "--scheduler", address, "--out", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_parts(out, 1, process)
    assert process.poll() is None, "the sweep ended before a worker could be killed"
    os.killpg(workers[0].pid, signal.SIGKILL)  # the worker and its nanny: gone for good
    try:
        _, stderr = process.communicate(timeout=180)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    import pandas as pd
    table = pd.read_parquet(out / "sweep.parquet")
    assert sorted(table["case"]) == list(range(160)) and set(table["status"]) == {"ok"}


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        found += [int(c) for c in text]
    return found


def _wait_for_parts(out: Path, at_least: int, process: subprocess.Popen) -> None:
    for _ in range(600):
        if len(list((out / "_parts").glob("part-*.parquet"))) >= at_least or process.poll() is not None:
            return
        time.sleep(0.05)


# slow enough to be interrupted: a run to 1 s has 142 impacts and a sustained contact, about
# 25 ms a case (to 0.1 s took under 1 ms, and 160 cases ended before a kill could land)
SLOW_CASES = ["--set", "solver.t_end=1.0", "--set", "solver.rtol=1e-8", "--set", "solver.method=bdf", "--vary",
              "initial.u[2]=linspace(-0.5,-0.1,160)", "--quiet"]


@pytest.mark.slow
def test_a_worker_killed_mid_sweep_loses_no_row(tmp_path):
    out = tmp_path / "killed"
    process = subprocess.Popen(CLI + ["sweep", "paper", *SLOW_CASES, "--workers", "2", "--out", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_parts(out, 1, process)
    workers = _children(process.pid)
    assert process.poll() is None and workers, "the sweep ended before a worker could be killed"
    os.kill(workers[0], signal.SIGKILL)
    try:
        stdout, stderr = process.communicate(timeout=180)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    assert "a worker process died" in stderr  # the pool broke, and its chunks ran again
    import pandas as pd
    table = pd.read_parquet(out / "sweep.parquet")
    assert sorted(table["case"]) == list(range(160))  # every case once: none lost, none twice
    assert set(table["status"]) == {"ok"}


@pytest.mark.slow
def test_sigterm_keeps_the_finished_rows_and_a_resume_computes_only_the_rest(tmp_path):
    out = tmp_path / "stopped"
    args = CLI + ["sweep", "paper", *SLOW_CASES, "--workers", "1", "--out", str(out)]
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_parts(out, 2, process)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == 130, stderr
    assert "run the same command to resume" in stderr
    first_parts = {p.name: p.read_bytes() for p in (out / "_parts").glob("part-*.parquet")}
    done = sum(len(pq_rows(p)) for p in (out / "_parts").glob("part-*.parquet"))
    assert 0 < done < 160
    resumed = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming: {done} of 160 cases were done" in resumed.stderr
    assert all((out / "_parts" / name).read_bytes() == data for name, data in first_parts.items())
    import pandas as pd
    table = pd.read_parquet(out / "sweep.parquet")
    assert sorted(table["case"]) == list(range(160))
    new_rows = sum(len(pq_rows(p)) for p in (out / "_parts").glob("part-*.parquet") if p.name not in first_parts)
    assert new_rows == 160 - done  # the finished cases were not computed again


def pq_rows(path: Path) -> list:
    import pyarrow.parquet as pq
    return pq.read_table(path, columns=["case"]).to_pylist()


def test_plot_and_trajectories_draw_the_paper_figures(tmp_path):
    pytest.importorskip("matplotlib")
    res = subprocess.run(CLI + ["sweep", "paper", "--vary", "initial.u[2]=[-0.2,-0.3,-0.4,-0.5]",
                                "--trajectories", "4", "--plot", "--out", str(tmp_path), "--quiet"],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert len(list((tmp_path / "_trajectories").glob("case-*.parquet"))) == 4
    named = subprocess.run(CLI + ["sweep", "paper", "--vary", "initial.u[2]=linspace(-0.5,-0.1,6)",
                                  "--trajectory-cases", "1,4", "--out", str(tmp_path / "named"), "--quiet"],
                           capture_output=True, text=True, timeout=300)
    assert named.returncode == 0, named.stderr
    assert sorted(p.name for p in (tmp_path / "named" / "_trajectories").iterdir()) == \
        ["case-1.parquet", "case-4.parquet"]
    bad = subprocess.run(CLI + ["sweep", "paper", "--vary", "initial.u[2]=[-0.2]", "--trajectory-cases", "3",
                                "--out", str(tmp_path / "bad"), "--quiet"], capture_output=True, text=True,
                         timeout=300)
    assert bad.returncode == 2 and "case 3 does not exist" in bad.stderr
    for name in ("kinetic_energy.png", "delta_T_vs_delta_r.png", "delta_r_vs_initial_u2.png"):
        assert (tmp_path / "_figures" / name).exists(), name
    drawn = impactgen.sweep("paper", vary={"initial.u[2]": "uniform(-0.5,-0.1)"}, random=30, workers=1,
                            out=tmp_path / "random")
    from impactgen.sweep.figures import plot_sweep
    paths = plot_sweep(drawn, SweepSpec.from_vary({"initial.u[2]": "uniform(-0.5,-0.1)"}, random=30),
                       tmp_path / "random")
    assert {p.name for p in paths} >= {"histograms.png", "scatter_delta_r.png"}


def _sigterm_default(payload, chunk, options):
    import signal as sg
    return [{"case": i, "sigterm_default": sg.getsignal(sg.SIGTERM) == sg.SIG_DFL} for i, _ in chunk]


def test_pool_workers_end_on_sigterm_whatever_the_driver_does_with_it():
    """The command line turns SIGTERM into KeyboardInterrupt; a forked worker must not inherit
    that, or a broken pool's terminate() leaves it alive and the pool's shutdown spins."""
    import signal

    from impactgen.sweep.execute import process_pool
    saved = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        rows = [r for chunk in process_pool(_sigterm_default, {}, None, [(i, {}) for i in range(4)], 2)
                for r in chunk]
    finally:
        signal.signal(signal.SIGTERM, saved)
    assert len(rows) == 4 and all(r["sigterm_default"] for r in rows)




# a chunk function that kills its worker process whenever its chunk holds case 3, in a module
# of its own: a pool started after a broken one forks from a server (the broken pool's threads
# live on), and its workers import the function by name
_CRASHING_MODULE = """
import os
from impactgen.sweep import run
original = run.run_chunk
def crashing(payload, cases, options):
    if any(index == 3 for index, _ in cases):
        os._exit(1)
    return original(payload, cases, options)
"""
_CRASHING_SWEEP = """
import json
import crashing_chunks, impactgen
from impactgen.sweep import run
run.run_chunk = crashing_chunks.crashing
table = impactgen.sweep("paper", vary={"initial.u[2]": "linspace(-0.5,-0.1,64)"}, workers=2)
failed = table[table["status"] == "failed"]
print(json.dumps({"cases": len(table), "failed": sorted(failed["case"].tolist()),
                  "messages": sorted(set(failed["message"])), "statuses": sorted(set(table["status"]))}))
"""


@pytest.mark.slow
def test_a_chunk_that_kills_its_worker_fails_alone(tmp_path):
    """A chunk whose worker dies every time ends as failed rows after MAX_CHUNK_TRIES; the
    chunks that were in the pool beside it when it broke are run again and finish."""
    from impactgen.sweep.execute import MAX_CHUNK_TRIES, chunked
    (tmp_path / "crashing_chunks.py").write_text(_CRASHING_MODULE)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")]))}
    res = subprocess.run([sys.executable, "-c", _CRASHING_SWEEP], capture_output=True, text=True, timeout=300,
                         env=env)
    assert res.returncode == 0, res.stderr
    got = json.loads(res.stdout.strip().splitlines()[-1])
    first = [index for index, _ in chunked(list(enumerate(range(64))), 2)[0]]  # the chunk holding case 3
    assert 3 in first and len(first) < 64
    assert got["cases"] == 64 and got["failed"] == first and got["statuses"] == ["failed", "ok"]
    assert got["messages"] == [f"its worker process died {MAX_CHUNK_TRIES} times (out of memory, or killed)"]
    assert res.stderr.count("a worker process died") == MAX_CHUNK_TRIES


# ----------------------------------------------------------------------------- hostile input (issue 37)

def test_a_huge_grid_is_refused_before_it_is_made():
    """1e9 values: refused in one line naming the key and the limit, not made and then
    killed for memory (run under a 2 GB address-space limit so that a regression cannot
    take the machine's memory)."""
    code = ("import resource; resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30)); "
            "from impactgen.cli import main; raise SystemExit(main())")
    res = subprocess.run([sys.executable, "-c", code, "sweep", "paper", "--vary",
                          "initial.u[2]=linspace(-0.5,-0.1,1000000000)"], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert "initial.u[2]" in res.stderr and "10000000" in res.stderr


@pytest.mark.parametrize("vary, words", [
    (None, "expected vary="),
    (5, "expected vary="),
    ("initial.u[2]=[1,2]", "expected vary="),
    ([1, 2], "expected vary="),
    ({1: [1, 2]}, "must be a scene key"),
    ({"initial.u[2]": "linspace(0,1,1e10)"}, "limit"),
])
def test_a_vary_that_is_not_a_specification_is_named(vary, words):
    with pytest.raises(SceneError, match=words):
        impactgen.sweep("paper", vary=vary, workers=1)


def test_a_bare_number_in_vary_is_a_list_of_one():
    one = impactgen.sweep("paper", vary={"initial.u[2]": -0.3, "contact.friction": np.float64(0.2)}, workers=1)
    listed = impactgen.sweep("paper", vary={"initial.u[2]": [-0.3], "contact.friction": [0.2]}, workers=1)
    assert len(one) == 1 and _comparable(one).equals(_comparable(listed))


READERS = ["pandas", "pyarrow.dataset", pytest.param("dask", marks=pytest.mark.slow)]


def _read_folder(reader: str, folder: Path):
    if reader == "pandas":
        import pandas as pd
        return pd.read_parquet(folder)
    if reader == "pyarrow.dataset":
        import pyarrow.dataset as ds
        return ds.dataset(folder, format="parquet").to_table().to_pandas()
    dd = pytest.importorskip("dask.dataframe")
    return dd.read_parquet(str(folder)).compute()


@pytest.mark.parametrize("reader", READERS)
def test_the_out_folder_reads_as_one_dataset_each_case_once(tmp_path, reader):
    pytest.importorskip("matplotlib")
    vary = {"initial.u[2]": "linspace(-0.4,-0.2,3)"}
    table = impactgen.sweep("paper", vary=vary, workers=1, out=tmp_path, trajectories=2)
    from impactgen.sweep.figures import plot_sweep
    plot_sweep(table, SweepSpec.from_vary(vary), tmp_path)  # figures beside the table too
    read = _read_folder(reader, tmp_path)
    assert sorted(read["case"]) == [0, 1, 2]
    np.testing.assert_array_equal(read.sort_values("case")["delta_r"], table["delta_r"])


def test_a_folder_of_the_old_layout_resumes_and_reads_as_one_dataset(tmp_path):
    import pandas as pd
    vary = {"initial.u[2]": "linspace(-0.4,-0.2,3)"}
    first = impactgen.sweep("paper", vary=vary, workers=1, out=tmp_path)
    (tmp_path / "_parts").rename(tmp_path / "parts")  # as written before the "_" names
    (tmp_path / "_sweep.json").rename(tmp_path / "sweep.json")
    calls = []
    again = impactgen.sweep("paper", vary=vary, workers=1, out=tmp_path, progress=calls.append)
    assert calls == [3] and again.equals(first)  # resumed: nothing computed again
    assert sorted(pd.read_parquet(tmp_path)["case"]) == [0, 1, 2]


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_killed_driver_takes_its_workers_with_it_and_the_same_command_resumes(tmp_path):
    out = tmp_path / "driver-killed"
    args = CLI + ["sweep", "paper", *SLOW_CASES, "--workers", "2", "--out", str(out)]
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _wait_for_parts(out, 1, process)
        workers = _children(process.pid)
        assert process.poll() is None and workers, "the sweep ended before its driver could be killed"
        process.kill()  # SIGKILL: no handler runs
        process.communicate(timeout=30)
        deadline = time.monotonic() + 20
        while any(_alive(w) for w in workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(_alive(w) for w in workers), "the workers outlived their driver"
    finally:
        for w in _children(process.pid) if process.poll() is None else []:
            os.kill(w, signal.SIGKILL)
    resumed = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming:" in resumed.stderr
    import pandas as pd
    assert sorted(pd.read_parquet(out)["case"]) == list(range(160))
