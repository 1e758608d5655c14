"""The front door: from a checked scene to a result, with the engine of one's choice."""
from __future__ import annotations

from .codegen.expressions import ModelSpec
from .errors import SceneError
from .results import SimulationResult
from .scene import Scene

ENGINES = ("c", "reference")


def model_spec(scene: Scene) -> ModelSpec:
    """The structure of the generated C that `scene` needs (numbers stay parameters)."""
    friction = scene.contact.friction_mode if scene.contact.friction > 0 else "none"
    sustained = scene.solver.t_end is not None and scene.solver.sustained_contact
    return ModelSpec(scene.n, scene.contact.model, friction, scene.solver.jacobian == "analytic", sustained)


def simulate(scene: Scene, engine: str = "c", **options) -> SimulationResult:
    """Run `scene` to separation (or to solver.t_end) and return the result."""
    if engine == "c":
        from . import phases
        from .build import compile_model
        return phases.run(compile_model(model_spec(scene)), scene, **options)
    if engine == "reference":
        from . import reference
        return reference.simulate(scene, **options)
    raise SceneError("engine", f"{engine!r} is not one of {', '.join(ENGINES)}")
