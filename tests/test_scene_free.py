"""Scene keys of free chains and inclined surfaces (chain.base, initial.base,
initial.base_velocity, contact.base_radius, surface.angle_deg): read, defaulted, written back,
and every bad input refused naming its key."""
from __future__ import annotations

import math

import pytest

import impactgen
from impactgen.errors import SceneError
from impactgen.scene import initial_surface_height, joint_heights, scene_from_text


def free_rod(**initial) -> dict:
    """A steel rod, 0.5 m long, held free 0.1 m above a level plate at 30 degrees."""
    return {
        "name": "free-rod",
        "chain": {"links": 1, "length": 0.5, "diameter": 0.01, "base": "free"},
        "rod": {"material": "steel-paper", "tip_radius": 0.005},
        "surface": {"material": "steel-paper"},
        "contact": {"friction": 0.2},
        "initial": {"q_deg": [30.0], "u": [0.0], "base": [0.0, 0.1], **initial},
    }


def test_free_chain_keys_are_read_and_defaulted():
    scene = impactgen.scene_from_dict(free_rod())
    assert scene.free and scene["chain.base"] == "free"
    assert scene.base0 == (0.0, 0.1) and scene.base_velocity == (0.0, 0.0)
    assert scene.surface_height == 0.0 and scene["surface.height"] == 0.0  # a free chain's default
    assert scene.base_radius == scene.tip_radius == scene["contact.base_radius"]
    assert scene["initial.base[2]"] == 0.1 and scene["surface.angle_deg"] == 0.0
    assert joint_heights(scene) == pytest.approx([0.1, 0.1 + 0.5 * math.sin(math.radians(30))])


def test_free_chain_round_trips_through_toml():
    raw = free_rod(base_velocity=[0.5, -1.0])
    raw["surface"]["angle_deg"] = 20.0
    raw["contact"]["base_radius"] = 0.003
    scene = impactgen.scene_from_dict(raw)
    again = scene_from_text(scene.to_toml())
    assert again == scene and again.surface_angle == pytest.approx(math.radians(20.0))
    assert again.base_u0 == (0.5, -1.0) and again.base_radius == 0.003


def test_initial_height_is_the_lowest_contact_point():
    raw = free_rod(base=[0.2, 0.3])
    raw["initial"]["q_deg"] = [-30.0]  # the tip is lowest, 0.25 m below the base
    raw["surface"]["height"] = "initial"
    scene = impactgen.scene_from_dict(raw)
    assert initial_surface_height(scene) == pytest.approx(0.05)
    raw["initial"]["q_deg"] = [30.0]  # now the base is lowest
    assert initial_surface_height(impactgen.scene_from_dict(raw)) == pytest.approx(0.3)


def test_overrides_change_the_free_keys():
    scene = impactgen.scene_from_dict(free_rod()).replace({"initial.base[2]": 0.2, "surface.angle_deg": -15.0})
    assert scene.base0 == (0.0, 0.2) and scene.surface_angle_deg == -15.0


def test_pinned_scenes_are_unchanged(paper_scene):
    assert not paper_scene.free and paper_scene.surface_angle_deg == 0.0
    assert paper_scene.base0 is None and paper_scene["initial.base"] is None
    assert paper_scene["contact.base_radius"] is None and paper_scene["surface.height"] == "initial"
    stated = paper_scene.to_dict()
    assert "base" not in stated["chain"] and "angle_deg" not in stated["surface"]
    assert set(stated["initial"]) == {"q", "u"}


def test_a_pinned_chain_may_stand_on_an_inclined_surface(paper_scene):
    assert paper_scene.replace({"surface.angle_deg": 10.0}).surface_angle_deg == 10.0


@pytest.mark.parametrize("overrides, key, words", [
    ({"initial.base": [0.0]}, "initial.base", "2 numbers"),
    ({"initial.base": [0.0, 1.0, 2.0]}, "initial.base", "2 numbers"),
    ({"initial.base_velocity": 1.0}, "initial.base_velocity", "2 numbers"),
    ({"surface.angle_deg": 90.0}, "surface.angle_deg", "(-90, 90)"),
    ({"surface.angle_deg": -95.0}, "surface.angle_deg", "(-90, 90)"),
    ({"initial.base": None}, "initial.base", "needs its base point"),
    ({"initial.base[2]": -0.01}, "initial.base", "inside the surface"),
    ({"initial.q_deg": [-30.0]}, "initial.q", "tip of the free chain"),
    ({"chain.base": "loose"}, "chain.base", "pinned, free"),
    ({"contact.base_radius": -1.0}, "contact.base_radius", "must"),
])
def test_bad_free_inputs_name_their_key(overrides, key, words):
    with pytest.raises(SceneError, match=None) as err:
        impactgen.scene_from_dict(free_rod(), overrides)
    assert err.value.key.startswith(key) and words in str(err.value)


@pytest.mark.parametrize("key, value", [("initial.base", [0.0, 1.0]), ("initial.base_velocity", [0.0, 0.0]),
                                        ("contact.base_radius", 0.004)])
def test_base_keys_on_a_pinned_chain_are_refused(paper_scene, key, value):
    with pytest.raises(SceneError, match="free chain's key") as err:
        paper_scene.replace({key: value})
    assert err.value.key == key
