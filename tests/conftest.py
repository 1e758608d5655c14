"""Shared fixtures: a fresh build cache per test session, the repository's scenes."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAPER = ROOT / "scenes" / "paper.toml"

# Every session builds its models from scratch, into a folder of its own.
os.environ.setdefault("IMPACTGEN_CACHE_DIR", tempfile.mkdtemp(prefix="impactgen-test-cache-"))


@pytest.fixture(scope="session")
def paper_scene():
    import impactgen
    return impactgen.load_scene(PAPER)


@pytest.fixture(scope="session")
def paper_result(paper_scene):
    import impactgen
    return impactgen.simulate(paper_scene)
