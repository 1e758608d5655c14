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
