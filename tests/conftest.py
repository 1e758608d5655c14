"""Shared fixtures: a fresh build cache per test session and the repository's scenes."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAPER = ROOT / "scenes" / "paper.toml"

# Every session builds its models from scratch, into a folder of its own. Under pytest-xdist this
# runs first in the controlling process, whose environment the workers inherit: they share the
# folder, and its entries are built once under their locks.
os.environ.setdefault("IMPACTGEN_CACHE_DIR", tempfile.mkdtemp(prefix="impactgen-test-cache-"))


def built_both_ways(base, overrides) -> list:
    """`overrides` applied to `base` by reading the scene again in full and by `scene_with`'s
    short way: the two scenes, or the two SceneErrors' messages (they must agree)."""
    from impactgen.errors import SceneError
    from impactgen.scene import scene_from_dict, scene_with
    outcomes = []
    for build in (lambda: scene_from_dict(base.to_dict(), overrides), lambda: scene_with(base, overrides)):
        try:
            outcomes.append(build())
        except SceneError as exc:
            outcomes.append(str(exc))
    return outcomes


@pytest.fixture
def c_driver(tmp_path):
    """A builder of examples/c's driver for a generated model folder, with the Makefile's own
    flags and the SUNDIALS impactgen found: it returns the driver's path."""
    import subprocess

    from impactgen.sundials import find_sundials

    def build(folder: Path) -> Path:
        flags = find_sundials().cc_args()
        driver = tmp_path / "impact_driver"
        made = subprocess.run(["make", "-s", "-C", str(ROOT / "examples" / "c"), f"MODEL={folder}",
                               "SUNDIALS_CFLAGS=" + " ".join(f for f in flags if f.startswith("-I")),
                               "SUNDIALS_LIBS=" + " ".join(f for f in flags if not f.startswith("-I")),
                               f"OUT={driver}"], capture_output=True, text=True)
        assert made.returncode == 0, made.stderr
        return driver
    return build


@pytest.fixture(scope="session")
def paper_scene():
    import impactgen
    return impactgen.load_scene(PAPER)


@pytest.fixture(scope="session")
def paper_result(paper_scene):
    import impactgen
    return impactgen.simulate(paper_scene)


def pytest_collection_modifyitems(items):
    """Tests marked `first` (minutes in a subprocess of their own) go to the front, so that a
    worker runs them beside the others rather than alone at the end of the session."""
    items.sort(key=lambda item: item.get_closest_marker("first") is None)  # stable: else as collected
