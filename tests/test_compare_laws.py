"""`impactgen compare --laws` and `--speeds`: the contact laws side by side on one scene."""
from __future__ import annotations

import json

import numpy as np
import pytest

import impactgen
from impactgen.cli import main
from impactgen.contact_compare import check_laws, parse_speeds
from impactgen.scene import CONTACT_MODELS

LAWS = "three-phase,hertz"


@pytest.fixture(scope="module")
def table():
    return impactgen.compare_contact_laws("paper", LAWS)


def test_every_law_of_the_scene_schema_is_accepted():
    assert check_laws(list(CONTACT_MODELS)) == CONTACT_MODELS
    assert check_laws(" hertz, three-phase,hertz ") == ("hertz", "three-phase")


def test_table_physics(table):
    rows = {row["law"]: row for _, row in table.iterrows()}
    assert list(rows) == ["three-phase", "hertz"]
    elastic, plastic = rows["hertz"], rows["three-phase"]
    assert (table["status"] == "ok").all()
    assert elastic["delta_r"] == 0 and plastic["delta_r"] > 0  # only the plastic law leaves a permanent set
    assert elastic["coefficients.e_E"] == pytest.approx(1.0, abs=1e-6)  # Hertz returns the normal work
    assert plastic["coefficients.e_E"] < 0.9
    assert elastic["coefficients.v_n0"] == plastic["coefficients.v_n0"] < 0  # the same impact
    for row in (elastic, plastic):
        assert row["P_max"] > 0 and 1e-5 < row["t_contact"] < 1e-2 and row["delta_max"] > row["delta_r"]


def test_cli_table(capsys):
    assert main(["compare", "paper", "--laws", LAWS]) == 0
    out = capsys.readouterr().out
    for heading in ("e_N", "e_E", "delta_max (m)", "delta_r (m)", "P_max (N)", "t_contact (s)"):
        assert heading in out
    assert main(["compare", "paper", "--laws", LAWS, "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [r["law"] for r in rows] == ["three-phase", "hertz"]


def test_cli_speeds_figure(tmp_path, capsys):
    figure = tmp_path / "speeds.png"
    assert main(["compare", "paper", "--laws", LAWS, "--speeds", "0.05..0.6:4", "--out", str(figure), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert figure.stat().st_size > 10_000 and out["figure"] == str(figure)
    speeds = out["speeds"]
    assert len(speeds) == 8 and all(r["status"] == "ok" for r in speeds)
    for law in ("three-phase", "hertz"):
        rows = [r for r in speeds if r["law"] == law]
        assert [r["speed"] for r in rows] == pytest.approx([0.05, 0.2333333, 0.4166667, 0.6])
        assert np.all(np.diff([r["delta_max"] for r in rows]) > 0)  # faster, deeper
    # the speed is the tip's normal speed at contact start, as the impact records it
    table = impactgen.contact_compare.speed_sweep("paper", "hertz", [0.3])
    assert table["coefficients.v_n0"].iloc[0] == pytest.approx(-0.3, rel=1e-12)


def test_speeds_syntax():
    assert parse_speeds("0.1..1") == pytest.approx(np.linspace(0.1, 1, 10))
    assert len(parse_speeds("0.1..1:3")) == 3


@pytest.mark.parametrize("argv, message", [
    (["--laws", "three-phase,nope"], "unknown contact law 'nope'"),
    (["--laws", ","], "name at least one contact law"),
    (["--laws", "hertz", "--speeds", "1..0.1"], "0 < LOW < HIGH"),
    (["--laws", "hertz", "--speeds", "fast"], "expected LOW..HIGH[:N]"),
    (["--out", "x.png"], "is the figure of --speeds"),
    (["--laws", "hertz", "--engine", "reference"], "run in C"),
])
def test_bad_input_is_one_line(argv, message, capsys):
    assert main(["compare", "paper", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_speeds_need_the_tip_on_the_surface(capsys):
    assert main(["compare", "chain3-free-flight", "--speeds", "0.1..1:3"]) == 2
    assert "tip must start on the surface" in capsys.readouterr().err
