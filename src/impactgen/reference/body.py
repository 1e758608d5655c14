"""What holds the chain and what it lies on: a pinned or a free base, where a free base starts
and how it moves, its contact radius, and the surface's angle. The reference engine reads it
from the scene's keys (chain.base, initial.base, initial.base_velocity, contact.base_radius,
surface.angle_deg), by their names, as a user does."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..scene import Scene


@dataclass(frozen=True)
class Body:
    """The chain's base and the surface's angle. A pinned chain's base is the fixed pivot at
    the origin; a free chain's starts at `base_position` with `base_velocity` and touches the
    surface with the radius `base_radius`."""

    free: bool = False
    slope: float = 0.0  # the surface's angle a (rad): it descends towards +x
    base_position: tuple[float, float] = (0.0, 0.0)  # m, in the surface's frame
    base_velocity: tuple[float, float] = (0.0, 0.0)  # m/s
    base_radius: float | None = None  # m; None: rod.tip_radius

    @classmethod
    def from_scene(cls, scene: Scene) -> "Body":
        """The body the scene's keys describe."""
        slope = math.radians(scene["surface.angle_deg"])
        if scene["chain.base"] != "free":
            return cls(slope=slope)
        return cls(True, slope, tuple(scene["initial.base"]), tuple(scene["initial.base_velocity"]),
                   scene["contact.base_radius"])

    def start(self, scene: Scene) -> tuple[list[float], list[float]]:
        """The positions and speeds at t = 0 in the state's order (the base's after the angles
        for a free chain)."""
        if not self.free:
            return list(scene.q0), list(scene.u0)
        return [*scene.q0, *self.base_position], [*scene.u0, *self.base_velocity]
