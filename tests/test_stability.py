"""The stability catalogue: cases end ok, or fail with a named reason; the checks bite."""
from __future__ import annotations

import pytest

from impactgen.stability import Case, catalogue, run_case


def test_catalogue_covers_the_kinds_of_case_asked_for():
    groups = {c.group for c in catalogue()}
    assert groups >= {"moduli", "tip radius", "approach speed", "friction", "chain length",
                      "degenerate", "repeated impacts"}
    assert any(c.links == 20 for c in catalogue())


@pytest.mark.parametrize("case, status", [
    (Case("paper", "reference", {}), "ok"),
    (Case("stiff modulus", "moduli", {"rod.E": 1e12, "surface.E": 1e12}), "ok"),
    (Case("soft tip", "tip radius", {"rod.tip_radius": 1e-5}), "ok"),
    (Case("approach 1e-2", "approach speed", {"initial.u": [-5e-3, -1e-2]}), "ok"),
    (Case("touching, moving away", "degenerate", {"initial.u": [0.1, 0.2]}), "no-impact"),
    (Case("soft", "moduli", {"rod.E": 1e6, "surface.E": 1e6, "rod.yield_strength": 5e3,
                             "surface.yield_strength": 5e3}), "ok"),
    (Case("approach 10", "approach speed", {"initial.u": [-5.0, -10.0]}), "ok"),
    (Case("mu=2 coulomb", "friction", {"contact.friction": 2.0, "contact.friction_mode": "coulomb"}), "ok"),
    (Case("link at -90 deg", "degenerate", {"initial.q_deg": [-90.0, -60.0]}), "ok"),
    (Case("1.5 s, sustained contact", "repeated impacts", {"solver.t_end": 1.5}), "ok"),
    (Case("3 links", "chain length", {}, links=3), "ok"),
])
def test_cases_end_ok_with_physical_checks(case, status):
    row = run_case(case, "bdf, rtol 1e-8, analytic J")
    assert row["status"] == status, row
    if status == "ok":
        assert row["budget_error"] < 1e-6 and 0 <= row["delta_r"] <= row["delta_max"]


def test_failures_carry_their_reason():
    row = run_case(Case("few steps", "limits", {"solver.max_steps": 50}), "adams, rtol 1e-8")
    assert row["status"] == "failed" and "more than 50 steps" in row["reason"]
    # an impact too gentle for double precision fails the energy check, and says so
    row = run_case(Case("approach 1e-6", "approach speed", {"initial.u": [-5e-7, -1e-6]}),
                   "bdf, rtol 1e-8, analytic J")
    assert row["status"] == "check failed" and "energy budget" in row["reason"]


def test_report_compares_stiff_friction_with_coulomb(tmp_path):
    from impactgen.stability import write_report
    rows = [run_case(Case(name, "friction", over), "bdf, rtol 1e-8, analytic J") for name, over in (
        ("mu=0.5 eps=1e-10", {"contact.friction": 0.5, "contact.friction_eps": 1e-10}),
        ("mu=0.5 coulomb", {"contact.friction": 0.5, "contact.friction_mode": "coulomb"}))]
    text = write_report(rows, tmp_path, quick=True).read_text()
    line = next(x for x in text.splitlines() if x.startswith("| 0.5 | bdf"))
    ratio = float(line.split("|")[-2])
    assert 1.0 <= ratio < 10.0  # the stiff regularization costs more steps, within the target
