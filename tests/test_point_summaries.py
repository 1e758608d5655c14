"""A run's summaries cover every contact point (docs/model.md section 6): the first impact is
the run's first at whichever point, with that point's own record and coefficients; the run's
counts and records are over every point's impacts, and the impacts are counted per point."""
from __future__ import annotations

import math

import pytest

import impactgen
from impactgen.sweep.chunk import summary_column_names

# rod-drop (a free rod, its lower end 5 cm above the plate): the base point strikes first
TO_SEPARATION = {"solver.t_end": None}
# the 3-link chain of docs/model.md section 5c released at rest, joint 2 lands first and comes to rest
JOINT_LANDS = {"chain.links": 3, "chain.length": [1, 1, 0.2], "initial.q_deg": [-30, -80, 60],
               "initial.u": [0, 0, 0], "surface.height": -1.5, "solver.t_end": 1}
AGREE = 1e-6  # the engines' summaries, relative (each at the scene's rtol)


def _by_point(result) -> dict[str, int]:
    counts: dict[str, int] = {}
    for impact in result.impacts:
        counts[impact.point] = counts.get(impact.point, 0) + 1
    return counts


def test_a_free_rod_that_strikes_first_at_its_base_reports_that_impact():
    result = impactgen.simulate(impactgen.load_scene("rod-drop", TO_SEPARATION))
    assert result.status == "ok", result.message
    summary, base = result.summary, result.impacts[0]
    assert base.point == "base" and len(result.impacts) == 1
    assert summary["impacts"] == 1 and summary["point_impacts"] == {"base": 1, "tip": 0}
    assert summary["first_point"] == 0 and summary["t_impact"] == base.t_start
    assert summary["delta_max"] == base.delta_max > 0 and summary["delta_r"] == base.delta_r > 0
    assert summary["t_contact"] == pytest.approx(base.duration, rel=1e-12)
    # the coefficients are the base's own: its own normal speed (v_y_J0), impulses and works
    v_y = result.trajectory.outputs["v_y_J0"]
    coefficients = summary["coefficients"]
    assert coefficients["v_n0"] == v_y[base.i_start] < 0
    assert coefficients["e_N"] == pytest.approx(-v_y[base.i_end] / v_y[base.i_start], rel=1e-12)
    for name, value in base.coefficients().items():
        assert coefficients[name] == pytest.approx(value, rel=1e-12), name
    assert 0 < coefficients["e_N"] < 1


def test_a_chain_that_lands_on_joint_2_first_reports_joint_2s_impact():
    result = impactgen.simulate(impactgen.load_scene("paper", JOINT_LANDS))
    assert result.status == "ok", result.message
    first, joint = result.first_impact, result.impacts[0]
    assert joint.point == "joint 2" and first["first_point"] == 2
    assert first["delta_max"] == joint.delta_max > 0 and first["t_impact"] == joint.t_start
    assert first["switches"][0]["t"] == joint.switches[0][0]
    run = result.summary
    assert run["first_point"] == 2 and run["impacts"] == len(result.impacts)
    assert run["point_impacts"] == {"joint 1": 0, **_by_point(result)}
    assert run["delta_max"] == max(impact.delta_max for impact in result.impacts)
    assert run["t_sustained"] is not None  # joint 2 comes to rest on the surface
    assert run["t_contact"] == pytest.approx(sum((i.t_end if i.t_end is not None else run["t_final"]) - i.t_start
                                                 for i in result.impacts), rel=1e-12)


def _flat(summary: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in summary.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        elif not isinstance(value, list) or key.endswith("_final"):
            out[prefix + key] = value
    return out


@pytest.mark.parametrize("overrides, counts", [(TO_SEPARATION, {"base": 1, "tip": 0}),
                                               ({"solver.sustained_contact": False}, {"base": 2, "tip": 1})],
                         ids=["first-impact", "both-ends"])
def test_the_engines_agree_on_every_points_summaries(overrides, counts):
    """rod-drop in both engines: to separation (the base's impact), and over its 0.25 s (the
    base, the tip, the base again): every field of both summaries."""
    scene = impactgen.load_scene("rod-drop", overrides)
    c, ref = impactgen.simulate(scene), impactgen.simulate(scene, engine="reference")
    assert c.status == ref.status == "ok"
    for which in ("summary", "first_impact"):
        ours, theirs = _flat(getattr(c, which)), _flat(getattr(ref, which))
        assert ours.keys() == theirs.keys()
        scale = max(ours["T0"], ours["Tf"])
        for key, value in ours.items():
            other = theirs[key]
            if value is None or isinstance(value, int) and not isinstance(value, bool):
                assert value == other, (which, key)
            elif isinstance(value, list):
                assert value == pytest.approx(other, rel=AGREE, abs=1e-12), (which, key)
            else:
                assert value == pytest.approx(other, rel=AGREE, abs=AGREE * scale if key == "energy.residual" else 0), \
                    (which, key)
    assert c.summary["point_impacts"] == counts


def test_a_sweep_over_a_free_rod_has_a_column_per_point(tmp_path):
    frame = impactgen.sweep(impactgen.load_scene("rod-drop"), {"initial.q_deg[1]": [20.0, 30.0]},
                            out=tmp_path / "sweep", workers=1)
    assert {"point_impacts.base", "point_impacts.tip"} <= set(frame.columns)
    assert "joint_impacts" not in frame.columns
    for _, row in frame.iterrows():
        assert row["point_impacts.base"] + row["point_impacts.tip"] == row["impacts"]
        assert row["point_impacts.base"] >= 1 and row["first_point"] == 0
    assert set(summary_column_names(1, free=True)) <= set(frame.columns)


def test_the_papers_scene_reports_as_before():
    """Only the tip can touch: the summaries are the tip's, as they always were."""
    result = impactgen.simulate(impactgen.load_scene("paper"))
    summary = result.summary
    assert summary["impacts"] == 1 and summary["point_impacts"] == {"joint 1": 0, "tip": 1}
    assert summary["first_point"] == 2 and summary["delta_max"] == result.impacts[0].delta_max
    assert not math.isnan(summary["coefficients"]["e_N"])
