"""FMI 2.0 export: Model Exchange and Co-Simulation FMUs of a scene (docs/embedding.md)."""
from .package import build_fmu, fmu_spec

__all__ = ["build_fmu", "fmu_spec"]
