"""The field's compliant contact laws (contact.model, docs/contact-laws.md): each against an
independent integration of its own equation, and the two engines against each other."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import impactgen
from impactgen import crosscheck
from impactgen.errors import SceneError
from conftest import PAPER

HERTZ_DAMPED = ("hunt-crossley", "lankarani-nikravesh", "flores", "gonthier")
ENGINES = ("c", "reference")
# a single steel bar, horizontal when its tip meets the surface, gravity off, frictionless:
# the tip moves along the surface normal, as a point of mass m/3 (I/L^2 about the pivot)
M, L, E, NU, R_TIP, V0 = 1.0, 1.0, 210e9, 0.29, 0.005, 1.0
E_STAR = E / (2 * (1 - NU ** 2))
K_HERTZ = 4 / 3 * E_STAR * math.sqrt(R_TIP)
CHI = {"hunt-crossley": lambda e: 1.5 * (1 - e), "lankarani-nikravesh": lambda e: 0.75 * (1 - e ** 2),
       "flores": lambda e: 1.6 * (1 - e) / e, "gonthier": lambda e: (1 - e ** 2) / e}
KV = {"contact.stiffness": 2e7, "contact.damping": 800.0}  # N/m, N s/m: an underdamped impact of ~1 ms


def bar(model: str, rtol: float = 1e-12, **keys) -> impactgen.Scene:
    """The bar under `model`, with the law's own `keys` (dotted)."""
    raw = {"name": "bar", "chain": {"links": 1, "length": L, "mass": M, "gravity": 0.0},
           "rod": {"E": E, "nu": NU, "yield_strength": 1.12e9, "tip_radius": R_TIP},
           "surface": {"E": E, "nu": NU, "yield_strength": 1.12e9, "height": "initial"},
           "contact": {"model": model, "friction": 0.0},
           "initial": {"q": [0.0], "u": [-V0 / L]}, "solver": {"rtol": rtol, "atol": 1e-14}}
    return impactgen.scene_from_dict(raw, overrides=keys)


def one_degree_of_freedom(force, m_eff: float, v0: float) -> tuple[float, float, float]:
    """e_N, delta_max and the contact time of a point mass m_eff meeting a surface at v0 under
    the force law force(delta, v), to the force's zero or delta = 0, whichever comes first."""
    def rhs(t, y):
        return [y[1], -force(y[0], y[1]) / m_eff]

    def leaves(t, y):
        return force(y[0], y[1]) if y[1] < 0 else 1.0
    leaves.terminal, leaves.direction = True, -1

    def surface(t, y):
        return y[0]
    surface.terminal, surface.direction = True, -1

    def turns(t, y):
        return y[1]
    turns.direction = -1

    t_scale = 1e-3
    sol = solve_ivp(rhs, (0, 100 * t_scale), [0.0, v0], method="DOP853", rtol=1e-13, atol=1e-20,
                    events=(leaves, surface, turns))
    ends = [(t[0], y[0]) for t, y in zip(sol.t_events[:2], sol.y_events[:2]) if len(t)]
    t_end, y_end = min(ends, key=lambda item: item[0])
    return -y_end[1] / v0, sol.y_events[2][0][0], t_end


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("law", HERTZ_DAMPED)
def test_damped_hertz_law_matches_its_one_degree_of_freedom_equation(law, engine):
    e = 0.2  # low enough that flores and gonthier let go while the tip still penetrates
    chi = CHI[law](e)
    e_N, delta_max, t_contact = one_degree_of_freedom(
        lambda d, v: K_HERTZ * max(d, 0.0) ** 1.5 * (1 + chi * v / V0), M / 3, V0)
    result = impactgen.simulate(bar(law, **{"contact.restitution": e}), engine=engine)
    assert result.success, result.message
    s = result.summary
    assert s["coefficients"]["e_N"] == pytest.approx(e_N, rel=1e-6)
    assert s["delta_max"] == pytest.approx(delta_max, rel=1e-6)
    assert s["t_contact"] == pytest.approx(t_contact, rel=1e-6)


@pytest.mark.parametrize("engine", ENGINES)
def test_flores_rebound_approaches_its_force_zero_but_never_pulls(engine):
    """At e = 0.2 Flores' factor 1 + chi v/v0 (chi = 6.4) would turn negative at v = -v0/chi:
    the force fades as the tip nears that speed, so the tip leaves at delta = 0 a little
    slower, and never with a pulling force."""
    result = impactgen.simulate(bar("flores", **{"contact.restitution": 0.2}), engine=engine)
    s = result.summary
    assert 0.95 / 6.4 < s["coefficients"]["e_N"] < 1 / 6.4
    assert s["delta_r"] <= 1e-15 * s["delta_max"]
    assert result.trajectory.outputs["F"].min() >= 0.0


@pytest.mark.parametrize("engine", ENGINES)
def test_hertz_alone_is_perfectly_elastic(engine):
    s = impactgen.simulate(bar("hertz"), engine=engine).summary
    for name in ("e_N", "e_P", "e_E"):
        assert s["coefficients"][name] == pytest.approx(1.0, abs=1e-8), name
    assert abs(s["delta_T"]) <= 1e-8 * s["T0"]
    assert abs(s["energy"]["residual"]) <= 1e-8 * s["T0"]


@pytest.mark.parametrize("engine", ENGINES)
def test_kelvin_voigt_jumps_at_contact_and_leaves_while_penetrating(engine):
    k, c = KV["contact.stiffness"], KV["contact.damping"]
    result = impactgen.simulate(bar("kelvin-voigt", **KV), engine=engine)
    assert result.success, result.message
    s = result.summary
    impact = result.impacts[0]
    F = result.trajectory.outputs["F"]
    t = result.trajectory.t
    at_start = F[t == impact.t_start]
    assert at_start.max() == pytest.approx(c * V0, rel=1e-9)  # the dashpot's force at once
    assert s["delta_r"] > 0  # k delta + c v reaches 0 before delta does
    e_N, delta_max, t_contact = one_degree_of_freedom(lambda d, v: k * d + c * v, M / 3, V0)
    assert s["coefficients"]["e_N"] == pytest.approx(e_N, rel=1e-6)
    assert s["t_contact"] == pytest.approx(t_contact, rel=1e-6)
    assert abs(s["energy"]["residual"]) <= 1e-8 * s["T0"]  # W_normal closes the kinetic energy
    assert -s["energy"]["W_normal"] == pytest.approx(s["delta_T"], rel=1e-8)  # delta_T = T0 - Tf


PAPER_LAWS = {**{law: {"contact.restitution": 0.5} for law in HERTZ_DAMPED}, "kelvin-voigt": KV,
              "thornton": {"contact.limiting_pressure": 1.5e9}}


@pytest.mark.parametrize("law", sorted(PAPER_LAWS))
def test_engines_agree_on_the_paper_scene_under_each_law(law):
    scene = crosscheck.with_tolerance(impactgen.load_scene(PAPER, overrides={
        "contact.model": law, **PAPER_LAWS[law]}), 1e-11)
    c, ref = impactgen.simulate(scene), impactgen.simulate(scene, engine="reference")
    assert c.success, c.message
    for quantity, value in crosscheck.compare(c, ref).items():
        assert value < 1e-7, quantity


def test_a_key_the_law_does_not_read_is_refused_by_name():
    with pytest.raises(SceneError, match="contact.stiffness.*'hunt-crossley' does not use"):
        bar("hunt-crossley", **{"contact.restitution": 0.5, "contact.stiffness": 1e7})
    with pytest.raises(SceneError, match="contact.restitution.*missing.*'flores'"):
        bar("flores")
    with pytest.raises(SceneError, match="contact.restitution"):
        bar("gonthier", **{"contact.restitution": 0.0})


@pytest.mark.parametrize("law", ["kelvin-voigt", "gonthier"])
def test_an_fmu_of_a_damped_law_validates_and_agrees_with_the_run(law, tmp_path):
    fmpy = pytest.importorskip("fmpy")
    from fmpy.validation import validate_fmu
    from impactgen.fmu import build_fmu
    scene = impactgen.load_scene(PAPER, overrides={"contact.model": law, **PAPER_LAWS[law]})
    path = build_fmu(scene, tmp_path / f"{law}.fmu")
    assert validate_fmu(str(path)) == []
    names = {v.name for v in fmpy.read_model_description(str(path)).modelVariables}
    assert set(PAPER_LAWS[law]) <= names  # the law's own keys are the FMU's parameters
    stop = 1e-3
    result = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=stop, relative_tolerance=1e-10,
                               output_interval=stop / 100, output=["u[1]", "u[2]", "W_normal", "delta_r"])
    run = impactgen.simulate(scene, t_end=stop)
    last = result[-1]
    for i in range(2):
        assert last[f"u[{i + 1}]"] == pytest.approx(run.u[i, -1], rel=1e-6)
    assert last["W_normal"] == pytest.approx(run.W_normal[-1], rel=1e-6)
    assert last["delta_r"] == pytest.approx(run.impacts[0].delta_r, rel=1e-6, abs=1e-15)


def thornton_restitution(ratio: float) -> float:
    """Thornton's closed form (J. Appl. Mech. 1997, Eq. 32) of e at v_i = ratio v_y."""
    r = 1 / ratio
    return math.sqrt(6 * math.sqrt(3) / 5) * math.sqrt(1 - r * r / 6) * (
        r / (r + 2 * math.sqrt(6 / 5 - r * r / 5))) ** 0.25


P_Y = 1.0e9  # Pa


@pytest.mark.parametrize("engine", ENGINES)
def test_thornton_restitution_follows_the_closed_form(engine):
    delta_y = (math.pi * P_Y / (2 * E_STAR)) ** 2 * R_TIP
    v_y = math.sqrt(4 / 5 * K_HERTZ * delta_y ** 2.5 / (M / 3))  # (1/2) m v_y^2 = (2/5) K delta_y^(5/2)
    for ratio in (2.0, 5.0, 20.0, 100.0):
        scene = bar("thornton", **{"contact.limiting_pressure": P_Y, "initial.u": [-ratio * v_y / L]})
        result = impactgen.simulate(scene, engine=engine)
        assert result.success, result.message
        s = result.summary
        assert s["coefficients"]["e_N"] == pytest.approx(thornton_restitution(ratio), rel=1e-6), ratio
        assert s["delta_r"] > 0
        assert abs(s["energy"]["residual"]) <= 1e-8 * s["T0"]


def test_a_point_back_before_it_left_the_surface_begins_a_new_impact_where_it_let_go():
    """Kelvin-Voigt lets go at depth delta_r; pulled back by gravity before delta reaches 0,
    the point meets the surface again at delta_r (no delta rising through 0 would say so)."""
    scene = bar("kelvin-voigt", rtol=1e-11, **{"contact.stiffness": 1e5, "contact.damping": 100.0,
                                                "chain.gravity": 100.0, "initial.u": [-1.0], "solver.t_end": 0.05,
                                                "solver.sustained_contact": False})
    c, ref = impactgen.simulate(scene, warn=False), impactgen.simulate(scene, engine="reference", warn=False)
    assert c.success, c.message
    assert len(c.impacts) == len(ref.impacts) == 2
    assert [p.ended_by for p in c.phases if p.phase == "free"] == ["separation"]
    assert c.impacts[0].delta_r > 0
    assert c.impacts[1].t_start == pytest.approx(ref.impacts[1].t_start, rel=1e-7)
    for quantity, value in crosscheck.compare(c, ref).items():
        assert value < 1e-7, quantity


@pytest.mark.parametrize("law", ["kelvin-voigt", "thornton"])
def test_the_c_driver_runs_the_law_the_scene_generates(law, tmp_path, c_driver):
    from test_c_driver import FIELDS, build_and_run
    scene = impactgen.load_scene(PAPER, overrides={"contact.model": law, **PAPER_LAWS[law]})
    path = tmp_path / "scene.toml"
    path.write_text(scene.to_toml())
    printed = build_and_run(str(path), tmp_path / "model", c_driver)
    s = impactgen.simulate(scene).first_impact
    assert printed["status"] == "ok"
    for name in FIELDS:
        assert float(printed[name]) == pytest.approx(s[name], rel=1e-8), name
