"""Where a result leaves the model's range of validity, say so (never a silent number).

Checked per impact from what was recorded at maximum compression:
- the contact radius a of Eq. 10 reaches the tip radius: the tip is no longer a small
  sphere on a half-space (Hertz and Jackson-Green both assume a << R);
- delta_max beyond 110 delta_c: outside the range of the finite-element results that the
  Jackson-Green fits were made from;
- delta_max < delta_c: the elastic limit was never reached, so the impact was purely
  Hertzian (delta_r = 0), which may not be what a plastic-impact study expects;
- delta_max within 100 times the resolution of the tip's position (rtol times the chain's
  length, since the angles carry a relative error rtol): a very gentle impact whose
  penetration and energy budget the tolerance cannot resolve;
- chattering: a flight between two impacts shorter than twice the contact time before it.
  The tip is settling onto the surface. Without the sustained-contact phase (switched off by
  solver.sustained_contact = false) the sequence of ever shorter impacts is not resolved
  reliably (its count depends on the tolerances).

And per run, from its summary: the energy budget does not close. The works of the normal
force, friction and gravity are integrated beside the motion, so their sum must match the
change of kinetic energy to a small multiple of rtol times the largest of them; a hundred
thousand times that, and the integrator did not resolve the motion (a friction layer
thinner than its steps, for one), whatever its own error estimate said.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from .codegen.spec import point_number
from .codegen.thresholds import THRESHOLD
from .errors import ImpactgenWarning, ValidityWarning, warn
from .laws import YIELD_ONSET, ContactConstants, contact_constants, contact_radius
from .scene import Scene

JACKSON_GREEN_MAX_W = 110.0
FROZEN_REVERSAL = "tangential speed reverses"  # the words of the frozen-friction warning (paper.py knows it)
CHATTER_RATIO = THRESHOLD["CHATTER_RATIO"]  # flight shorter than this many contact times (as the machine)


def chattering(before, now) -> bool:
    """The flight between impacts `before` and `now` is shorter than CHATTER_RATIO times the
    contact of `before`: the impacts are becoming a chattering sequence."""
    return before.t_end is not None and now.t_start - before.t_end < CHATTER_RATIO * (before.t_end - before.t_start)


def chattering_warning(impacts) -> list[str]:
    """The chattering of one contact point's impacts (in time order)."""
    for k in range(len(impacts) - 1):
        a, b = impacts[k], impacts[k + 1]
        if chattering(a, b):
            return [f"chattering from impact {k + 1} on (t = {a.t_end:.4g} s): flights shorter than "
                    f"{CHATTER_RATIO:g} contact times; the tip is settling onto the surface, and "
                    "without a sustained-contact phase the later impacts are not resolved reliably"]
    return []


def chattering_by_point(impacts) -> list[str]:
    """`chattering_warning` of each contact point's own impacts, named by its point when the
    joints touch too (the impacts of two points overlap in time without chattering)."""
    points = list(dict.fromkeys(impact.point for impact in impacts))
    if points == ["tip"]:
        return chattering_warning(impacts)
    found = []
    for point in points:
        found += [f"{point}: {w}" for w in chattering_warning([i for i in impacts if i.point == point])]
    return found


class YieldScale(NamedTuple):
    """What the checks read of a run's contact constants (`laws.ContactConstants` has them
    too): the reduced radius R (m), the critical deformation delta_c (m) and the
    Jackson-Green exponent B."""

    R: float
    delta_c: float
    B: float


RESOLUTION_MARGIN = 100.0  # delta_max should exceed the tip's positional resolution this much
# The energy budget closes to ENERGY_MARGIN rtol of its largest term, or to ENERGY_FLOOR of it,
# whichever is looser: a bound for gross errors, since the works' global error grows with the
# run. Measured (the budget's residual over its largest term, in units of rtol): 0.004 to 9.4
# on the bundled scenes at rtol 1e-3 to 1e-10; on the stability catalogue's runs that pass
# its checks up to 3600 at rtol 1e-8 and 1.5e-7 of the largest term at rtol 1e-11 (5 s runs
# with sustained contact); 5.4e6 for the stiff friction of docs/stability.md under BDF at rtol 1e-8.
ENERGY_MARGIN = 1e5
ENERGY_FLOOR = 1e-6


def validity_warnings(scene: Scene, impacts, contact: Mapping[str, YieldScale] | None = None) -> list[str]:
    """One warning per kind of trouble, naming the impacts it concerns. Each impact is judged
    by the contact constants of its own point: `contact` has those the engine ran with, by
    point name ("tip", "joint k"; the C model derives them from the same expressions); the
    points it lacks are computed from the scene (which imports sympy). A sweep asks this of
    every case, mostly of one impact and nothing to say: that path calls nothing."""
    solver = scene.solver
    # with sustained contact the phase machine rests the point instead: the phases say so
    chatter = chattering_by_point(impacts) if len(impacts) > 1 and not (
        solver.t_end is not None and solver.sustained_contact) else []
    found: dict[str, list[tuple[int, str]]] = {}
    resolution = solver.rtol * sum(scene.chain.length)  # the angles carry rtol |q|
    for k, impact in enumerate(impacts, start=1):
        if 0 < impact.delta_max < RESOLUTION_MARGIN * resolution:
            found.setdefault("resolution", []).append(
                (k, f"{_at(impact)}delta_max = {impact.delta_max:.3g} m is within {RESOLUTION_MARGIN:g} times the "
                    f"position's resolution rtol * sum(L) = {resolution:.1g} m: the energy budget closes "
                    "only to about (resolution / delta_max)^2 of T0; tighten solver.rtol"))
    if impacts and scene.contact.model == "three-phase":
        for k, impact in enumerate(impacts, start=1):
            c = contact.get(impact.point) if contact else None
            if c is None:  # (laws' constants are cached by material and radius)
                c = point_constants(scene, impact.point)
            if not c.delta_c > 0:  # moduli beyond double precision's range: the run failed, and says why
                continue
            w = impact.delta_max / c.delta_c
            if impact.delta_max >= YIELD_ONSET * c.delta_c:
                a = contact_radius(impact.delta_max, c)
                if a >= c.R:
                    found.setdefault("radius", []).append(
                        (k, f"{_at(impact)}contact radius a = {a:.3g} m reaches the "
                            f"{'tip' if impact.point == 'tip' else 'joint'}'s radius {c.R:.3g} m; "
                            "Hertz and Jackson-Green assume a << R"))
            if w > JACKSON_GREEN_MAX_W:
                found.setdefault("range", []).append(
                    (k, f"{_at(impact)}delta_max = {w:.3g} delta_c, beyond the {JACKSON_GREEN_MAX_W:g} delta_c "
                        "that the Jackson-Green fits cover"))
            if 0 < w < 1:
                found.setdefault("elastic", []).append(
                    (k, f"{_at(impact)}the elastic limit was never reached (delta_max = {w:.3g} delta_c): "
                        "a purely Hertzian impact, delta_r = 0"))
    return _grouped(found, len(impacts)) + chatter if found else chatter


def issue_warnings(warnings: list[str], scene_name: str,
                   category: type[ImpactgenWarning] = ValidityWarning) -> None:
    """Issue a run's warnings (its `warnings`) through Python's warnings module, each naming
    the scene, attributed to the user's line that asked for the run."""
    for text in warnings:
        warn(f"{scene_name}: {text}", category)


def point_constants(scene: Scene, point: str) -> ContactConstants:
    """The contact constants of a contact point ("tip", "joint k"), with its own radius."""
    if point == "tip":
        return contact_constants(scene)
    return contact_constants(scene, scene.point_radius(point_number(point, scene.n)))


def _at(impact) -> str:
    """Where an impact was, as a warning's text begins: nothing for the tip."""
    return "" if impact.point == "tip" else f"at {impact.point}, "


def _grouped(found: dict[str, list[tuple[int, str]]], n_impacts: int) -> list[str]:
    warnings = []
    for items in found.values():
        first, text = items[0]
        if n_impacts == 1:
            warnings.append(f"the impact: {text}")
        elif len(items) == 1:
            warnings.append(f"impact {first}: {text}")
        else:
            warnings.append(f"{len(items)} of {n_impacts} impacts, from impact {first} on "
                            f"(first: {text})")
    return warnings


def frozen_friction_warning(scene: Scene, impacts, t, y) -> list[str]:
    """With contact.friction_mode = "frozen", a warning when the tip's tangential speed
    reverses within an impact (seen at the samples t, y: rows q, u, ...): the friction then
    pushes the tip along its motion and does positive work, which no physical friction does."""
    if scene.contact.friction_mode != "frozen" or scene.contact.friction == 0:
        return []
    n, dof, L = scene.n, scene.dof, np.asarray(scene.chain.length)
    reversed_at = []
    for k, impact in enumerate(impacts, start=1):
        i1 = impact.i_end if impact.i_end is not None else len(t) - 1
        links = point_number(impact.point, n)  # the point is the end of this many links
        rows = slice(impact.i_start, i1 + 1)
        q, u = y[rows, :links], y[rows, dof:dof + links]
        v_x = -(L[:links] * np.sin(q) * u).sum(axis=1)  # the point's tangential speed at each sample
        if scene.free:  # and the base point's, which it moves with
            v_x = v_x + y[rows, dof + n]
        start = np.sign(v_x[0])
        turned = np.nonzero(v_x * start < 0)[0] if start != 0 else []
        if len(turned):
            reversed_at.append((k, float(t[impact.i_start + turned[0]])))
    if not reversed_at:
        return []
    k, when = reversed_at[0]
    which = "the impact" if len(impacts) == 1 else f"{len(reversed_at)} of {len(impacts)} impacts (first: impact {k})"
    return [f"{which}: the {'tip' if impacts[k - 1].point == 'tip' else 'point'}'s {FROZEN_REVERSAL} (t = {when:.6g} s) while friction_mode = \"frozen\" "
            "keeps the friction's direction from contact start; from there on the friction does positive work, "
            "which is not physical (the mode reproduces the paper's published energy losses; "
            "\"regularized\" or \"coulomb\" is the physical law)"]


def energy_warning(scene: Scene, T0: float, Tf: float, W_normal: float, W_friction: float, W_gravity: float,
                   residual: float) -> list[str]:
    """A warning when the run's energy budget (its summary's) misses by more than
    ENERGY_MARGIN rtol of its largest term (ENERGY_FLOOR at least): the motion was not
    resolved."""
    scale = max(abs(T0), abs(Tf), abs(W_normal), abs(W_friction), abs(W_gravity))
    allowed = max(ENERGY_MARGIN * scene.solver.rtol, ENERGY_FLOOR) * scale
    if abs(residual) <= allowed:
        return []
    contact = scene.contact
    cause = (f"; a friction layer thinner than the steps (contact.friction_eps = {contact.friction_eps:g} m/s) "
             "is a common cause: friction_mode = \"coulomb\" is exact"
             if contact.friction > 0 and contact.friction_mode == "regularized" else "")
    return [f"the energy budget does not close: the works differ from the change of kinetic energy by "
            f"{residual:.3g} J, {abs(residual) / scale:.2g} of its largest term (at rtol = {scene.solver.rtol:g} "
            f"it should be below {allowed / scale:.2g}); the integration did not resolve the motion: tighten "
            f"solver.rtol and solver.atol{cause}"]
