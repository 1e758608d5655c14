"""impactgen: generate fast C for an n-link pendulum hitting a flat surface, and simulate it.

    import impactgen
    scene = impactgen.load_scene("paper.toml", overrides={"initial.u": [-0.1, -0.3]})
    result = impactgen.simulate(scene)          # engine="c" (CVODE) or "reference"
    result.summary, result.phases, result.t, result.q, result.u
"""
from .compare import compare_laws
from .contact_compare import compare_contact_laws
from .engines import simulate
from .errors import BuildError, ImpactgenError, ImpactgenWarning, SceneError, SolverError, ValidityWarning
from .fitting import fit
from .scene import Scene, load_scene, scene_from_dict
from .sweep import run_batch, sweep

__version__ = "0.1.0"


__all__ = ["BuildError", "ImpactgenError", "ImpactgenWarning", "SceneError", "SolverError", "ValidityWarning", "Scene", "load_scene",
           "scene_from_dict", "simulate", "sweep", "run_batch", "compare_laws",
           "compare_contact_laws", "fit", "__version__"]
