"""Named materials and link masses from a density and a cross-section: a scene by material runs
as the one with the values typed, masses follow the closed form, and contradictions are refused
naming the keys."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import impactgen
from impactgen.errors import SceneError
from impactgen.materials import MATERIALS
from conftest import built_both_ways

STEEL = MATERIALS["steel-paper"]
ALUMINIUM = MATERIALS["aluminium-6061-t6"]
TYPED = ("rod.E", "rod.nu", "rod.yield_strength", "surface.E", "surface.nu", "surface.yield_strength")


def _by_material(rod: str = "steel-paper", surface: str = "steel-paper", **more) -> impactgen.Scene:
    """The paper's scene with its materials named instead of typed."""
    return impactgen.load_scene("paper", {**{k: None for k in TYPED}, "rod.material": rod,
                                          "surface.material": surface, **more})


def test_every_material_has_its_values_and_a_source():
    for m in MATERIALS.values():
        assert 1e9 < m.E < 1e12 and 0 < m.nu < 0.5 and 0 < m.yield_strength < m.E and 1000 < m.density < 20000
        assert m.source and m.description
    assert (STEEL.E, STEEL.nu, STEEL.yield_strength, STEEL.density) == (210e9, 0.29, 1.12e9, 7800.0)  # MODEL 7


def test_a_scene_by_material_runs_as_the_scene_with_the_values_typed(paper_result):
    scene = _by_material()
    assert (scene.rod.E, scene.rod.nu, scene.rod.yield_strength) == (210e9, 0.29, 1.12e9)
    assert scene["rod.material"] == "steel-paper" and scene["rod.density"] == 7800.0
    assert scene["surface.E"] == 210e9 and scene.surface.density is None  # the surface's mass is not in the model
    result = impactgen.simulate(scene)
    np.testing.assert_array_equal(result.y, paper_result.y)
    assert result.summary["delta_r"] == paper_result.summary["delta_r"]


def test_a_key_given_beside_a_material_overrides_its_value():
    scene = _by_material(rod="aluminium-6061-t6", **{"rod.yield_strength": 200e6})
    assert scene.rod.E == ALUMINIUM.E and scene.rod.yield_strength == 200e6
    assert scene.to_dict()["rod"] == {"material": "aluminium-6061-t6", "yield_strength": 200e6, "tip_radius": 0.005}
    # an override of the material replaces the values the scene gave, but for those it gives too
    brass = MATERIALS["brass-c36000"]
    assert scene.replace({"rod.material": brass.name}).rod == impactgen.scene.Material(
        brass.E, brass.nu, brass.yield_strength, brass.name, brass.density)
    assert scene.replace({"rod.yield_strength": 1e8, "rod.material": brass.name}).rod.yield_strength == 1e8
    typed = impactgen.load_scene("paper", {"rod.material": "aluminium-6061-t6"})  # the paper's scene types E, ...
    assert (typed.rod.E, typed.rod.nu, typed.rod.yield_strength) == (ALUMINIUM.E, ALUMINIUM.nu, ALUMINIUM.yield_strength)
    assert typed.surface.E == 210e9
    assert impactgen.scene_from_dict(scene.to_dict()) == scene
    assert impactgen.scene.scene_from_text(scene.to_toml()) == scene


def test_an_unknown_material_lists_the_named_ones():
    with pytest.raises(SceneError, match=r"rod.material: 'steel' is not one of steel-paper, steel-a36"):
        _by_material(rod="steel")
    with pytest.raises(SceneError, match=r"rod.E: missing required key \(Pa; or give rod.material\)"):
        impactgen.load_scene("paper", {"rod.E": None})


def test_link_masses_from_a_density_and_a_cross_section_match_the_closed_form():
    d = 0.012  # m
    lengths = [1.0, 0.6]
    scene = impactgen.load_scene("paper", {"chain.mass": None, "rod.density": 7800.0, "chain.diameter": d,
                                           "chain.length": lengths})
    expected = [7800.0 * math.pi * d ** 2 / 4 * L for L in lengths]
    assert scene.chain.mass == pytest.approx(expected, rel=1e-15)
    assert scene["chain.mass"] == list(scene.chain.mass) and scene["chain.diameter"] == [d, d]
    by_area = impactgen.load_scene("paper", {"chain.area": [2e-4, 1e-4], "rod.material": "aluminium-6061-t6"})
    assert by_area["chain.mass"] == list(by_area.chain.mass) and by_area["chain.diameter"] is None
    assert by_area.chain.mass == pytest.approx([2700.0 * 2e-4 * 1.0, 2700.0 * 1e-4 * 1.0], rel=1e-15)
    # the paper's 1 kg links of its steel are a round bar of this diameter
    paper_bar = math.sqrt(4 / (math.pi * STEEL.density))
    assert _by_material(**{"chain.diameter": paper_bar}).chain.mass == pytest.approx((1.0, 1.0), rel=1e-14)


def test_the_inertia_follows_the_derived_mass_by_the_models_one_rule():
    """A chain by density runs as the same masses typed (the model takes m and L only, and
    its inertia is m L^2 / 12 of the mass, however the mass was given)."""
    from impactgen.reference.chain import ChainModel
    by_density = impactgen.load_scene("paper", {"chain.mass": None, "chain.diameter": [0.012, 0.015],
                                                "rod.density": 7800.0})
    typed = impactgen.load_scene("paper", {"chain.mass": list(by_density.chain.mass)})
    np.testing.assert_array_equal(impactgen.simulate(by_density).y, impactgen.simulate(typed).y)
    model = ChainModel.from_scene(by_density)
    assert model.inertia == pytest.approx([m * 1.0 ** 2 / 12 for m in by_density.chain.mass], rel=1e-15)


@pytest.mark.parametrize("overrides, key, words", [
    ({"chain.mass": 1.0, "chain.diameter": 0.01, "rod.density": 7800.0}, "chain.diameter", "given twice"),
    ({"chain.diameter": 0.01, "chain.area": 1e-4}, "chain.area", "given twice"),
    ({"chain.diameter": 0.01}, "chain.diameter", "rod.density"),
    ({"chain.area": 1e-4, "rod.density": -1.0}, "rod.density", "> 0"),
    ({"chain.diameter": [0.01], "rod.density": 7800.0}, "chain.diameter", "2 values"),
])
def test_contradictions_and_missing_densities_are_refused_naming_the_keys(overrides, key, words):
    with pytest.raises(SceneError) as err:
        impactgen.load_scene("paper", overrides)
    assert err.value.key.startswith(key) and words in str(err.value)


def test_a_file_giving_masses_and_a_cross_section_is_refused():
    text = (impactgen.load_scene("paper").to_toml()
            .replace("[rod]\n", "[rod]\ndensity = 7800.0\n").replace("[chain]\n", "[chain]\ndiameter = 0.01\n"))
    with pytest.raises(SceneError, match=r"chain.mass: the links' masses are given twice, by chain.mass and by "
                                         r"chain.diameter"):
        impactgen.scene.scene_from_text(text)


def test_an_override_of_the_masses_replaces_the_cross_section_and_back():
    """As initial.q replaces initial.q_deg: one of chain.mass, chain.diameter, chain.area."""
    by_density = _by_material(**{"chain.diameter": 0.01})
    typed = by_density.replace({"chain.mass": [2.0, 3.0]})
    assert typed.chain.mass == (2.0, 3.0) and typed.chain.diameter is None
    again = typed.replace({"chain.area": 1e-4})
    assert again.chain.mass == pytest.approx((0.78, 0.78)) and again.chain.area == (1e-4, 1e-4)
    # a longer link of the same bar weighs more; the short way and the full read agree
    for overrides in ({"chain.length[2]": 2.0}, {"chain.mass": 1.5}, {"rod.density": 2700.0},
                      {"rod.material": "ti-6al-4v"}, {"chain.diameter[1]": 0.02}, {"rod.E": 1e11}):
        full, short = built_both_ways(by_density, overrides)
        assert full == short, overrides
    longer = by_density.replace({"chain.length[2]": 2.0})
    assert longer.chain.mass[1] == pytest.approx(2 * by_density.chain.mass[1], rel=1e-15)


def test_the_scene_reads_and_round_trips_every_key_by_material():
    scene = _by_material(rod="ti-6al-4v", **{"chain.area": [1e-4, 2e-4], "rod.nu": 0.3})
    for key in scene.keys():
        if key not in ("initial.q_deg", "contact.joint_radius", "chain.mass", "rod.material"):
            assert scene.replace({key: scene[key]}) == scene, key
    typed = scene.replace({"chain.mass": scene["chain.mass"]})  # the masses typed replace the cross-section
    assert typed.chain.mass == scene.chain.mass and typed.chain.area is None
    again = scene.replace({"rod.material": "ti-6al-4v"})  # the material again: its own nu, not the one given
    assert again.rod.nu == MATERIALS["ti-6al-4v"].nu and again.rod.E == scene.rod.E
    assert impactgen.scene_from_dict(scene.to_dict()) == scene


def test_impactgen_materials_lists_the_table():
    res = subprocess.run([sys.executable, "-m", "impactgen.cli", "materials"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    for m in MATERIALS.values():
        line = next(line for line in res.stdout.splitlines() if line.startswith(m.name + " "))
        assert f"{m.E / 1e9:.1f}" in line and m.source in line


def test_a_sweep_over_materials_runs_each_material():
    """Varying rod.material over the paper's scene (which types E, nu and the yield strength)
    runs each material, not the typed values: the override replaces them."""
    pytest.importorskip("pandas")
    names = ["steel-paper", "aluminium-6061-t6"]
    table = impactgen.sweep("paper", vary={"rod.material": names}, workers=1)
    assert list(table["status"]) == ["ok", "ok"]
    for name, (_, row) in zip(names, table.iterrows()):
        alone = impactgen.simulate(impactgen.load_scene("paper", {"rod.material": name}))
        assert row["delta_r"] == alone.summary["delta_r"]
    assert table["delta_r"].iloc[1] > 2 * table["delta_r"].iloc[0]  # the softer rod yields more


def test_the_table_in_docs_scene_md_states_the_materials_values():
    """docs/scene.md repeats the table for readers: its numbers are MATERIALS'."""
    from conftest import ROOT
    rows = [line.split("|")[1:-1] for line in (ROOT / "docs" / "scene.md").read_text().splitlines()
            if line.startswith("| `") and line.split("|")[1].strip(" `") in MATERIALS]
    assert [r[0].strip(" `") for r in rows] == list(MATERIALS)
    for cells in rows:
        m = MATERIALS[cells[0].strip(" `")]
        E, nu, yield_mpa, density = (float(c) for c in cells[1:5])
        assert (E * 1e9, nu, yield_mpa * 1e6, density) == pytest.approx((m.E, m.nu, m.yield_strength, m.density))
