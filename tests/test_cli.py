"""The command line: JSON contract, generation, exit codes and one-line errors."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from conftest import PAPER


def impactgen(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "impactgen.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


def test_run_json_prints_one_object_with_the_contract_keys():
    res = impactgen("run", str(PAPER), "--json", "--set", "initial.u=[-0.1,-0.3]")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert set(out) >= {"scene", "engine", "status", "summary", "phases", "stats"}
    assert out["scene"] == "paper-double-pendulum" and out["engine"] == "c" and out["status"] == "ok"
    s = out["summary"]
    for key in ("T0", "Tf", "delta_T", "delta_max", "delta_r", "P_max", "R_res", "t_contact",
                "u_final", "q_final", "energy"):
        assert key in s
    assert set(s["energy"]) >= {"W_normal", "W_friction", "W_gravity"}
    assert s["delta_r"] == pytest.approx(8.64e-6, rel=0.03)
    assert [p["phase"] for p in out["phases"]] == ["elastic", "elastoplastic", "restitution"]
    assert set(out["stats"]) >= {"nsteps", "nfev", "wall_s"}


def test_run_prints_a_readable_summary():
    res = impactgen("run", str(PAPER))
    assert res.returncode == 0, res.stderr
    assert "delta_r" in res.stdout and "energy budget" in res.stdout


def test_links_generates_and_compiles(tmp_path):
    res = impactgen("--links", "3", "--out", str(tmp_path / "c3"))
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "c3" / "model.h").exists() and (tmp_path / "c3" / "model.c").exists()
    assert str(tmp_path / "c3") in res.stdout


@pytest.mark.parametrize("args, code, words", [
    (["run", "missing.toml"], 2, "not found"),
    (["run", str(PAPER), "--set", "chain.mas=2"], 2, "chain.mas"),
    (["run", str(PAPER), "--set", "novalue"], 2, "KEY=VALUE"),
    (["run", str(PAPER), "--set", "chain.mass=-1"], 2, "chain.mass"),
    (["--links", "0"], 2, "--links"),
    (["--links", "three"], 2, "invalid int"),
    (["frobnicate"], 2, "invalid choice"),
    (["run", str(PAPER), "--set", "contact.friction_mode=sticky"], 2, "coulomb"),
])
def test_bad_input_exits_2_with_one_line(args, code, words):
    res = impactgen(*args)
    assert res.returncode == code
    assert words in res.stderr
    assert "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_solver_failure_exits_4():
    res = impactgen("run", str(PAPER), "--set", "solver.max_steps=5")
    assert res.returncode == 4
    assert "max_steps" in res.stderr and "elastic" in res.stderr
    assert "Traceback" not in res.stderr


def test_compiler_failure_exits_3_with_the_compiler_error(tmp_path):
    env = {**__import__("os").environ, "IMPACTGEN_CACHE_DIR": str(tmp_path),
           "CFLAGS": "-include /nonexistent/impactgen-missing.h"}
    res = subprocess.run([sys.executable, "-m", "impactgen.cli", "--links", "1", "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, timeout=600, env=env)
    assert res.returncode == 3
    assert "impactgen-missing.h" in res.stderr and "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_unwritable_cache_exits_3():
    env = {**__import__("os").environ, "IMPACTGEN_CACHE_DIR": "/proc/impactgen-cache"}
    res = subprocess.run([sys.executable, "-m", "impactgen.cli", "run", str(PAPER)],
                         capture_output=True, text=True, timeout=600, env=env)
    assert res.returncode == 3 and "IMPACTGEN_CACHE_DIR" in res.stderr


@pytest.mark.parametrize("prefix", ["x; int evil", "../x", "model\n#include", "1abc", "é"])
def test_c_prefix_must_be_an_identifier(prefix, tmp_path):
    res = impactgen("--links", "1", "--prefix", prefix, "--out", str(tmp_path))
    assert res.returncode == 2 and "--prefix" in res.stderr
    assert not any(tmp_path.iterdir())


def test_no_arguments_is_one_line_pointing_at_help():
    res = impactgen()
    assert res.returncode == 2 and "--help" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- whole runs, discovery

def test_json_carries_the_impacts_beside_the_whole_run_summary():
    res = impactgen("run", str(PAPER), "--json", "--set", "solver.t_end=0.2", "--set", "solver.rtol=1e-8")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    impacts = out["impacts"]
    assert len(impacts) == out["summary"]["impacts"] >= 3
    assert {"t_start", "t_end", "duration", "delta_max", "delta_r", "P_max", "R_res", "T_before",
            "T_after", "W_normal", "W_friction", "switches"} <= set(impacts[0])
    assert out["summary"]["t_final"] == pytest.approx(0.2)
    assert out["first_impact"]["u_final"] != out["summary"]["u_final"]
    assert out["first_impact"]["delta_r"] == impacts[0]["delta_r"]


def test_run_prints_the_whole_run_and_a_table_of_impacts():
    res = impactgen("run", "bouncing")
    assert res.returncode == 0, res.stderr
    assert "whole run to t = 2 s" in res.stdout and "sustained contact from" in res.stdout
    assert "first impact:" in res.stdout and "t_start (s)" in res.stdout and "more)" in res.stdout
    # contact phases in microseconds from the impact's start, not 4 figures of absolute time
    assert "elastic 0-43.1" in res.stdout


def test_solver_failure_with_json_prints_the_partial_result():
    res = impactgen("run", str(PAPER), "--json", "--set", "solver.max_steps=5")
    assert res.returncode == 4
    out = json.loads(res.stdout)
    assert out["status"] == "failed" and "max_steps" in out["message"]


def test_chain_below_the_surface_exits_2_naming_the_link():
    res = impactgen("run", str(PAPER), "--set", "initial.q_deg=[20.0, 30.0]")
    assert res.returncode == 2
    assert "initial.q" in res.stderr and "link 1" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_out_writes_trajectories_impacts_and_summary(tmp_path):
    import pandas as pd
    import pyarrow.parquet as pq
    res = impactgen("run", str(PAPER), "--set", "solver.t_end=0.2", "--set", "solver.rtol=1e-8",
                    "--out", str(tmp_path / "pq"))
    assert res.returncode == 0, res.stderr
    table = pq.read_table(tmp_path / "pq" / "trajectory.parquet")
    assert table.schema.field("q1").metadata[b"unit"] == b"rad"
    assert table.schema.field("F").metadata[b"unit"] == b"N"
    frame = table.to_pandas()
    assert {"t", "q1", "q2", "u1", "u2", "W_normal", "delta", "F", "T", "V", "phase"} <= set(frame.columns)
    impacts = pd.read_parquet(tmp_path / "pq" / "impacts.parquet")
    summary = json.loads((tmp_path / "pq" / "summary.json").read_text())
    assert len(impacts) == summary["summary"]["impacts"]
    assert frame["t"].iloc[-1] == pytest.approx(0.2)
    res = impactgen("run", str(PAPER), "--out", str(tmp_path / "csv"), "--format", "csv")
    assert res.returncode == 0, res.stderr
    first = (tmp_path / "csv" / "trajectory.csv").read_text().splitlines()[0]
    assert first.startswith("# units:") and "q1 [rad]" in first and "F [N]" in first
    csv = pd.read_csv(tmp_path / "csv" / "trajectory.csv", comment="#")
    assert csv["delta"].max() == pytest.approx(2.05e-5, rel=1e-2)


def test_examples_are_listed_copied_and_run_from_another_folder(tmp_path):
    res = impactgen("examples", cwd=tmp_path)
    assert res.returncode == 0
    for name in ("paper", "chain3-free-flight", "coulomb", "bouncing", "aluminium-on-steel"):
        assert name in res.stdout
    res = impactgen("examples", "coulomb", cwd=tmp_path)
    assert res.returncode == 0 and (tmp_path / "coulomb.toml").exists()
    res = impactgen("run", "paper", "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["summary"]["delta_r"] == pytest.approx(5.57e-6, rel=2e-3)
    res = impactgen("run", "nonesuch", cwd=tmp_path)
    assert res.returncode == 2 and "impactgen examples" in res.stderr


def test_version_and_help_texts():
    import argparse
    import impactgen as package
    from impactgen.cli.parser import build_parser
    res = impactgen("--version")
    assert res.returncode == 0 and package.__version__ in res.stdout
    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for sub in [parser, *commands.choices.values()]:
        for action in sub._actions:
            if not isinstance(action, argparse._SubParsersAction):
                assert action.help, f"{sub.prog} {action.option_strings or action.dest} has no help text"
    assert impactgen("run", "--help").returncode == 0


def test_links_writes_a_scene_to_run(tmp_path):
    res = impactgen("--links", "3", "--out", str(tmp_path / "c3"))
    assert res.returncode == 0, res.stderr
    scene = tmp_path / "c3" / "scene.toml"
    assert scene.exists() and str(scene) in res.stdout
    res = impactgen("run", str(scene), "--json", "--set", "solver.rtol=1e-8")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["scene"] == "steel-chain-3"


def test_plot_draws_the_whole_run_one_impact_or_a_window(tmp_path):
    pytest.importorskip("matplotlib")
    res = impactgen("plot", str(PAPER), "--set", "solver.t_end=0.2", "--set", "solver.rtol=1e-8",
                    "--out", str(tmp_path / "run"))
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "run" / "run_overview.png").exists()
    res = impactgen("plot", str(PAPER), "--set", "solver.t_end=0.2", "--set", "solver.rtol=1e-8",
                    "--impact", "2", "--out", str(tmp_path / "k2"))
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "k2" / "deformation_force.png").exists()
    res = impactgen("plot", str(PAPER), "--window", "0:0.0002", "--out", str(tmp_path / "w"))
    assert res.returncode == 0 and (tmp_path / "w" / "angles.png").exists()
    res = impactgen("plot", str(PAPER), "--impact", "9", "--out", str(tmp_path / "bad"))
    assert res.returncode == 2 and "--impact" in res.stderr


def test_stability_prints_its_pass_count(tmp_path, monkeypatch, capsys):
    from impactgen import cli, stability
    monkeypatch.setattr(stability, "catalogue", lambda quick=False: [stability.Case("paper", "reference", {})])
    assert cli.main(["stability", "--quick", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "stability: 2 of 2 runs passed" in out


def test_generate_writes_only_into_an_empty_or_generated_folder(tmp_path):
    """The user's own model.c is not replaced silently (issue 37): only with --force."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "model.c").write_text("/* my own model */\n")
    res = impactgen("generate", "paper", "--out", str(out))
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "model.c" in res.stderr and "--force" in res.stderr
    assert (out / "model.c").read_text() == "/* my own model */\n"
    other = tmp_path / "notes"  # a folder of the user's, no file in the way: still not ours
    other.mkdir()
    (other / "notes.txt").write_text("mine\n")
    assert impactgen("generate", "paper", "--out", str(other)).returncode == 2
    fresh = tmp_path / "fresh"
    assert impactgen("generate", "paper", "--out", str(fresh)).returncode == 0
    assert impactgen("generate", "paper", "--out", str(fresh)).returncode == 0  # ours: written again
    (fresh / "model.c").write_text("/* edited by hand */\n")
    again = impactgen("generate", "paper", "--out", str(fresh))
    assert again.returncode == 2 and "model.c" in again.stderr
    assert (fresh / "model.c").read_text() == "/* edited by hand */\n"
    forced = impactgen("generate", "paper", "--out", str(out), "--force")
    assert forced.returncode == 0, forced.stderr
    assert "my own model" not in (out / "model.c").read_text()
    links = impactgen("--links", "1", "--out", str(other))
    assert links.returncode == 2 and "--force" in links.stderr


# ----------------------------------------------------------------------------- the generated folder

@pytest.mark.parametrize("prefix, words", [("a" * 300, "300 characters"), ("m" * 33, "at most 32"),
                                           ("_model", "starting with a letter")])
def test_a_bad_prefix_is_refused_before_anything_is_written(prefix, words, tmp_path):
    """Run twice: each time one line, exit 2, and no folder made (issue 45)."""
    out = tmp_path / "D"
    for _ in range(2):
        res = impactgen("--links", "2", "--prefix", prefix, "--out", str(out))
        assert res.returncode == 2 and "--prefix" in res.stderr and words in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1 and "Traceback" not in res.stderr
        assert len(res.stderr) < 300  # a bounded excerpt of the prefix, not all of it
        assert not out.exists()


def test_an_out_folder_that_cannot_be_one_is_refused_up_front(tmp_path):
    (tmp_path / "file").write_text("mine\n")
    for out in (tmp_path / "file", tmp_path / "file" / "sub"):
        res = impactgen("generate", "paper", "--out", str(out))
        assert res.returncode == 2 and "--out" in res.stderr and "is a file" in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1
    assert (tmp_path / "file").read_text() == "mine\n"


@pytest.mark.parametrize("existing", [False, True])
def test_a_write_that_fails_leaves_the_folder_as_it_was(existing, tmp_path, monkeypatch):
    """A write that fails half-way (a full disk, say) ends in one BuildError and leaves neither
    a new folder nor a half-made one: the files are renamed into place only once all are written."""
    from pathlib import Path

    from impactgen.cli import generated
    from impactgen.errors import BuildError
    out = tmp_path / "new" / "D"
    if existing:
        generated._write_generated(out, {"model.c": "/* first */\n", "model.h": "/* first */\n"})
        before = {p.name: p.read_text() for p in out.iterdir()}
    written = []
    real = Path.write_text

    def fails_on_the_second(path, text, *args, **kwargs):
        written.append(path)
        if len(written) == 2:
            raise OSError(28, "No space left on device")
        return real(path, text, *args, **kwargs)
    monkeypatch.setattr(Path, "write_text", fails_on_the_second)
    with pytest.raises(BuildError, match="No space left on device") as failed:
        generated._write_generated(out, {"model.c": "/* second */\n", "model.h": "/* second */\n"})
    assert failed.value.exit_code == 3
    if existing:
        assert {p.name: p.read_text() for p in out.iterdir()} == before
    else:
        assert not (tmp_path / "new").exists()


# ----------------------------------------------------------------------------- the text report

def test_the_report_names_the_point_of_one_impact_in_a_table():
    import impactgen as package
    from impactgen.cli import format_summary
    text = format_summary(package.simulate(package.load_scene(PAPER)))
    assert "first impact: the tip, t_start = 0 s" in text
    assert "delta_max = 2.04" in text and "P_max     = 806" in text and "t_contact = 0.00046" in text
    assert "delta_m " not in text and "P_m " not in text and "duration  " not in text
    table = text[text.index("impacts:"):].splitlines()
    assert table[1].split()[:2] == ["impact", "point"] and table[2].split()[:2] == ["1", "tip"]


def test_the_report_describes_the_first_impact_wherever_it_happened():
    """A run to separation whose first (and only) impact is a joint's: that impact, named, not
    the tip's zeros (issue 45)."""
    import impactgen as package
    from impactgen.cli import format_summary
    scene = package.load_scene(PAPER, {"chain.links": 3, "chain.length": [1, 1, 0.2],
                                       "initial.q_deg": [-30, -80, 60], "initial.u": [0, 0, 0],
                                       "surface.height": -1.5})
    result = package.simulate(scene)
    joint = result.impacts[0]
    assert joint.point == "joint 2" and result.first_impact["first_point"] == 2  # the summary is joint 2's
    assert result.first_impact["delta_max"] == joint.delta_max > 0
    text = format_summary(result)
    assert f"first impact: joint 2, t_start = {joint.t_start:.9g} s" in text
    assert f"delta_max = {joint.delta_max:.6g} m" in text and f"P_max     = {joint.P_max:.6g} N" in text
    assert "phases of impact 1" in text and "elastic 0-" in text
    assert "  joint 2 " in text[text.index("impacts:"):]
