"""The docs are for users: they name no path under /tmp (a reader has none of those files)."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
UNDER_TMP = re.compile(r"(?<![\w.~-])/tmp\b")


def _docs() -> list[Path]:
    return [*sorted((ROOT / "docs").rglob("*.md")), ROOT / "README.md", ROOT / "generated" / "README.md"]


def test_no_doc_names_a_path_under_tmp():
    found = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}" for path in _docs()
             for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
             if UNDER_TMP.search(line)]
    assert found == [], "docs name paths under /tmp:\n" + "\n".join(found[:20])


def test_the_check_finds_a_path_under_tmp():
    assert UNDER_TMP.search("see /tmp/run.py") and UNDER_TMP.search("in /tmp")
    assert not UNDER_TMP.search("a/tmp/b") and not UNDER_TMP.search("/tmpfs")
