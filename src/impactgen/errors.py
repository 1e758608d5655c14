"""One exception family for everything impactgen reports to a user.

Each class carries the process exit code the command line uses for it, so that the CLI
maps an error to its code in one place and a caller of the Python API can catch
`ImpactgenError` for all of them.
"""
from __future__ import annotations


class ImpactgenError(Exception):
    """Base of all impactgen errors; the message says what is wrong and what to do."""

    exit_code = 1


class SceneError(ImpactgenError, ValueError):
    """A scene file, an override or an argument is invalid (exit code 2)."""

    exit_code = 2

    def __init__(self, key: str | None, message: str):
        self.key = key
        shown = key if key is None or key.isprintable() else repr(key)  # keys come from users
        super().__init__(f"{shown}: {message}" if key else message)


class BuildError(ImpactgenError, RuntimeError):
    """Generating or compiling the model failed, or SUNDIALS is missing (exit code 3)."""

    exit_code = 3


class SolverError(ImpactgenError, RuntimeError):
    """CVODE (or the reference integrator) could not finish a phase (exit code 4)."""

    exit_code = 4

    def __init__(self, message: str, phase: str | None = None, t: float | None = None):
        self.phase = phase
        self.t = t
        where = ""
        if phase is not None:
            where = f" in phase '{phase}'" + (f" at t = {t:.6g} s" if t is not None else "")
        super().__init__(f"solver failed{where}: {message}")
