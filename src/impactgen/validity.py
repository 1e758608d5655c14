"""Where a result leaves the model's range of validity, say so (never a silent number).

Checked per impact from what was recorded at maximum compression:
- the contact radius a of Eq. 10 reaches the tip radius: the tip is no longer a small
  sphere on a half-space (Hertz and Jackson-Green both assume a << R);
- delta_max beyond 110 delta_c: outside the range of the finite-element results that the
  Jackson-Green fits were made from;
- delta_max < delta_c: the elastic limit was never reached, so the impact was purely
  Hertzian (delta_r = 0), which may not be what a plastic-impact study expects.
"""
from __future__ import annotations

import math

from .contact_constants import YIELD_ONSET, contact_constants
from .scene import Scene

JACKSON_GREEN_MAX_W = 110.0


def contact_radius(delta: float, R: float, delta_c: float, B: float) -> float:
    return math.sqrt(R * delta * (delta / (YIELD_ONSET * delta_c)) ** B)


def validity_warnings(scene: Scene, impacts) -> list[str]:
    if scene.contact.model != "three-phase" or not impacts:
        return []
    c = contact_constants(scene)
    warnings = []
    for k, impact in enumerate(impacts, start=1):
        w = impact.delta_m / c.delta_c
        where = f"impact {k}" if len(impacts) > 1 else "the impact"
        if impact.delta_m >= YIELD_ONSET * c.delta_c:
            a = contact_radius(impact.delta_m, c.R, c.delta_c, c.B)
            if a >= c.R:
                warnings.append(f"{where}: contact radius a = {a:.3g} m reaches the tip radius "
                                f"{c.R:.3g} m; Hertz and Jackson-Green assume a << R")
        if w > JACKSON_GREEN_MAX_W:
            warnings.append(f"{where}: delta_max = {w:.3g} delta_c, beyond the {JACKSON_GREEN_MAX_W:g} "
                            "delta_c that the Jackson-Green fits cover")
        if 0 < w < 1:
            warnings.append(f"{where}: the elastic limit was never reached (delta_max = {w:.3g} "
                            "delta_c): a purely Hertzian impact, delta_r = 0")
    return warnings
