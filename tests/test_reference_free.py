"""Free bodies and inclined surfaces in the reference engine (issue 46): a chain whose base
point is free (chain.base = "free": its coordinates x_0, y_0 after the angles in the state,
their rates u_x0, u_y0 after the angles' rates), the base as contact point 0, and gravity
(g sin a, -g cos a) in the frame of a surface inclined at a (surface.angle_deg).

Every check here is physics the reference engine's own derivation (reference/chain.py) must
reproduce: a free chain's centre of mass on its parabola with its angular momentum about it
constant, a rod on a slope sticking or sliding at g (sin a - mu cos a), Hertz's closed forms
for a rod striking at one end, and the energy budget closing.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import impactgen
from impactgen import reference
from impactgen.reference import ReferenceModel
from impactgen.reference.body import Body
from impactgen.validity import energy_warning

BUDGET_CLOSES = 1e-8  # |residual| over the budget's largest term, at the scenes' rtol 1e-10
SETTLED_DEPTH = 3.0  # a settling point stays within this many static Hertz penetrations
SLIDING = 1e-4  # a sliding rod's acceleration against g (sin a - mu cos a), relative
FLIGHT = 1e-8  # the centre of mass off its parabola, and the angular momentum's drift, relative
STEEL_ROD = {"chain.links": 1, "chain.length": 0.5, "rod.material": "steel-a36", "surface.material": "steel-a36",
             "chain.diameter": 0.01, "rod.tip_radius": 0.005}


def _free(overrides: dict, base: tuple[float, float], velocity: tuple[float, float] = (0.0, 0.0),
          slope_deg: float = 0.0) -> tuple[impactgen.Scene, ReferenceModel]:
    """The paper's scene changed by `overrides`, as a free chain whose base starts at `base`
    with `velocity`, on a surface inclined at `slope_deg`."""
    scene = impactgen.load_scene("paper", {**overrides, "chain.base": "free", "initial.base": list(base),
                                           "initial.base_velocity": list(velocity), "surface.angle_deg": slope_deg})
    return scene, ReferenceModel.from_scene(scene)


def _column(result, name: str) -> np.ndarray:
    return result.trajectory.y[:, result.trajectory.state_names.index(name)]


def _centres(model: ReferenceModel, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each link's centre and its velocity (links, 2, samples), written again from the geometry
    (the base, then each link's end), and the links' angles' rates (links, samples)."""
    n, L = model.n, model.chain.L
    q, u = y[:, :n].T, y[:, n + 2:2 * n + 2].T
    joint, velocity = y[:, n:n + 2].T.copy(), y[:, 2 * n + 2:2 * n + 4].T.copy()
    centres, speeds = [], []
    for i in range(n):
        e, e_dot = np.array([np.cos(q[i]), np.sin(q[i])]), np.array([-np.sin(q[i]), np.cos(q[i])]) * u[i]
        centres.append(joint + L[i] / 2 * e)
        speeds.append(velocity + L[i] / 2 * e_dot)
        joint, velocity = joint + L[i] * e, velocity + L[i] * e_dot
    return np.array(centres), np.array(speeds), u


def _assert_budget_closes(result) -> None:
    s, e = result.summary, result.summary["energy"]
    terms = (s["T0"], s["Tf"], e["W_normal"], e["W_friction"], e["W_gravity"])
    assert not energy_warning(result.scene, *terms, e["residual"]), e
    scene = result.scene  # where every term is tiny, the works' own absolute tolerance: solver.atol of m g L
    works_atol = scene.solver.atol * sum(scene.chain.mass) * max(scene.chain.gravity, 1.0) * sum(scene.chain.length)
    assert abs(e["residual"]) <= BUDGET_CLOSES * max(map(abs, terms)) + works_atol, e


# ----------------------------------------------------------------------------- free flight

@pytest.mark.parametrize("links", [1, 3])
def test_the_free_mass_matrix_gives_the_kinetic_energy_of_the_links(links):
    """1/2 w^T M(q) w, w = (u_1..u_n, u_x0, u_y0), is the links' kinetic energy summed from
    their centres' velocities (ChainModel.energies): M's coupling of the base to the angles."""
    rng = np.random.default_rng(46)
    scene, model = _free({"chain.links": links, "chain.length": rng.uniform(0.2, 1.0, links).tolist(),
                          "chain.mass": rng.uniform(0.1, 2.0, links).tolist(), "initial.q_deg": [10.0] * links,
                          "initial.u": [0.0] * links, "surface.height": -10.0}, base=(0.0, 1.0))
    q, w = rng.uniform(-3, 3, links + 2), rng.uniform(-2, 2, links + 2)
    T, _ = model.chain.energies(q[:, None], w[:, None])
    assert 0.5 * w @ model.chain.mass_matrix(q) @ w == pytest.approx(T.sum(), rel=1e-13)


@pytest.mark.parametrize("links, slope_deg", [(1, 0.0), (2, 0.0), (4, 0.0), (2, 25.0)])
def test_a_free_chain_flies_on_its_parabola_with_constant_angular_momentum(links, slope_deg):
    """In flight, over a level or an inclined surface (gravity then has a component along it)."""
    L, m = [0.5, 0.3, 0.4, 0.2][:links], [1.0, 0.4, 0.7, 0.2][:links]
    scene, model = _free({"chain.links": links, "chain.length": L, "chain.mass": m,
                          "initial.q_deg": [-30.0, 10.0, 75.0, -120.0][:links],
                          "initial.u": [3.0, -5.0, 2.0, 7.0][:links], "surface.height": -100.0,
                          "solver.t_end": 0.3, "solver.sustained_contact": False},
                         base=(0.2, 1.0), velocity=(1.0, 2.0), slope_deg=slope_deg)
    result = reference.simulate(scene)
    assert result.status == "ok" and not result.impacts, result.message
    t, y = result.trajectory.t, result.trajectory.y
    centres, speeds, u = _centres(model, y)
    mass = np.array(m)
    com = (mass[:, None, None] * centres).sum(0) / mass.sum()
    com_velocity = (mass[:, None, None] * speeds).sum(0) / mass.sum()
    g, a = scene.chain.gravity, math.radians(slope_deg)
    gravity = np.array([[g * math.sin(a)], [-g * math.cos(a)]])
    parabola = com[:, :1] + com_velocity[:, :1] * t + gravity / 2 * t ** 2
    scale = np.abs(com).max() + np.abs(com_velocity).max() * t[-1]
    assert np.abs(com - parabola).max() <= FLIGHT * scale
    # about the centre of mass: each link's centre's moment and its own spin
    r, v = centres - com, speeds - com_velocity
    H = (mass[:, None] * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]) + model.chain.inertia[:, None] * u).sum(0)
    assert np.abs(H - H[0]).max() <= FLIGHT * np.abs(model.chain.inertia[:, None] * u).sum(0).max() + 1e-15
    # gravity's work is the only one, and the energy closes
    _assert_budget_closes(result)


def test_a_pinned_chain_on_an_inclined_surface_closes_its_energy():
    """Gravity along the surface as well: the budget (gravity's work from V with both of its
    components) closes over impacts of the tip."""
    scene = impactgen.load_scene("paper", {"solver.t_end": 0.02, "solver.sustained_contact": False,
                                           "surface.angle_deg": 20.0})
    result = reference.simulate(scene)
    assert result.status == "ok" and result.impacts, result.message
    _assert_budget_closes(result)


# ----------------------------------------------------------------------------- a rod on a slope

def _rod_on_slope(slope_deg: float, mu: float, t_end: float):
    """A steel rod lying along a slope at rest under exact Coulomb friction, both ends pressed
    in to their static Hertz depth under m g cos(a) / 2 (and approaching at 1 um/s, so that
    they start in contact). Laid at delta = 0 instead, the undamped contacts bounce between 0
    and twice that depth, losing their grip at every rebound, and the rod creeps down even a
    gentle slope (1.9 um in 10 ms at atan(mu) - 5 degrees): a test of the friction law wants
    it settled."""
    scene = impactgen.load_scene("paper", {**STEEL_ROD, "initial.q_deg": [0.0], "initial.u": [0.0],
                                           "surface.height": 0.0, "contact.friction": mu,
                                           "contact.friction_mode": "coulomb", "solver.t_end": t_end,
                                           "solver.sustained_contact": False})
    a = math.radians(slope_deg)
    contact = ReferenceModel.from_scene(scene).contact
    load = scene.chain.mass[0] * scene.chain.gravity * math.cos(a) / 2
    depth = (3 * load / (4 * contact.E_star * math.sqrt(contact.R))) ** (2 / 3)
    model = ReferenceModel.from_scene(scene, Body(True, a, (0.0, -depth), (0.0, -1e-6)))
    return scene, reference.simulate(scene, model=model)


def test_a_free_rod_laid_flat_at_rest_settles_on_both_ends():
    """A resting start: the rod laid on a level surface at delta = 0, released. Both ends come
    into contact at t = 0 and stay within SETTLED_DEPTH static Hertz depths (each carries
    m g / 2)."""
    scene, model = _free({**STEEL_ROD, "initial.q_deg": [0.0], "initial.u": [0.0], "solver.t_end": 0.003,
                          "solver.sustained_contact": False}, base=(0.0, 0.0))
    result = reference.simulate(scene)
    assert result.status == "ok", result.message
    assert [(i.point, i.t_start) for i in result.impacts] == [("tip", 0.0), ("base", 0.0)]
    contact = model.tip.contact
    load = scene.chain.mass[0] * scene.chain.gravity / 2
    static = (3 * load / (4 * contact.E_star * math.sqrt(contact.R))) ** (2 / 3)
    out = result.trajectory.outputs
    assert max(out["delta"].max(), out["delta_J0"].max()) < SETTLED_DEPTH * static
    _assert_budget_closes(result)


def _laid_at_delta_0(slope_deg: float, mu: float, t_end: float):
    """The rod of `_rod_on_slope` laid on the slope at delta = 0 and released, its resting ends
    held in sustained contact once their vibration's reload peaks (solver.sustained_contact);
    and the time from which both are held."""
    scene = impactgen.load_scene("paper", {**STEEL_ROD, "initial.q_deg": [0.0], "initial.u": [0.0],
                                           "surface.height": 0.0, "contact.friction": mu,
                                           "contact.friction_mode": "coulomb", "solver.t_end": t_end,
                                           "chain.base": "free", "initial.base": [0.0, 0.0],
                                           "surface.angle_deg": slope_deg})
    result = reference.simulate(scene)
    assert result.status == "ok", result.message
    for impact in result.impacts:  # each end: one impact, vibrating, then held to the end of the run
        assert impact.t_end is None and impact.switches[-1][2] == "sustained"
        assert [s[1:] for s in impact.switches[1:3]] == [("elastoplastic", "restitution"), ("restitution", "reloading")]
    return scene, result, max(impact.switches[-1][0] for impact in result.impacts)


def test_a_free_rod_laid_flat_at_delta_0_comes_to_rest_in_sustained_contact():
    """The resting start above, run with sustained contact: each end compresses (into yield,
    for this steel: beyond the (5/2)^(2/3) d_s of a Hertzian contact of static depth d_s),
    unloads to its dent's bottom, reloads back to that maximum (undamped), and is held there
    (no normal speed). The rod then rests at that depth, each end pressed by m g / 2, and the
    energy left in the dents is W_normal's loss: W_normal = -m g delta, and the budget closes."""
    scene, result, held_from = _laid_at_delta_0(0.0, 0.3, 0.01)
    assert sorted(i.point for i in result.impacts) == ["base", "tip"] and held_from < 2e-3
    contact = ReferenceModel.from_scene(scene).tip.contact
    m, g = scene.chain.mass[0], scene.chain.gravity
    static = (3 * (m * g / 2) / (4 * contact.E_star * math.sqrt(contact.R))) ** (2 / 3)
    t, out = result.trajectory.t, result.trajectory.outputs
    held = t > held_from
    first_maximum = {i.point: i.switches[1][0] for i in result.impacts}  # elastoplastic -> restitution
    for point, delta, F in (("tip", out["delta"], out["F"]), ("base", out["delta_J0"], out["F_J0"])):
        assert np.ptp(delta[held]) < 1e-6 * static  # where it was held
        assert delta[-1] > 2.5 ** (2 / 3) * static
        assert delta[-1] == pytest.approx(np.interp(first_maximum[point], t, delta), rel=1e-6)
        np.testing.assert_allclose(F[held], m * g / 2, rtol=1e-9)
    speeds = [_column(result, name)[held] for name in ("u1", "u_x0", "u_y0")]
    assert np.abs(speeds).max() < 1e-9
    _assert_budget_closes(result)
    assert -result.summary["energy"]["W_normal"] == pytest.approx(m * g * out["delta"][-1], rel=1e-6)


def test_a_rod_laid_at_delta_0_on_a_gentle_slope_rests_stuck():
    """Laid at delta = 0 on a slope gentler than atan(mu), the rod slips a little while its ends
    first press in (with F = 0 at the start they cannot stick), and from the hold on both rest
    stuck: it does not move."""
    mu = 0.3
    scene, result, held_from = _laid_at_delta_0(math.degrees(math.atan(mu)) - 5.0, mu, 0.01)
    assert result.phases[-1].slip_state == "base: stick, tip: stick" and result.phases[-1].ended_by == "t_end"
    held = result.trajectory.t > held_from
    x = _column(result, "x_0")[held]
    assert np.abs(x - x[0]).max() < 1e-12 * scene.chain.length[0]
    assert np.abs(_column(result, "u_x0")[held]).max() < 1e-9
    _assert_budget_closes(result)


def test_a_rod_laid_at_delta_0_on_a_steep_slope_slides_at_g_sin_minus_mu_cos():
    mu, slope = 0.3, math.degrees(math.atan(0.3)) + 10.0
    scene, result, held_from = _laid_at_delta_0(slope, mu, 0.01)
    held = result.trajectory.t > held_from
    t, v = result.trajectory.t[held], _column(result, "u_x0")[held]
    a = math.radians(slope)
    expected = scene.chain.gravity * (math.sin(a) - mu * math.cos(a))
    assert len(t) > 2 and np.polyfit(t, v, 1)[0] == pytest.approx(expected, rel=SLIDING)
    _assert_budget_closes(result)


def test_a_rod_on_a_slope_gentler_than_the_friction_angle_stays_stuck():
    mu = 0.3
    scene, result = _rod_on_slope(math.degrees(math.atan(mu)) - 5.0, mu, 0.01)
    assert result.status == "ok", result.message
    assert all(not impact.stick_slip for impact in result.impacts)  # both ends stuck throughout
    x = _column(result, "x_0")
    assert np.abs(x - x[0]).max() < 1e-12 * scene.chain.length[0]  # it does not slide down
    _assert_budget_closes(result)


def test_a_rod_on_a_slope_steeper_than_the_friction_angle_slides_at_g_sin_minus_mu_cos():
    mu, slope = 0.3, math.degrees(math.atan(0.3)) + 10.0
    scene, result = _rod_on_slope(slope, mu, 0.01)
    assert result.status == "ok", result.message
    t, v = result.trajectory.t, _column(result, "u_x0")  # the rod slides without turning
    a = math.radians(slope)
    expected = scene.chain.gravity * (math.sin(a) - mu * math.cos(a))
    measured = np.polyfit(t, v, 1)[0]
    assert measured == pytest.approx(expected, rel=SLIDING)
    _assert_budget_closes(result)


# ----------------------------------------------------------------------------- Hertz at one end

@pytest.mark.parametrize("theta_deg", [30.0, 60.0])
def test_a_free_rod_striking_at_one_end_follows_hertz_with_its_effective_mass(theta_deg):
    """Frictionless, Hertzian (contact.model = "hertz"), without gravity (its work over the
    contact, m_eff g delta_max against m_eff v^2 / 2, would raise delta_max by 3e-4): the
    rod's lower end (the tip) strikes at v; delta_max and the contact time are Hertz's for
    m_eff = m / (1 + 3 cos^2 theta) but for the rod's turn during the contact (4e-4 rad at
    30 degrees), which changes m_eff by what `drift` bounds (3e-4 of delta_max at 30 degrees,
    against the 8e-6 it differs by)."""
    v, theta = 1.0, math.radians(theta_deg)
    scene, model = _free({**STEEL_ROD, "initial.q_deg": [-theta_deg], "initial.u": [0.0],
                          "surface.height": "initial", "contact.model": "hertz", "contact.friction": 0.0,
                          "chain.gravity": 0.0},
                         base=(0.0, 0.0), velocity=(0.0, -v))
    result = reference.simulate(scene)
    assert result.status == "ok" and [i.point for i in result.impacts] == ["tip"], result.message
    impact = result.impacts[0]
    m = scene.chain.mass[0]
    contact = model.tip.contact

    def hertz(angle: float) -> tuple[float, float]:
        delta_max = _hertz_delta_max(m / (1 + 3 * math.cos(angle) ** 2), v, contact)
        return delta_max, 2.9432 * delta_max / v  # the contact time, Hertz's 2.94 delta_max / v

    delta_max, t_contact = hertz(theta)
    q_end = result.trajectory.y[impact.i_end, 0]
    turn = abs(abs(q_end) - theta)  # the rod's turn over the contact
    drift = abs(hertz(theta + turn)[0] / delta_max - 1) + abs(hertz(theta - turn)[0] / delta_max - 1)
    assert impact.delta_max == pytest.approx(delta_max, rel=drift + 1e-6)
    assert impact.t_end - impact.t_start == pytest.approx(t_contact, rel=2 * drift + 1e-4)
    _assert_budget_closes(result)


def _hertz_delta_max(m_eff: float, v: float, contact) -> float:
    return (15 * m_eff * v ** 2 / (16 * contact.E_star * math.sqrt(contact.R))) ** 0.4


@pytest.mark.parametrize("friction_mode", ["regularized", "coulomb", "frozen"])
def test_a_free_rod_dropped_flat_strikes_with_both_ends_at_once(friction_mode):
    """Both ends at once (simultaneous impacts of the base and the tip): each carries half the
    rod, which falls without turning, so each end's delta_max is Hertz's for m / 2, whatever
    the friction (the ends do not slide: the rod only falls)."""
    v = 0.5
    scene, model = _free({**STEEL_ROD, "initial.q_deg": [0.0], "initial.u": [0.0], "contact.model": "hertz",
                          "contact.friction": 0.3, "contact.friction_mode": friction_mode, "chain.gravity": 0.0},
                         base=(0.0, 0.0), velocity=(0.0, -v))
    result = reference.simulate(scene)
    assert result.status == "ok", result.message
    assert sorted(i.point for i in result.impacts) == ["base", "tip"]
    assert result.impacts[0].t_start == result.impacts[1].t_start == 0.0
    expected = _hertz_delta_max(scene.chain.mass[0] / 2, v, model.tip.contact)
    for impact in result.impacts:
        assert impact.delta_max == pytest.approx(expected, rel=1e-6)
    assert np.abs(result.trajectory.y[:, 0]).max() < 1e-12  # it does not turn
    assert not result.warnings, result.warnings
    _assert_budget_closes(result)


def test_the_base_is_a_contact_point_named_base():
    """The rod with its base end lower: the base strikes, named "base", with its own outputs."""
    scene, _ = _free({**STEEL_ROD, "initial.q_deg": [30.0], "initial.u": [0.0], "contact.model": "hertz",
                      "contact.friction": 0.0}, base=(0.0, 0.0), velocity=(0.0, -1.0))
    result = reference.simulate(scene)
    assert result.status == "ok" and [i.point for i in result.impacts] == ["base"], result.message
    out = result.trajectory.outputs
    assert out["delta_J0"].max() == pytest.approx(result.impacts[0].delta_max, rel=1e-12)
    assert set(result.point_works) == {"base", "tip"}
    assert result.point_works["base"]["W_normal"] == pytest.approx(result.summary["energy"]["W_normal"], rel=1e-12)
    assert not result.warnings, result.warnings
    _assert_budget_closes(result)


def test_a_pinned_level_chain_is_the_model_it_was():
    """The pinned chain on a level surface: the body the scene gives by default, the state and
    the mass matrix of before (the existing tests hold its runs)."""
    scene = impactgen.load_scene("paper")
    model = ReferenceModel.from_scene(scene)
    assert not model.chain.free and model.chain.gravity_vector == (0.0, -scene.chain.gravity)
    assert model.state_names[:4] == ("q1", "q2", "u1", "u2") and model.base is None
    free = ReferenceModel.from_scene(impactgen.load_scene("paper", {"chain.base": "free", "initial.base": [0.0, 1.0]}))
    assert free.state_names[:8] == ("q1", "q2", "x_0", "y_0", "u1", "u2", "u_x0", "u_y0")
    assert [p.name for p in free.points] == ["base", "joint 1", "tip"]
