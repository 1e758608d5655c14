"""The root functions of a segment: each point's contact events in its phase and, under exact
Coulomb friction, its stick-slip events; and the names they carry."""
from __future__ import annotations

from typing import Callable

import numpy as np

from .model import ContactPoint, ReferenceModel

Event = Callable[[float, np.ndarray], float]  # with the attributes solve_ivp reads: terminal, direction

FRICTION_EVENTS = ("slip_stops", "slip_backward", "slip_forward")
POINT_SEPARATOR = ": "  # a joint's event is named "joint k: <event>"


def event_name(point: ContactPoint, event: str) -> str:
    """The name an event of `point` carries (`PhaseSpan.ended_by`): "joint k: <event>", and
    the bare event for the tip (as the C engine names them)."""
    return event if point.name == "tip" else f"{point.name}{POINT_SEPARATOR}{event}"


def split_event(model: ReferenceModel, name: str) -> tuple[ContactPoint, str]:
    """The point and the event of an event's name."""
    event = name.rpartition(POINT_SEPARATOR)[2]
    return next(p for p in model.points if event_name(p, event) == name), event


def terminal(fn: Event, direction: int) -> Event:
    """A terminal solve_ivp event that fires only on crossings in `direction`."""
    def event(t: float, y: np.ndarray) -> float:
        return fn(t, y)
    event.terminal = True  # type: ignore[attr-defined]
    event.direction = direction  # type: ignore[attr-defined]
    return event


def segment_events(model: ReferenceModel, y: np.ndarray) -> dict[str, Event]:
    """The events of every point, by name, for a segment that begins at state `y`: point n's
    first, then the joints', then a free chain's base (the C engine's order for the first two,
    so that simultaneous roots resolve alike)."""
    events = {}
    for point in (model.tip, *model.joints, *([model.base] if model.base else [])):
        start = model.delta_and_rate(y, point)[0] if point.phase == "free" else 0.0
        own = {**contact_events(model, point, start), **friction_events(model, point)}
        events.update({event_name(point, name): event for name, event in own.items()})
    return events


def contact_events(model: ReferenceModel, point: ContactPoint, start: float = 0.0) -> dict[str, Event]:
    """The events of one point in its phase; `start`: its penetration where a free segment begins."""
    c = point.contact
    delta = lambda t, y: model.delta_and_rate(y, point)[0]  # noqa: E731
    rate = lambda t, y: model.delta_and_rate(y, point)[1]  # noqa: E731
    phase = point.phase
    if phase == "free":
        # A point that separated is still at delta_r (or a rounding inside 0): were it to turn
        # back before leaving the surface, delta rising through 0 would never fire. "reentry"
        # fires where it comes back to where it separated, its dent's bottom; having left the
        # surface, it meets "contact" first (the earlier root of the two).
        entry = max(c.delta_r, start)
        if entry > 0:
            return {"contact": terminal(delta, 1), "reentry": terminal(lambda t, y: delta(t, y) - entry, 1)}
        return {"contact": terminal(delta, 1)}
    if phase == "elastic":
        events = {"max_compression": terminal(rate, -1)}
        if c.plastic:
            events["yield"] = terminal(lambda t, y: delta(t, y) - c.yield_depth, 1)
        return events
    if phase == "elastoplastic":
        return {"max_compression": terminal(rate, -1)}
    if phase == "restitution":
        events = {"separation": terminal(lambda t, y: delta(t, y) - c.delta_r, -1), "reloading": terminal(rate, 1)}
        if c.rate_law:  # a damped force falls to 0 while the point still penetrates
            events["force_zero"] = terminal(lambda t, y: c.force_sign(*model.delta_and_rate(y, point)), -1)
        return events
    if phase == "sustained":  # resting: lifts off where the force that holds it falls to 0
        return {"lift_off": terminal(lambda t, y: next(a.F for a in model.contact_forces(y) if a.point is point), -1)}
    # reloading
    return {"unloading": terminal(rate, -1),
            "passes_delta_m": terminal(lambda t, y: delta(t, y) - c.delta_m, 1)}


def friction_events(model: ReferenceModel, point: ContactPoint) -> dict[str, Event]:
    """Exact Coulomb: a slip ends when the point's v_x returns to 0, a stick when the holding
    force leaves the cone |F_f| <= mu F."""
    c = point.contact
    if not c.exact_coulomb or point.phase == "free":
        return {}
    if c.slip != 0:
        return {"slip_stops": terminal(lambda t, y: model.kinematics(y, point)[2], -int(c.slip))}

    def cone(side: float) -> Event:
        def gap(t: float, y: np.ndarray) -> float:
            a = next(a for a in model.contact_forces(y) if a.point is point)
            return c.mu * a.F - side * a.F_f
        return gap
    return {"slip_backward": terminal(cone(+1.0), -1), "slip_forward": terminal(cone(-1.0), -1)}
