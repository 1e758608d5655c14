"""One driver of the phase machine: the FMU's Co-Simulation step runs the same ig_run as
`impactgen run`, so a Coulomb impact whose tip sticks (mu = 2) is reported the same way by
both: the same contact phases and stick-slip changes at the same times, and the same status
(a stuck tip that needs more than mu F without a slip event would fail both with the same
message; at mu = 2 the slip event fires and neither fails)."""
from __future__ import annotations

import numpy as np
import pytest

import impactgen
from impactgen.fmu import build_fmu

fmpy = pytest.importorskip("fmpy")
from fmpy import simulate_fmu  # noqa: E402

MU = 2.0
STOP = 1e-3  # s: past the first impact's separation
RTOL = 1e-10
SWITCH_ATOL = 1e-9  # s: the switch times agree to this (as tests/test_fmu.py's)
SLIP_LABELS = {"stick", "slip+", "slip-"}


@pytest.fixture(scope="module")
def scene():
    return impactgen.load_scene("coulomb").replace({"contact.friction": MU, "solver.rtol": RTOL})


def test_stuck_tip_is_reported_alike_by_the_fmu_and_impactgen_run(scene, tmp_path):
    run = impactgen.simulate(scene, t_end=STOP)
    assert run.status == "ok" and run.message == ""
    impact = run.impacts[0]
    stuck = [(t, a, b) for t, a, b in impact.stick_slip if b == "stick"]
    assert stuck, "the tip must stick at mu = 2 for this test to mean anything"

    events, errors = [], []

    def logger(env, instance, status, category, message):
        if category == b"logEvents":
            t, _, change = message.decode().partition(": ")
            a, _, b = change.partition(" -> ")
            events.append((float(t.split("=")[1]), a, b))
        elif status >= 3:
            errors.append(message.decode())

    fmu = build_fmu(scene, tmp_path / "coulomb.fmu")
    result = simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=STOP, relative_tolerance=RTOL,
                          output_interval=STOP / 100, debug_logging=True, logger=logger)
    assert errors == []  # the same status: no failure (ig_run's IG_ERR_STICK would log one)
    slips = [e for e in events if e[1] in SLIP_LABELS or e[2] in SLIP_LABELS]
    phases = [e for e in events if e not in slips]
    assert [(a, b) for _, a, b in slips] == [(a, b) for _, a, b in impact.stick_slip]
    expected = [(impact.t_start, "free", "elastic")] if impact.t_start > 0 else []
    expected += impact.switches
    assert [(a, b) for _, a, b in phases] == [(a, b) for _, a, b in expected]
    np.testing.assert_allclose([t for t, _, _ in slips], [t for t, _, _ in impact.stick_slip], rtol=0,
                               atol=SWITCH_ATOL)
    np.testing.assert_allclose([t for t, _, _ in phases], [t for t, _, _ in expected], rtol=0, atol=SWITCH_ATOL)
    assert result[-1]["impacts"] == len(run.impacts)
