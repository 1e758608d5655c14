"""The pure-C driver (examples/c): the generated model, its phase machine and CVODE, no Python.
Built with its one documented command; its summary matches `impactgen run`."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import impactgen

FIELDS = ("T0", "Tf", "delta_max", "delta_r", "P_max", "R_res", "t_contact")


def build_and_run(scene_name: str, folder: Path, c_driver) -> dict[str, str]:
    subprocess.run([sys.executable, "-m", "impactgen.cli", "generate", scene_name, "--out", str(folder)],
                   check=True, capture_output=True, text=True)
    out = subprocess.run([str(c_driver(folder))], capture_output=True, text=True, check=True).stdout
    return dict(line.split(" ", 1) for line in out.splitlines())


@pytest.mark.parametrize("scene_name", ["paper", "chain3-free-flight"])
def test_c_driver_matches_impactgen_run(scene_name, tmp_path, c_driver):
    printed = build_and_run(scene_name, tmp_path / "model", c_driver)
    result = impactgen.simulate(impactgen.load_scene(scene_name))
    s = result.first_impact
    assert printed["status"] == "ok" and int(printed["impacts"]) == len(result.impacts)
    for name in FIELDS:
        assert float(printed[name]) == pytest.approx(s[name], rel=1e-8), name
    for i, u in enumerate(s["u_final"], start=1):
        assert float(printed[f"u_final[{i}]"]) == pytest.approx(u, rel=1e-8)
    assert float(printed["W_normal"]) == pytest.approx(s["energy"]["W_normal"], rel=1e-8)


@pytest.mark.slow  # generates and compiles a 4-link model
def test_c_driver_builds_a_model_generated_with_a_prefix(tmp_path, c_driver):
    """`impactgen --links 4 --prefix chain4 --out D`, then examples/c's make with MODEL=D: the
    Makefile finds the prefix by the folder's chain4_scene.h and gives the runtime its names."""
    folder = tmp_path / "chain4"
    subprocess.run([sys.executable, "-m", "impactgen.cli", "--links", "4", "--prefix", "chain4", "--out", str(folder)],
                   check=True, capture_output=True, text=True)
    assert (folder / "chain4.c").exists() and not (folder / "model.c").exists()
    out = subprocess.run([str(c_driver(folder))], capture_output=True, text=True, check=True).stdout
    printed = dict(line.split(" ", 1) for line in out.splitlines())
    s = impactgen.simulate(impactgen.load_scene(folder / "scene.toml")).first_impact
    assert printed["scene"] == "steel-chain-4" and printed["status"] == "ok"
    for name in FIELDS:
        assert float(printed[name]) == pytest.approx(s[name], rel=1e-8), name


def test_c_driver_runs_a_free_rod(tmp_path, c_driver):
    """rod-drop (a free rod, both ends striking in turn) from its generated folder: the C
    driver's impacts, by point, and its final state (the base point's too) are impactgen's."""
    printed = build_and_run("rod-drop", tmp_path / "model", c_driver)
    result = impactgen.simulate(impactgen.load_scene("rod-drop"))
    assert printed["status"] == "ok"
    points = [printed[f"impact[{i}].point"] for i in range(1, len(result.impacts) + 1)]
    assert points == [impact.point for impact in result.impacts] and {"base", "tip"} <= set(points)
    final = result.summary
    # its summary's counts are every point's: per point by number (0 the base, 1 the tip), and the first's point
    assert int(printed["impacts"]) == final["impacts"] == len(result.impacts)
    assert {"base": int(printed["point_impacts[0]"]), "tip": int(printed["point_impacts[1]"])} == final["point_impacts"]
    assert int(printed["first_point"]) == final["first_point"] == 0
    assert float(printed["delta_max"]) == pytest.approx(final["delta_max"], rel=1e-8)
    assert float(printed["u_final[1]"]) == pytest.approx(final["u_final"][0], rel=1e-8)
    for i, value in enumerate(result.base[:2, -1], start=1):
        assert float(printed[f"base_final[{i}]"]) == pytest.approx(value, rel=1e-8)
