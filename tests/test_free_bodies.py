"""Free bodies and inclined surfaces on the C engine: a free chain's flight (its centre of mass
on its parabola, its angular momentum about it constant), a free rod's Hertzian impact against
the closed forms with the rod's effective mass, a rod on a slope under exact Coulomb friction,
and the shipped examples' energy budgets."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

import impactgen
from impactgen.materials import MATERIALS

STEEL = MATERIALS["steel-paper"]


def free_chain(links: int, **changes) -> dict:
    """A free steel chain of `links` links, 0.2 m each, thrown high above a level plate."""
    raw = {
        "name": f"free-{links}",
        "chain": {"links": links, "length": 0.2, "diameter": 0.01, "base": "free"},
        "rod": {"material": "steel-paper", "tip_radius": 0.005},
        "surface": {"material": "steel-paper"},
        "contact": {"friction": 0.2},
        "initial": {"q_deg": [10.0 + 25.0 * i for i in range(links)], "u": [3.0 - 2.5 * i for i in range(links)],
                    "base": [0.0, 50.0], "base_velocity": [1.5, 2.0]},
        "solver": {"t_end": 0.5},
    }
    for section, values in changes.items():
        raw[section] = {**raw[section], **values}
    return raw


def centres(result, scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each link's centre (x, y) and velocity (vx, vy) at every sample: arrays (links, samples)."""
    n = scene.n
    L = np.asarray(scene.chain.length)[:, None]
    q, u = result.q, result.u
    x0, y0, vx0, vy0 = result.base
    joint_x = x0 + np.vstack([np.zeros_like(x0), np.cumsum(L * np.cos(q), axis=0)[:-1]])
    joint_y = y0 + np.vstack([np.zeros_like(y0), np.cumsum(L * np.sin(q), axis=0)[:-1]])
    joint_vx = vx0 + np.vstack([np.zeros_like(x0), np.cumsum(-L * np.sin(q) * u, axis=0)[:-1]])
    joint_vy = vy0 + np.vstack([np.zeros_like(x0), np.cumsum(L * np.cos(q) * u, axis=0)[:-1]])
    assert joint_x.shape == (n, len(result.t))
    return (joint_x + L / 2 * np.cos(q), joint_y + L / 2 * np.sin(q),
            joint_vx - L / 2 * np.sin(q) * u, joint_vy + L / 2 * np.cos(q) * u)


@pytest.mark.parametrize("links, angle", [(1, 0.0), (2, 0.0), (4, 0.0), (2, 25.0)])
def test_free_flight_follows_the_parabola_and_keeps_its_angular_momentum(links, angle):
    """No contact: the centre of mass moves under gravity alone, g (sin a, -cos a) in the
    surface's frame, and the angular momentum about it stays what it was."""
    scene = impactgen.scene_from_dict(free_chain(links, surface={"angle_deg": angle}))
    result = impactgen.simulate(scene, warn=False)
    assert result.success and not result.impacts
    m = np.asarray(scene.chain.mass)[:, None]
    L = np.asarray(scene.chain.length)[:, None]
    x, y, vx, vy = centres(result, scene)
    mass = m.sum()
    xg, yg = (m * x).sum(axis=0) / mass, (m * y).sum(axis=0) / mass
    vxg, vyg = (m * vx).sum(axis=0) / mass, (m * vy).sum(axis=0) / mass
    t = result.t
    a = math.radians(angle)
    gx, gy = 9.81 * math.sin(a), -9.81 * math.cos(a)
    assert xg == pytest.approx(xg[0] + vxg[0] * t + gx * t ** 2 / 2, abs=1e-8)
    assert yg == pytest.approx(yg[0] + vyg[0] * t + gy * t ** 2 / 2, abs=1e-8)
    spin = (m * ((x - xg) * (vy - vyg) - (y - yg) * (vx - vxg)) + m * L ** 2 / 12 * result.u).sum(axis=0)
    assert np.ptp(spin) < 1e-8 * max(abs(spin[0]), 1e-3)


def hertz_time_factor() -> float:
    """t_c v / delta_max of a Hertzian impact: 2 int_0^1 dx / sqrt(1 - x^(5/2))."""
    return 2 * quad(lambda x: 1 / math.sqrt(1 - x ** 2.5), 0, 1)[0]


@pytest.mark.parametrize("theta", [30.0, 60.0])
def test_a_free_rod_striking_at_one_end_is_hertzian_with_its_effective_mass(theta):
    """A free rod at theta to a level plate, its lower end (the base point) striking it at 1 m/s,
    frictionless, no gravity, yield raised: the contact stays elastic, and delta_max and the
    contact time are Hertz's for m_eff = m / (1 + 3 cos^2 theta), within what the rod's turning
    during the contact explains: it turns by dtheta (0.022 degrees at 30, 0.031 at 60), which
    moves m_eff by |d ln m_eff / dtheta| dtheta (3.1e-4 and 7.9e-4); delta_max is off by
    8e-6 and 2e-5 of itself, the contact time by 7e-5 and 1.9e-4."""
    raw = free_chain(1, chain={"length": 0.5, "gravity": 0.0}, contact={"friction": 0.0},
                     rod={"yield_strength": 100e9}, surface={"yield_strength": 100e9},
                     initial={"q_deg": [theta], "u": [0.0], "base": [0.0, 1e-4], "base_velocity": [0.0, -1.0]})
    del raw["solver"]  # to the first separation
    scene = impactgen.scene_from_dict(raw)
    result = impactgen.simulate(scene, warn=False)
    impact = result.impacts[0]
    assert impact.point == "base" and impact.delta_r == 0.0
    m = scene.chain.mass[0]
    th = math.radians(theta)
    m_eff = m / (1 + 3 * math.cos(th) ** 2)
    E_star = 1 / (2 * (1 - STEEL.nu ** 2) / STEEL.E)
    v = 1.0
    delta_max = (15 * m_eff * v ** 2 / (16 * E_star * math.sqrt(scene.base_radius))) ** 0.4
    turned = abs(result.q[0][impact.i_end] - result.q[0][impact.i_start])
    explained = 6 * math.cos(th) * math.sin(th) / (1 + 3 * math.cos(th) ** 2) * turned  # m_eff's relative change
    assert 0 < turned < math.radians(0.1)
    assert impact.delta_max == pytest.approx(delta_max, rel=0.4 * explained)  # delta_max ~ m_eff^(2/5)
    assert impact.duration == pytest.approx(hertz_time_factor() * delta_max / v, rel=explained)


def test_a_free_rod_laid_flat_at_delta_0_settles_on_both_ends():
    """A resting start on a level plate: the rod laid flat, both ends touching at delta = 0,
    released. Both ends are pulled in, compress to the undamped peak (5/2)^(2/3) d_s of their
    static depth d_s under m g / 2 (gravity's work m g delta there equals the Hertz energy
    (2/5) P delta), unload to the surface and reload; at the reload's peak (no normal speed)
    each is held in sustained contact instead of vibrating to the end of the run. The rod
    then rests: no speed, its ends at that depth, each pressed by m g / 2, and the vibration's
    energy, the elastic energy left in the dents, is W_normal's loss: the budget closes."""
    raw = free_chain(1, chain={"length": 0.5},
                     initial={"q_deg": [0.0], "u": [0.0], "base": [0.0, 0.0], "base_velocity": [0.0, 0.0]},
                     solver={"t_end": 0.05})
    scene = impactgen.scene_from_dict(raw)
    result = impactgen.simulate(scene, warn=False)
    assert result.success and {impact.point for impact in result.impacts} == {"base", "tip"}
    for impact in result.impacts:  # one impact per end, held to the end of the run
        assert impact.t_end is None and impact.switches[-1][2] == "sustained"
        assert [s[2] for s in impact.switches] == ["restitution", "reloading", "sustained"]
    held = result.t > max(impact.switches[-1][0] for impact in result.impacts)
    assert result.t[-1] - result.t[held][0] > 0.04  # held from the first 2 ms on
    m, g = scene.chain.mass[0], scene.chain.gravity
    E_star = 1 / (2 * (1 - STEEL.nu ** 2) / STEEL.E)
    static = (3 * (m * g / 2) / (4 * E_star * math.sqrt(scene.base_radius))) ** (2 / 3)
    for delta, F in ((result.delta, result.F), (result.outputs["delta_J0"], result.outputs["F_J0"])):
        assert np.ptp(delta[held]) < 1e-6 * static  # the height stays where it was held
        assert delta[-1] == pytest.approx(2.5 ** (2 / 3) * static, rel=1e-3)
        np.testing.assert_allclose(F[held], m * g / 2, rtol=1e-9)
    assert np.max(np.abs(result.u[:, held])) < 1e-9 and np.max(np.abs(np.asarray(result.base)[2:, held])) < 1e-9
    energy = result.summary["energy"]
    assert energy["residual"] == pytest.approx(0.0, abs=1e-9 * energy["W_gravity"])
    assert -energy["W_normal"] == pytest.approx(m * g * result.delta[-1], rel=1e-6)  # the dents keep it all


def rod_on_slope(angle: float) -> dict:
    """A steel rod laid along a slope (both ends on it, at rest), exact Coulomb friction mu = 0.3."""
    return free_chain(1, chain={"length": 0.5}, surface={"angle_deg": angle, "height": "initial"},
                      contact={"friction": 0.3, "friction_mode": "coulomb"},
                      initial={"q_deg": [0.0], "u": [0.0], "base": [0.0, 0.0], "base_velocity": [0.0, 0.0]},
                      solver={"t_end": 0.2})


def test_a_rod_on_a_slope_steeper_than_atan_mu_slides_at_g_sin_less_mu_cos():
    angle, mu = 30.0, 0.3
    # sampled: once its ends rest, sliding, the integrator steps over the rest of the run at once
    result = impactgen.simulate(impactgen.scene_from_dict(rod_on_slope(angle)), warn=False,
                                t_eval=np.linspace(0.0, 0.2, 201))
    t, vx = result.t, result.base[2]
    later = t > t[-1] / 2
    a = math.radians(angle)
    assert np.polyfit(t[later], vx[later], 1)[0] == pytest.approx(9.81 * (math.sin(a) - mu * math.cos(a)), rel=1e-3)


def test_a_rod_on_a_slope_gentler_than_atan_mu_stays_stuck():
    """At 10 degrees (atan 0.3 = 16.7) the rod stays where it was laid, but for the micro-slips
    while the undamped normal vibration of its release unloads its ends: a thousandth of the
    34 mm it would slide without friction."""
    angle = 10.0
    result = impactgen.simulate(impactgen.scene_from_dict(rod_on_slope(angle)), warn=False)
    t, x0 = result.t, result.base[0]
    frictionless = 9.81 * math.sin(math.radians(angle)) * t[-1] ** 2 / 2
    assert abs(x0[-1]) < 2e-3 * frictionless
    assert result.summary["energy"]["residual"] == pytest.approx(0.0, abs=1e-9)
    # laid at delta = 0, its ends vibrate on the slope only until their reloads peak: from
    # then on (1.3 ms) both rest, stuck, held in sustained contact, and the rod does not move
    rest = result.phases[-1]
    assert (rest.phase, rest.slip_state, rest.ended_by) == ("sustained", "stick", "t_end") and rest.t0 < 2e-3
    assert [impact.switches[-1][2] for impact in result.impacts] == ["sustained", "sustained"]
    held = t > rest.t0
    assert np.ptp(x0[held]) < 1e-12 and np.max(np.abs(result.base[2][held])) < 1e-9


@pytest.mark.parametrize("name", ["rod-drop", "rocking-rod", "chain-on-slope"])
def test_the_free_examples_close_their_energy_budget(name):
    """Each example's whole run: the works (contact, friction, gravity along the incline) make
    the change of kinetic energy (the base point's too), as closely as the run's own check asks
    (no ValidityWarning), and to 1e-5 of its largest term (at rtol 1e-8 and 1e-10)."""
    result = impactgen.simulate(impactgen.load_scene(name), warn=False)
    assert result.success and len(result.impacts) >= 3 and not result.warnings
    energy = result.summary["energy"]
    largest = max(abs(energy[k]) for k in ("W_normal", "W_friction", "W_gravity"))
    assert abs(energy["residual"]) < 1e-5 * largest
    points = {impact.point for impact in result.impacts}
    assert {"base", "tip"} <= points  # both ends strike


def test_the_rocking_rod_strikes_on_its_ends_in_turn_until_it_rests():
    """The rocking-rod example (dropped nearly flat, Flores's damped law, e = 0.7): its ends
    strike in turn, the flights shorten until the impacts chatter, and the rod rests on the plate
    in sustained contact at both ends, its kinetic energy gone (what it had from the fall, 0.015
    J, down to rounding)."""
    result = impactgen.simulate(impactgen.load_scene("rocking-rod"), warn=False)
    points = [impact.point for impact in result.impacts]
    assert points[:3] == ["base", "tip", "base"]
    counts = result.summary["point_impacts"]
    assert counts["base"] >= 3 and counts["tip"] >= 3
    assert result.summary["t_sustained"] is not None and result.summary["t_sustained"] < 0.5
    assert result.phases[-1].phase == "sustained" and result.impacts[-1].t_end is None
    assert result.summary["Tf"] < 1e-12 * result.impacts[0].T_before
    assert np.abs(result.u[:, -1]).max() < 1e-9 and np.abs(result.base[2:, -1]).max() < 1e-9


def test_a_pinned_pendulum_over_an_inclined_surface_hangs_along_gravity():
    """A pinned link over a surface inclined by 20 degrees hangs at rest along gravity, at
    -90 + 20 degrees in the surface's frame; hung normal to the surface it swings towards it,
    its energy closing."""
    overrides = {"surface.angle_deg": 20.0, "surface.height": -5.0, "chain.links": 1, "initial.u": [0.0],
                 "solver.t_end": 0.2}
    along = impactgen.load_scene("paper", overrides={**overrides, "initial.q_deg": [-70.0]})
    normal = impactgen.load_scene("paper", overrides={**overrides, "initial.q_deg": [-90.0]})
    resting, swinging = (impactgen.simulate(scene, warn=False) for scene in (along, normal))
    assert np.abs(resting.u).max() < 1e-9
    assert swinging.u[0, -1] > 0.1 and swinging.q[0, -1] > math.radians(-90.0)  # towards -70 degrees
    energy = swinging.summary["energy"]
    assert abs(energy["residual"]) < 1e-6 * abs(energy["W_gravity"])


def test_the_rigid_laws_give_a_free_rods_compliant_speeds():
    """The rigid-body limit: a free steel rod's tip striking a plate (frictionless, yield
    raised: elastic), its compliant post-impact speeds (the rod's spin and its base point's
    velocity) against Newton's and the energetic law given the compliant run's own coefficients,
    within what the rod's turning during the contact (4e-4 rad) explains: they differ by 6e-4 m/s
    of 5.7."""
    from impactgen.compare import compare_rows
    raw = free_chain(1, chain={"length": 0.5, "gravity": 0.0}, contact={"friction": 0.0},
                     rod={"yield_strength": 100e9}, surface={"yield_strength": 100e9},
                     initial={"q_deg": [-40.0], "u": [0.5], "base": [0.0, 0.5], "base_velocity": [0.3, -1.0]})
    del raw["solver"]
    result = impactgen.simulate(impactgen.scene_from_dict(raw), warn=False)
    assert result.impacts[0].point == "tip"
    rows = {row["law"]: row for row in compare_rows(result)}
    compliant = np.array([rows["compliant"][f"u_after[{i}]"] for i in (1, 2, 3)])
    impact = result.impacts[0]
    turned = abs(result.q[0][impact.i_end] - result.q[0][impact.i_start])  # the rigid laws hold the rod still
    for law in ("newton", "energetic"):
        rigid = np.array([rows[law][f"u_after[{i}]"] for i in (1, 2, 3)])
        assert np.abs(rigid - compliant).max() < 2 * turned * np.abs(compliant).max(), law
    # the energetic law keeps the energy (e_E = 1); the rod's turning during the contact puts the
    # compliant e_N just above 1 (1.0003), with which Newton's law makes a little (2e-5 J)
    assert not rows["energetic"]["gains_energy"] and rows["newton"]["e"] == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("name, t_end, rel", [("rod-drop", 0.25, 1e-7), ("chain-on-slope", 0.25, 1e-5)])
def test_a_free_chains_analytic_jacobian_runs_as_the_difference_quotients_do(name, t_end, rel):
    """BDF on a free chain with the generated Jacobian (over the angles and the base point's
    x_0, y_0, every point's contact forces by the chain rule) and with CVODE's difference
    quotients: the same impacts at the same points, the same first impact, to the tolerance
    the runs were made with (rod-drop: level, both ends striking; chain-on-slope: an inclined
    surface, three links, contact at the joints)."""
    from impactgen.engines import model_spec
    runs = {}
    for jacobian in ("analytic", "difference"):
        scene = impactgen.load_scene(name, overrides={"solver.method": "bdf", "solver.jacobian": jacobian,
                                                      "solver.t_end": t_end})
        assert model_spec(scene).jacobian == (jacobian == "analytic")
        runs[jacobian] = impactgen.simulate(scene, warn=False)
    analytic, difference = runs["analytic"], runs["difference"]
    assert analytic.success and difference.success and len(analytic.impacts) >= 3
    assert [i.point for i in analytic.impacts] == [i.point for i in difference.impacts]
    assert {"base", "tip"} <= {i.point for i in analytic.impacts}
    for a, d in zip(analytic.impacts, difference.impacts):
        assert a.t_start == pytest.approx(d.t_start, rel=rel)
        assert a.delta_max == pytest.approx(d.delta_max, rel=rel)
    for key in ("t_impact", "t_contact", "delta_max", "delta_r", "P_max", "Tf"):
        assert analytic.summary[key] == pytest.approx(difference.summary[key], rel=rel), key
    assert analytic.y[:, -1] == pytest.approx(difference.y[:, -1], rel=100 * rel, abs=100 * rel)
