"""The checks across keys that make a scene physical: yield below modulus, and every point of
the chain starting on or above the surface."""
from __future__ import annotations

import math

from ..codegen.parameters import broken_rule
from ..codegen.spec import EVERY_LAW_KEY, LAW_KEYS
from ..codegen.thresholds import THRESHOLD
from ..errors import SceneError
from .model import Scene

# A tip (or joint) this far below the surface, relative to the chain's length (at least
# 1 m), still counts as touching it: the rounding of a height summed over the links (the
# phase machine's own start test uses the same number).
TOUCH_TOLERANCE = THRESHOLD["TOUCH_TOLERANCE"]


def joint_heights(scene: Scene) -> list[float]:
    """Heights of the base (the pivot at 0, or a free chain's base point), of every joint and
    of the tip (last), in m, at the start."""
    heights = [scene.base_start[1]]
    for L, q in zip(scene.chain.length, scene.q0):
        heights.append(heights[-1] + L * math.sin(q))
    return heights


def check_law_keys(scene: Scene) -> None:
    """The contact law's own keys: each one it reads is given, none that it does not read."""
    law = scene.contact.model
    reads = LAW_KEYS.get(law, ())
    for key in EVERY_LAW_KEY:
        given = getattr(scene.contact, key.split(".")[1]) is not None
        if given and key not in reads:
            uses = f"it reads {', '.join(reads)}" if reads else "it reads none of the other laws' keys"
            raise SceneError(key, f"contact.model = {law!r} does not use this key ({uses}); remove it "
                                  "or choose a law that reads it (docs/contact-laws.md)")
        if not given and key in reads:
            raise SceneError(key, f"missing: contact.model = {law!r} needs it (docs/contact-laws.md)")


def check_physics(scene: Scene) -> None:
    """Checks across keys: yield below modulus; every point of the chain (the joints and the
    tip, each a contact point) may start on the surface, none in it; nor may the pivot."""
    check_law_keys(scene)
    broken = broken_rule(scene)  # the rules across inputs: one list, which the generated C's start check prints
    if broken:
        raise SceneError(broken[0].key, broken[1])
    heights = joint_heights(scene)
    if scene.free:
        _check_free_start(scene, heights)
        return
    y_tip = heights[-1]
    slack = TOUCH_TOLERANCE * max(1.0, sum(scene.chain.length))
    if scene.surface_height is not None and scene.surface_height - y_tip > slack:
        raise SceneError("surface.height", f"the tip starts {scene.surface_height - y_tip:.3g} m inside "
                         f"the surface (tip at y = {y_tip:.6g} m, surface at {scene.surface_height:.6g} m); "
                         "lower the surface or change initial.q")
    y_s = y_tip if scene.surface_height is None else scene.surface_height
    for link, (upper, lower) in enumerate(zip(heights[:-1], heights[1:]), start=1):
        low = min(upper, lower)  # a straight bar is lowest at one of its ends
        if y_s - low > slack:
            if low == upper:
                where = "its pivot end" if link == 1 else f"its pivot end (joint {link - 1})"
            else:
                where = "its lower end" + (" (the tip)" if link == scene.n else f" (joint {link})")
            height = ' (surface.height = "initial" puts the surface at the tip)' \
                if scene.surface_height is None else ""
            raise SceneError("initial.q", f"link {link} starts below the surface: {where} is at "
                             f"y = {low:.6g} m, the surface at y = {y_s:.6g} m{height}; every point "
                             "of the chain must start on or above the surface (the joints and the tip "
                             "may touch it)")


def initial_surface_height(scene: Scene) -> float:
    """The surface's height y_s at the start, in m: `surface.height`, or with "initial" the
    height of the lowest contact point (a pinned chain's tip, which the checks make its lowest;
    a free chain's base point, joints and tip)."""
    if scene.surface_height is not None:
        return scene.surface_height
    heights = joint_heights(scene)
    return min(heights) if scene.free else heights[-1]


def _check_free_start(scene: Scene, heights: list[float]) -> None:
    """A free chain's every point (the base point, the joints, the tip: each a contact point)
    starts on or above the surface; a straight bar is lowest at one of its ends."""
    slack = TOUCH_TOLERANCE * max(1.0, sum(scene.chain.length))
    y_s = initial_surface_height(scene)
    if y_s - heights[0] > slack:
        raise SceneError("initial.base", f"the free chain's base point starts {y_s - heights[0]:.3g} m inside "
                         f"the surface (base at y = {heights[0]:.6g} m, surface at y = {y_s:.6g} m); "
                         "raise initial.base[2] or lower surface.height")
    for k, y in enumerate(heights[1:], start=1):
        if y_s - y > slack:
            where = "the tip" if k == scene.n else f"joint {k}"
            raise SceneError("initial.q", f"{where} of the free chain starts {y_s - y:.3g} m inside the surface "
                             f"(at y = {y:.6g} m, the surface at y = {y_s:.6g} m); every point must start on "
                             "or above the surface: change initial.q or raise initial.base")
