"""The generated C phase machine, probed through cffi: its transitions, switch laws and
derived constants (the rules that once lived in Python, with the same assertions)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from impactgen.build import compile_model
from impactgen.codegen.spec import ModelSpec
from impactgen.engines import model_spec
from impactgen.laws import YIELD_ONSET, contact_constants, hertz_force, residual_deformation
from impactgen.model_params import params_at_start


class Probe:
    """One machine of a compiled model, put in a chosen state to ask what an event does."""

    def __init__(self, scene, spec: ModelSpec | None = None):
        self.model = compile_model(spec or model_spec(scene))
        self.lib, self.ffi = self.model.lib, self.model.ffi
        self.params = params_at_start(self.model, scene)
        self.m = self.ffi.new("model_machine *")
        y = list(scene.q0) + list(scene.u0) + [0.0] * (self.model.nstate - 2 * scene.n)
        self.y = self.ffi.new("double[]", y)
        self.lib.model_machine_start(self.m, self.params, 0.0, self.y, 1)
        self.tip, self.record = self.m.point[self.lib.MODEL_TIP_POINT], self.params.point[self.lib.MODEL_TIP_POINT]

    def code(self, state: str) -> int:
        return getattr(self.lib, f"MODEL_MACHINE_{state.upper()}")

    def watched(self, state: str, slip: float = 1.0) -> list[tuple[str, int]]:
        self.tip.state, self.tip.slip = self.code(state), slip
        ev, dirs = self.ffi.new("int[16]"), self.ffi.new("int[16]")
        k = self.lib.model_machine_events(self.m, ev, dirs)
        return [(self.model.event_names[ev[i]], dirs[i]) for i in range(k)]

    def after(self, state: str, fired: list[str], slip: float = 1.0) -> str:
        events = [name for name, _ in self.watched(state, slip)]
        flags = self.ffi.new("int[16]", [1 if name in fired else 0 for name in events])
        self.lib.model_machine_switch(self.m, self.params, 0.0, self.y, flags)
        return self.ffi.string(self.lib.model_machine_state_name(self.tip.state)).decode()


def test_critical_load_is_the_hertz_force_at_the_critical_deformation(paper_scene):
    c = contact_constants(paper_scene)
    assert c.P_c == pytest.approx(hertz_force(c.delta_c, c.E_star, c.R), rel=1e-12)


def test_residual_law_is_zero_up_to_the_critical_deformation():
    assert residual_deformation(0.5e-6, 1e-6) == 0.0
    assert residual_deformation(1e-6, 1e-6) == pytest.approx(0.0, abs=1e-22)
    assert 0 < residual_deformation(5e-6, 1e-6) < 5e-6


def test_the_c_derives_the_same_constants_as_the_expressions(paper_scene):
    probe = Probe(paper_scene)
    c = contact_constants(paper_scene)
    for name in ("E_star", "C_j", "B"):
        assert getattr(probe.params, name) == pytest.approx(getattr(c, name), rel=1e-14), name
    for name in ("R", "delta_c", "P_c"):  # the tip's radius's, in its own record
        assert getattr(probe.record, name) == pytest.approx(getattr(c, name), rel=1e-14), name
    # the two that only spare the elasto-plastic law work per call
    assert probe.record.inv_delta_c == pytest.approx(1 / c.delta_c, rel=1e-15)
    assert probe.record.theta_c == pytest.approx(math.pi * math.sqrt(c.delta_c / c.R) * 1.9 ** (-c.B / 2), rel=1e-14)


def test_reloading_rules_follow_the_curve_it_left(paper_scene):
    probe = Probe(paper_scene)
    assert ("max_compression", 1) in probe.watched("restitution")  # rate turns positive
    c = contact_constants(paper_scene)
    probe.record.delta_m = 10e-6
    assert probe.after("restitution", ["max_compression"]) == "reloading"
    assert probe.record.phase == probe.lib.MODEL_PHASE_RESTITUTION  # reloads along the unloading curve
    assert probe.after("reloading", ["max_compression"]) == "restitution"
    assert probe.after("reloading", ["passes_delta_m"]) == "elastoplastic"
    probe.record.delta_m = 1.5 * c.delta_c
    assert 1.5 < YIELD_ONSET
    assert probe.after("reloading", ["passes_delta_m"]) == "elastic"
    assert probe.after("restitution", ["separation"]) == "free"
    hertz = Probe(paper_scene, ModelSpec(2, "hertz", "regularized"))
    assert hertz.after("reloading", ["passes_delta_m"]) == "elastic"
    assert ("contact", -1) in hertz.watched("restitution")  # Hertz only: delta_r = 0


def test_lift_off_is_the_only_end_of_sustained_contact(paper_scene):
    probe = Probe(paper_scene, ModelSpec(2, "three-phase", "regularized", sustained=True))
    assert probe.watched("sustained") == [("lift_off", -1)]
    assert probe.after("sustained", ["lift_off"]) == "free"


def test_stick_slip_rules(paper_scene):
    probe = Probe(paper_scene, ModelSpec(2, "three-phase", "coulomb"))
    stopped = probe.lib.model_slip_when_stopped
    # at a stop: stick strictly inside the cone, else slip the way the tip is pushed
    assert stopped(10.0, 5.0, 0.6) == 0.0
    assert stopped(10.0, 7.0, 0.6) == -1.0
    assert stopped(10.0, -7.0, 0.6) == +1.0
    # each stick-slip state watches its own ends
    assert ("slip_stops", -1) in probe.watched("elastic", slip=+1.0)
    assert ("slip_stops", 1) in probe.watched("elastic", slip=-1.0)
    assert {("slip_backward", -1), ("slip_forward", -1)} <= set(probe.watched("elastic", slip=0.0))
    # leaving a stick: by the side of the cone reached, the contact phase unchanged
    assert probe.after("elastic", ["slip_backward"], slip=0.0) == "elastic" and probe.tip.slip == -1.0
    assert probe.after("elastic", ["slip_forward"], slip=0.0) == "elastic" and probe.tip.slip == +1.0
    assert probe.record.slip == probe.tip.slip


def test_a_bad_input_is_named_by_its_scene_key(paper_scene):
    probe = Probe(paper_scene)
    text = probe.ffi.new("char *[1]")
    probe.params.nu_rod = 0.7
    bad = probe.lib.model_derive(probe.params, text)
    assert probe.ffi.string(probe.lib.model_param_key(bad)).decode() == "rod.nu"
    assert probe.ffi.string(text[0]).decode() == "(-1, 0.5)"
    probe.params.nu_rod, probe.params.m2 = 0.29, 0.0
    bad = probe.lib.model_derive(probe.params, text)
    assert probe.ffi.string(probe.lib.model_param_key(bad)).decode() == "chain.mass[2]"


def test_free_flight_and_impact_tolerances(paper_scene):
    probe = Probe(paper_scene)
    atol = probe.ffi.new("double[8]")  # q, u, the works, the impulses
    probe.tip.state = probe.lib.MODEL_MACHINE_FREE
    probe.lib.model_machine_atol(probe.m, probe.params, 1e-8, 1e-12, atol)
    assert list(atol)[:4] == [1e-12] * 4 and atol[4] > 1e-12  # the works: times a typical energy
    probe.lib.model_machine_start(probe.m, probe.params, 0.0, probe.y, 1)
    probe.tip.state = probe.lib.MODEL_MACHINE_ELASTIC
    probe.tip.scale[0] = probe.tip.scale[1] = 1e-8
    probe.lib.model_machine_atol(probe.m, probe.params, 1e-8, 1e-12, atol)
    assert atol[0] == pytest.approx(1e-15)  # floored at the double precision of a tip height
    assert np.all(np.array(list(atol)) <= np.array([1e-12] * 4 + [np.inf] * 4))


def test_the_embedding_guide_lists_the_parameter_table():
    from pathlib import Path
    from impactgen.codegen.parameters import markdown_table
    text = (Path(__file__).resolve().parents[1] / "docs" / "embedding.md").read_text()
    shown = text.split("<!-- parameters:begin -->\n")[1].split("\n<!-- parameters:end -->")[0]
    assert shown == markdown_table(), "regenerate the table in docs/embedding.md from codegen/parameters.py"


@pytest.mark.parametrize("q_deg, height, expected", [
    ((-70.0, -60.0), None, -1),          # the paper's start: the tip on the surface
    ((-70.0, -60.0), -1.81, -1),         # the tip above it
    ((-70.0, -60.0), -1.8, 2),           # the tip 6 mm inside the surface
    ((-30.0, -90.0), -0.49, 2),          # joint 1 and the tip below the surface: the tip named first
    ((-30.0, 90.0), -0.49, 1),           # joint 1 below the surface, the tip above it
    ((-30.0, 80.0), None, 0),            # surface "initial": the tip high, the pivot under it
    ((20.0, 0.0), -0.1, -1),             # every point above the surface
    ((-70.0, -60.0), 0.2, 2),            # the pivot and the tip under the surface: the tip named first
    ((80.0, 80.0), 0.2, 0),              # the pivot under the surface, the chain above it
])
def test_the_c_start_check_refuses_what_the_scene_check_refuses(paper_scene, q_deg, height, expected):
    """model_machine_start_inside (what the FMU and the C driver run) names the same first
    point inside the surface as the scene's own check refuses."""
    from impactgen.errors import SceneError
    from impactgen.scene.physics import check_physics
    try:
        check_physics(paper_scene.replace({"initial.q_deg": list(q_deg),
                                           "surface.height": "initial" if height is None else height}))
        refused = False
    except SceneError:
        refused = True
    assert refused == (expected >= 0)
    probe = Probe(paper_scene)
    lib, ffi = probe.lib, probe.ffi
    params = params_at_start(probe.model, paper_scene)
    params.surface_initial = 1.0 if height is None else 0.0
    params.surface_height = 0.0 if height is None else height
    y = ffi.new("double[]", [math.radians(q) for q in q_deg] + [0.0] * (probe.model.nstate - 2))
    depth = ffi.new("double *")
    assert lib.model_machine_start_inside(params, y, depth) == expected
    assert (depth[0] > 0.0) == (expected >= 0)


def test_slip_names(paper_scene):
    lib = Probe(paper_scene, ModelSpec(2, "three-phase", "coulomb")).lib
    names = {s: lib.model_machine_slip_name(lib.MODEL_MACHINE_ELASTIC, s) for s in (1.0, -1.0, 0.0)}
    from cffi import FFI
    assert {s: FFI().string(n).decode() for s, n in names.items()} == {1.0: "slip+", -1.0: "slip-", 0.0: "stick"}
    assert FFI().string(lib.model_machine_slip_name(lib.MODEL_MACHINE_FREE, 0.0)).decode() == ""
