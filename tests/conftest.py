"""Shared fixtures: a fresh build cache per test session, the repository's scenes, and the
commands of tests that start before their turn."""
from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAPER = ROOT / "scenes" / "paper.toml"

# Every session builds its models from scratch, into a folder of its own.
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


# ----------------------------------------------------------------------------- started early

class EarlyRun:
    """One test's subprocess, started at the end of the collection: it runs beside the tests
    before it (the suite itself keeps one core busy) and the test waits for its end. Its output
    goes to files (nobody reads a pipe meanwhile); its timeout counts from its start, as
    subprocess.run's. It stays in the session's process group, as a child of the test itself
    would, so that a Ctrl-C reaches it too."""

    def __init__(self, args: list[str], env: dict[str, str] | None = None, timeout: float | None = None):
        self.args, self.timeout = args, timeout
        self.out = tempfile.TemporaryFile("w+")
        self.err = tempfile.TemporaryFile("w+")
        self.started = time.monotonic()
        self.process = subprocess.Popen(args, stdout=self.out, stderr=self.err, env=env, text=True)

    def result(self) -> subprocess.CompletedProcess:
        left = None if self.timeout is None else max(0.0, self.timeout - (time.monotonic() - self.started))
        try:
            self.process.wait(timeout=left)
        except subprocess.TimeoutExpired:
            self.stop()
            raise subprocess.TimeoutExpired(self.args, self.timeout) from None
        self.out.seek(0)
        self.err.seek(0)
        return subprocess.CompletedProcess(self.args, self.process.returncode, self.out.read(), self.err.read())

    def stop(self) -> None:
        """End the process and every process under it (the session is ending without it)."""
        if self.process.poll() is None:
            for signum in (signal.SIGTERM, signal.SIGKILL):
                for pid in [*_descendants(self.process.pid), self.process.pid]:
                    with contextlib.suppress(ProcessLookupError):
                        os.kill(pid, signum)
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self.process.wait(timeout=30)
                    break
        self.out.close()
        self.err.close()


def _descendants(pid: int) -> list[int]:
    """Every process under `pid` (Linux's /proc), deepest first."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with contextlib.suppress(OSError):
            for child in map(int, (task / "children").read_text().split()):
                found += [*_descendants(child), child]
    return found


_EARLY: dict[str, EarlyRun] = {}


def start_early(command):
    """Mark a test whose one expensive subprocess needs nothing the tests before it make:
    `command()` gives subprocess.run's args, env and timeout, and the test gets the finished
    process from `early_run(request.node, command)`. Not started when the test is deselected
    or skipped by a skipif of its own."""
    def mark(test):
        test.early_command = command
        return test
    return mark


def early_run(node, command) -> subprocess.CompletedProcess:
    """The finished process of `command`: the one started early for this test, or, when none
    was (the test run some other way than by a whole session's collection), one run now."""
    early = _EARLY.pop(node.nodeid, None)
    if early is None:
        return subprocess.run(capture_output=True, text=True, **command())
    return early.result()


def _skipped_by_its_own_marks(item) -> bool:
    if next(item.iter_markers("skip"), None) is not None:
        return True
    for mark in item.iter_markers("skipif"):
        condition = mark.args[0] if mark.args else mark.kwargs.get("condition", True)
        if not isinstance(condition, bool) or condition:  # a string condition: left to pytest
            return True
    return False


def pytest_collection_finish(session):
    if session.config.option.collectonly:
        return
    for item in session.items:
        command = getattr(getattr(item, "function", None), "early_command", None)
        if command is not None and not _skipped_by_its_own_marks(item):
            _EARLY[item.nodeid] = EarlyRun(**command())


def pytest_sessionfinish(session):
    while _EARLY:  # not reached (the session stopped first): no process outlives the session
        _EARLY.popitem()[1].stop()
