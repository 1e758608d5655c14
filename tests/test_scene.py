"""Scene files: valid ones load, and every bad one names its key (exit code 2 at the CLI)."""
from __future__ import annotations

import math
import re

import pytest

import impactgen
from impactgen.errors import SceneError
from impactgen.scene import SCHEMA, parse_override
from conftest import PAPER, built_both_ways

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib


def paper_dict() -> dict:
    return tomllib.loads(PAPER.read_text())


def test_paper_scene_loads_with_its_values(paper_scene):
    s = paper_scene
    assert s.name == "paper-double-pendulum" and s.n == 2
    assert s.chain.length == (1.0, 1.0) and s.chain.mass == (1.0, 1.0)
    assert s.q0 == pytest.approx((math.radians(-70), math.radians(-60)))
    assert s.u0 == (-0.1, -0.2)
    assert s.surface_height is None and s.solver.t_end is None
    assert s.contact.friction == 0.2 and s.solver.method == "auto"


def test_overrides_replace_values():
    s = impactgen.load_scene(PAPER, overrides={"initial.u": [-0.1, -0.3], "solver.method": "adams",
                                               "initial.q": [-1.0, -1.1]})
    assert s.u0 == (-0.1, -0.3) and s.solver.method == "adams" and s.q0 == (-1.0, -1.1)


def test_override_values_are_parsed_as_toml():
    assert parse_override("initial.u=[-0.1,-0.3]") == ("initial.u", [-0.1, -0.3])
    assert parse_override("solver.rtol=1e-8") == ("solver.rtol", 1e-8)
    assert parse_override("solver.method=adams") == ("solver.method", "adams")
    assert parse_override('name="x"') == ("name", "x")


def _mutate(path: str, value) -> dict:
    raw = paper_dict()
    section, _, key = path.rpartition(".")
    target = raw.setdefault(section, {}) if section else raw
    if value is KeyError:
        del target[key]
    else:
        target[key] = value
    return raw


@pytest.mark.parametrize("path, value, key, words", [
    ("chain.mas", 1.0, "chain.mas", "did you mean 'chain.mass'"),
    ("chain.mass", KeyError, "chain.mass", "missing"),
    ("chain.mass", "heavy", "chain.mass", "expected a number"),
    ("chain.mass", -1.0, "chain.mass", "> 0"),
    ("chain.mass", [1.0, 0.0], "chain.mass[2]", "> 0"),  # elements count from 1
    ("contact.friction", KeyError, "contact.friction", "missing required key"),
    ("chain.length", [1.0], "chain.length", "2 values"),
    ("chain.links", 2.5, "chain.links", "integer"),
    ("chain.links", 0, "chain.links", "between 1 and 60"),
    ("rod.nu", 0.5, "rod.nu", "(-1, 0.5)"),
    ("surface.E", 0.0, "surface.E", "> 0"),
    ("rod.tip_radius", float("nan"), "rod.tip_radius", "finite"),
    ("contact.friction", -0.1, "contact.friction", ">= 0"),
    ("contact.model", "rigid", "contact.model", "three-phase"),
    ("initial.u", [0.1], "initial.u", "2 values"),
    ("solver.rtol", 2.0, "solver.rtol", "(0, 1)"),
    ("surface.height", "floor", "surface.height", "initial"),
    ("name", "../../etc", "name", "not a valid name"),
])
def test_bad_values_name_their_key(path, value, key, words):
    with pytest.raises(SceneError) as err:
        impactgen.scene_from_dict(_mutate(path, value))
    assert err.value.key == key
    assert words in str(err.value)


def test_both_or_neither_initial_angle_is_an_error():
    raw = paper_dict()
    raw["initial"]["q"] = [-1.0, -1.0]
    with pytest.raises(SceneError, match="exactly one"):
        impactgen.scene_from_dict(raw)


def test_tip_inside_the_surface_is_an_error():
    raw = paper_dict()
    raw["surface"]["height"] = 0.0  # the tip starts at y = -1.81 m
    with pytest.raises(SceneError, match="inside the surface") as err:
        impactgen.scene_from_dict(raw)
    assert err.value.key == "surface.height"


def test_unreadable_and_invalid_files(tmp_path):
    with pytest.raises(SceneError, match="not found"):
        impactgen.load_scene(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n")
    with pytest.raises(SceneError, match="not valid TOML"):
        impactgen.load_scene(bad)


def test_unknown_override_key_is_an_error():
    with pytest.raises(SceneError, match="unknown key"):
        impactgen.load_scene(PAPER, overrides={"solver.rtoll": 1e-8})


def test_a_changed_scene_equals_the_scene_read_in_full():
    """scene_with (how a sweep builds its cases) checks only the changed values, and must
    give the very scene, or the very error, that reading the whole scene gives."""
    import random

    rng = random.Random(7)
    values = {
        "initial.u[2]": lambda: rng.uniform(-1, 1), "initial.q_deg[2]": lambda: rng.uniform(-90, 0),
        "initial.q[1]": lambda: rng.uniform(-1.6, -0.5), "initial.u": lambda: [rng.uniform(-1, 1)] * 2,
        "initial.q_deg": lambda: [rng.uniform(-80, -40), rng.uniform(-80, -40)],
        "chain.length[1]": lambda: rng.choice([rng.uniform(0.1, 2), -1.0]), "chain.mass[2]": lambda: 2.0,
        "chain.mass": lambda: rng.uniform(0.5, 2), "contact.friction": lambda: rng.choice([0.0, 0.3, -0.2]),
        "rod.yield_strength": lambda: rng.choice([1e9, 3e11]), "rod.nu": lambda: rng.choice([0.3, 0.6]),
        "surface.height": lambda: rng.choice(["initial", -1.8, 0.0]), "solver.rtol": lambda: rng.choice([1e-8, "x"]),
        "solver.t_end": lambda: rng.choice(["separation", 0.5]), "contact.friction_mode": lambda: rng.choice(
            ["coulomb", "bad"]), "chain.links": lambda: rng.choice([2, 3]),
        "solver.method": lambda: rng.choice(["adams", "bdf", "dopri5", "x"]),
        "solver.jacobian": lambda: rng.choice(["auto", "analytic", "difference", "x"]),
        "rod.tip_radius": lambda: rng.uniform(1e-4, 1e-2), "initial.u[3]": lambda: 0.1, "name": lambda: "x y",
        "rod.E": lambda: rng.choice([2e11, 5e8]), "surface.E": lambda: rng.choice([2e11, 5e8]),
        "surface.yield_strength": lambda: rng.choice([1e9, 3e11])}
    for name in ("paper", "chain3-free-flight"):
        base = impactgen.load_scene(name)
        for _ in range(400):
            overrides = {k: values[k]() for k in rng.sample(sorted(values), rng.randint(1, 3))}
            outcomes = built_both_ways(base, overrides)
            assert outcomes[0] == outcomes[1], overrides


def test_solver_settings_give_the_scene_read_in_full():
    """with_solver (how simulate applies its options) gives the very scene, or an error
    naming the same key, that reading the whole scene with those settings gives."""
    import random

    from impactgen.errors import SceneError
    from impactgen.scene import scene_from_dict, with_solver
    rng = random.Random(11)
    values = {"rtol": [1e-8, 1e-6, 0.0, "x"], "atol": [1e-10, 2.0], "max_steps": [5, 0, 1.5],
              "t_end": ["separation", 0.5, -1.0], "method": ["bdf", "adams", "dopri5", "auto"],
              "jacobian": ["auto", "analytic", "difference"]}
    for name in ("paper", "chain3-free-flight", "bouncing"):
        base = impactgen.load_scene(name)
        for _ in range(200):
            settings = {k: rng.choice(values[k]) for k in rng.sample(sorted(values), rng.randint(1, 3))}
            outcomes = []
            for build in (lambda: scene_from_dict(base.to_dict(), {f"solver.{k}": v for k, v in settings.items()}),
                          lambda: with_solver(base, settings)):
                try:
                    outcomes.append(build())
                except SceneError as exc:
                    outcomes.append(exc.key)
            if len([o for o in outcomes if isinstance(o, str)]) == 1:
                raise AssertionError((settings, outcomes))
            if not isinstance(outcomes[0], str) or len(settings) == 1:
                assert outcomes[0] == outcomes[1], settings


def test_checking_many_values_refuses_exactly_what_checking_each_refuses():
    """check_values (a sweep's check of every value before it runs) passes plain floats by a
    shortcut; it must refuse the same values, with the same message, as check_value."""
    from impactgen.errors import SceneError
    from impactgen.scene import check_value, check_values
    values = [0.3, -0.2, 0.0, 0.5, 0.49, 1e9, 3e11, -1.0, 2, True, "x", float("nan"), float("inf"), [0.1, 0.2]]
    for key in ("initial.u[2]", "rod.nu", "rod.yield_strength", "chain.mass[1]", "chain.mass", "contact.friction",
                "surface.height", "chain.links", "solver.rtol"):
        for value in values:
            outcomes = []
            for check in (lambda: check_value(key, value, 2), lambda: check_values(key, [value], 2)):
                try:
                    check()
                    outcomes.append(None)
                except SceneError as exc:
                    outcomes.append(str(exc))
            assert outcomes[0] == outcomes[1], (key, value)


def test_the_keys_that_rerun_the_cross_key_checks_are_scene_keys():
    """scene_with skips the cross-key checks when no key they read changed; a misspelt key
    in that list would skip them for good."""
    from impactgen.scene import split_key
    from impactgen.scene.updates import _CROSS_CHECKED
    for name in _CROSS_CHECKED:
        split_key(name)


def test_the_scene_refuses_a_parameter_exactly_where_its_table_range_ends():
    """One statement of each physical range (the parameter table): the scene checks it, as
    the generated C checks it when an FMU importer sets the parameter."""
    from impactgen.codegen.parameters import PARAMETERS
    from impactgen.scene import check_value
    ranged = [p for p in PARAMETERS if p.kind == "input" and p.range_text() and "." in p.key
              and p.key != "surface.height_initial"]
    assert {p.key for p in ranged} >= {"rod.nu", "chain.mass[{i}]", "contact.friction", "contact.friction_eps"}
    for row in ranged:
        key = row.key.format(i=1)
        for end, is_open in ((row.low, row.low_open), (row.high, row.high_open)):
            if not math.isfinite(end):
                continue
            for value in (end, math.nextafter(end, -math.inf), math.nextafter(end, math.inf)):
                if row.admits(value):
                    assert check_value(key, value, 2) == value
                else:
                    with pytest.raises(SceneError, match=re.escape(row.range_text())):
                        check_value(key, value, 2)
            assert row.admits(end) is not is_open


# ----------------------------------------------------------------------------- reading by key

def test_the_scene_reads_every_key_that_overrides_take():
    """scene[key] gives what the scene file states, by the dotted keys of --set and overrides:
    setting a key to what it reads leaves the scene as it was."""
    for scene in (impactgen.load_scene("paper"), impactgen.load_scene("paper", {
            "chain.links": 3, "chain.length": [1.0, 0.5, 0.25], "initial.q_deg": [-70, -60, -50],
            "initial.u": [-0.1, -0.2, -0.3], "contact.joint_radius": [0.004, 0.003], "surface.height": -2.5,
            "solver.t_end": 0.1})):
        assert set(scene.keys()) == {f"{s}.{k}" if s else k for s, keys in SCHEMA.items() for k in keys}
        for key in scene.keys():
            value = scene[key]
            assert scene.get(key) == value
            changed = scene.replace({key: value})
            assert changed[key] == pytest.approx(value) if key == "initial.q_deg" else changed[key] == value
            if key not in ("initial.q_deg", "contact.joint_radius"):  # degrees round; radii given where none were
                assert changed == scene, key


def test_the_scene_reads_values_and_elements_as_the_file_names_them():
    scene = impactgen.load_scene("paper", {"initial.u[2]": -0.3})
    assert scene["surface.height"] == "initial" and scene["solver.t_end"] == "separation"
    assert scene["initial.u"] == [-0.1, -0.3] and scene["initial.u[2]"] == -0.3
    assert scene["initial.q_deg[1]"] == pytest.approx(-70.0) and scene["initial.q[1]"] == scene.q0[0]
    assert scene["rod.tip_radius"] == scene.tip_radius == scene["contact.joint_radius[1]"]
    assert scene["chain.length[2]"] == 1.0 and scene["contact.friction"] == 0.2
    assert scene["solver.jacobian"] == "auto" and scene["name"] == "paper-double-pendulum"
    lower = scene.replace({"surface.height": -2.0})
    assert lower["surface.height"] == -2.0 == lower.surface_height


@pytest.mark.parametrize("key", ["contact.mu", "surface.heigth", "initial.u[3]", "rod.E[1]", "initial.u[0]",
                                 "solvr.rtol"])
def test_reading_a_key_fails_as_setting_it_does(key):
    """An unknown key, or an element that is not there, gives the error --set gives."""
    scene = impactgen.load_scene("paper")
    with pytest.raises(SceneError) as setting:
        impactgen.load_scene("paper", dict([parse_override(f"{key}=1.0")]))
    with pytest.raises(SceneError) as reading:
        scene[key]
    assert str(reading.value) == str(setting.value)
    with pytest.raises(SceneError) as getting:
        scene.get(key)
    assert str(getting.value) == str(setting.value)


def test_a_scene_is_read_by_key_not_iterated():
    scene = impactgen.load_scene("paper")
    with pytest.raises(SceneError, match="dotted string"):
        scene[0]
    with pytest.raises(TypeError):
        iter(scene)


@pytest.mark.parametrize("typed, meant", [
    ("contact.mu", "contact.friction"), ("mu", "contact.friction"), ("chain.g", "chain.gravity"),
    ("surface.S_y", "surface.yield_strength"), ("initial.omega", "initial.u"), ("contact.frction", "contact.friction"),
    ("rod.height", "surface.height"), ("solvr.rtol", "solver.rtol"), ("nmae", "name"),
])
def test_an_unknown_key_suggests_the_key_meant(typed, meant):
    with pytest.raises(SceneError, match=re.escape(f"did you mean '{meant}'?")):
        impactgen.load_scene("paper", {typed: 1.0})


def test_get_gives_the_default_for_a_key_left_unset_never_for_an_unknown_one():
    scene = impactgen.load_scene("paper")
    assert scene.get("surface.height", 0.0) == "initial" and scene.get("rod.tip_radius", 1.0) == 0.005
    assert scene["rod.material"] is None and scene.get("rod.material", "typed") == "typed"
    assert scene.get("chain.diameter") is None and scene.get("rod.density", 7800.0) == 7800.0
    with pytest.raises(SceneError, match=re.escape("surface.heigth: unknown key (did you mean 'surface.height'?)")):
        scene.get("surface.heigth", 0.0)


@pytest.mark.parametrize("attribute, key", [
    ("surface.height", "surface.height"), ("rod.tip_radius", "rod.tip_radius"), ("q_deg", "initial.q_deg"),
    ("contact.mu", "contact.friction"), ("chain.density", "rod.density"), ("height", "surface.height"),
])
def test_an_attribute_the_scene_lacks_names_the_dotted_key_meant(attribute, key):
    """scene.surface.height is not an attribute: the error says how to read it."""
    scene = impactgen.load_scene("paper")
    part, _, name = attribute.rpartition(".")
    with pytest.raises(AttributeError, match=re.escape(f"scene['section.key'] (did you mean '{key}'?)")):
        getattr(getattr(scene, part) if part else scene, name)
    assert scene[key] is not None or key == "rod.density"


def test_the_initial_table_is_named_by_its_keys():
    with pytest.raises(AttributeError, match=re.escape("(the [initial] table's keys: initial.q_deg, initial.q, "
                                                       "initial.u, initial.base, initial.base_velocity)")):
        impactgen.load_scene("paper").initial


def test_a_scene_still_pickles_and_copies():
    import copy
    import pickle
    scene = impactgen.load_scene("paper", {"rod.material": "steel-paper", "chain.diameter": 0.01})
    assert pickle.loads(pickle.dumps(scene)) == scene == copy.deepcopy(scene)
    assert not hasattr(scene.rod, "height") and hasattr(scene.rod, "density")
