"""The phase machine over points: how each point starts, the phase a point's event leads to,
what a switch fixes and records, and each point's stick-slip state under exact Coulomb
friction. The rules are a point's own; points interact only through the chain (and stuck
points, which are held together)."""
from __future__ import annotations

import math

import numpy as np

from .contact import Contact
from .events import FRICTION_EVENTS
from .model import ContactPoint, ReferenceModel
from .result import PointImpact, PointIntegrals

SLIP_NAMES = {1.0: "slip+", -1.0: "slip-", 0.0: "stick"}
TANGENTIAL = 1e-12  # a normal speed within this fraction of the point's speed is a tangential start
MOVING = 1e-12  # a contact begins slipping if its v_x exceeds this fraction of its speed, else as at a stop
STOPPED = 1e-9  # after a contact event, a slip whose v_x (along it) is within this fraction of the speed has stopped
CHATTER = 2.0  # a point's impacts chatter when the flight between them is shorter than this many contact times

# the phase each event leads to; "reentry" and "passes_delta_m" depend on the point (`after`)
TRANSITIONS = {("free", "contact"): "elastic", ("elastic", "yield"): "elastoplastic",
               ("elastic", "max_compression"): "restitution",
               ("elastoplastic", "max_compression"): "restitution",
               ("restitution", "separation"): "free", ("restitution", "force_zero"): "free",
               ("restitution", "reloading"): "reloading",
               ("reloading", "unloading"): "restitution", ("sustained", "lift_off"): "free"}


def normal_start(model: ReferenceModel, y: np.ndarray, point: ContactPoint, touch: float) -> tuple[bool, float]:
    """Whether a point touches the surface at the start (delta >= -`touch`), and its rate
    d(delta)/dt there: 0 for a tangential start, up to rounding."""
    delta, rate = model.delta_and_rate(y, point)
    _, _, v_x, v_y = model.kinematics(y, point)
    if abs(rate) <= TANGENTIAL * (abs(v_x) + abs(v_y)):
        rate = 0.0
    return delta >= -touch, rate


def after(phase: str, event: str, contact: Contact) -> str:
    """The phase a point in `phase` enters at `event`."""
    if (phase, event) == ("free", "reentry"):  # into its own dent (with one), else a new impact
        return "reloading" if contact.delta_r > 0 else "elastic"
    if (phase, event) in TRANSITIONS:
        return TRANSITIONS[(phase, event)]
    # reloading passed delta_m: back onto the loading curve it left
    return "elastoplastic" if contact.plastic and contact.delta_m >= contact.yield_depth else "elastic"


def segment_label(model: ReferenceModel) -> tuple[str, str]:
    """The phase and stick-slip state a segment is listed with: the points in contact, named,
    "joint 2: restitution, tip: elastic"; the tip's bare phase while no joint is in contact
    (as the single-point runs and the C engine list it)."""
    touching = model.touching()
    exact = model.contact.exact_coulomb  # the scene's friction mode: every point's
    if all(p is model.tip for p in touching):
        return model.tip.phase, (SLIP_NAMES[model.tip.contact.slip] if exact and touching else "")
    friction = ", ".join(f"{p.name}: {SLIP_NAMES[p.contact.slip]}" for p in touching) if exact else ""
    return ", ".join(f"{p.name}: {p.phase}" for p in touching), friction


# ----------------------------------------------------------------------------- stick and slip

def slip_at_stop(model: ReferenceModel, y: np.ndarray, phase: str, point: ContactPoint) -> float:
    """Stick if the force that holds the point still (the point in `phase`) lies strictly
    inside its cone, else slip against it."""
    a = next(a for a in model.contact_forces(y, {point.index: phase}, still=point) if a.point is point)
    hold = a.F_f
    return 0.0 if abs(hold) < point.contact.mu * a.F or hold == 0 else -math.copysign(1.0, hold)


def begin_slip(model: ReferenceModel, y: np.ndarray, point: ContactPoint) -> None:
    """A contact begins slipping the way the point moves (as at a stop if it does not); frozen
    friction keeps that direction to separation."""
    _, _, v_x, v_y = model.kinematics(y, point)
    point.contact.frozen_sign = float(np.sign(v_x))
    if not point.contact.exact_coulomb:
        return
    moving = abs(v_x) > MOVING * math.hypot(v_x, v_y)
    point.contact.slip = math.copysign(1.0, v_x) if moving else slip_at_stop(model, y, "elastic", point)


def check_slip_direction(model: ReferenceModel, y: np.ndarray, phase: str, t: float, point: ContactPoint) -> None:
    """After a contact event with no stick-slip event: a slip whose point (now in `phase`) has
    stopped, or moves the other way, is decided as at a stop (its event can coincide with the
    contact event: a single bar stops sliding exactly when it stops penetrating)."""
    c = point.contact
    if not c.exact_coulomb or c.slip == 0:
        return
    _, _, v_x, v_y = model.kinematics(y, point)
    if v_x * c.slip > STOPPED * math.hypot(v_x, v_y):
        return
    old, c.slip = c.slip, slip_at_stop(model, y, phase, point)
    if c.slip != old:
        point.impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))


def release_overloaded(model: ReferenceModel, y: np.ndarray, t: float) -> None:
    """Exact Coulomb with several points in contact: the stuck points are held together, so a
    switch of one point can push another's holding force out of its cone (two points of a
    nearly flat link hold it only by huge opposite forces). The point furthest out of its cone
    then slips against its force, and the rest are held again, until every stuck point holds.
    A point alone in contact is decided by its own events."""
    if len(model.touching()) < 2:
        return
    while True:
        over = [(abs(a.F_f) / (a.point.contact.mu * a.F) if a.F > 0 else math.inf, a)
                for a in model.contact_forces(y)
                if a.held and a.F_f != 0 and abs(a.F_f) >= a.point.contact.mu * a.F]
        if not over:
            return
        _, a = max(over, key=lambda item: item[0])
        c = a.point.contact
        old, c.slip = c.slip, -math.copysign(1.0, a.F_f)
        a.point.impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))


def _switch_slip(model: ReferenceModel, point: ContactPoint, event: str, t: float, y: np.ndarray) -> None:
    """A stick-slip event of a point: a stick ends against the side its force left the cone
    by; a slip that stops is decided as at a stop (pushed on only by rounding: stuck)."""
    c = point.contact
    old = c.slip
    if old == 0:
        c.slip = -1.0 if event == "slip_backward" else 1.0
    else:
        c.slip = slip_at_stop(model, y, point.phase, point)
        c.slip = 0.0 if c.slip == old else c.slip
    point.impact.stick_slip.append((t, SLIP_NAMES[old], SLIP_NAMES[c.slip]))


# ----------------------------------------------------------------------------- switches

def switch(model: ReferenceModel, point: ContactPoint, events: list[str], t: float, y: np.ndarray,
           sample: int, impacts: list[PointImpact], integrals: PointIntegrals) -> bool:
    """Apply the events of one point at time t (state y, sample index `sample`): its stick-slip
    switch, then its phase switch; a new impact at contact. True if it separated."""
    slipping = [e for e in events if e in FRICTION_EVENTS]
    if slipping:  # possibly at the same instant as a contact event (a single bar: u = 0)
        _switch_slip(model, point, slipping[0], t, y)
    events = [e for e in events if e not in FRICTION_EVENTS]
    if not events:
        return False
    phase, new = point.phase, after(point.phase, events[0], point.contact)
    if new != "free" and phase != "free" and not slipping:
        check_slip_direction(model, y, new, t, point)
    if phase == "free":
        begin_impact(model, point, new, t, y, sample, impacts, integrals)
        return False
    impact = point.impact
    if new == "restitution" and phase in ("elastic", "elastoplastic"):
        _at_maximum_compression(model, point, phase, y, sample, integrals)
    if new == "restitution" and model.sustained and comes_to_rest(model, point, phase, impacts, y):
        new = "sustained"
    impact.switches.append((t, phase, new))
    point.phase = new
    if new == "free":
        if phase == "sustained":  # the surface stays where the point lifted off it: its dent kept
            point.contact.y_s -= model.delta_and_rate(y, point)[0]
        end_impact(model, point, t, y, sample, integrals)
        return True
    return False


def comes_to_rest(model: ReferenceModel, point: ContactPoint, phase: str, impacts: list[PointImpact],
                  y: np.ndarray) -> bool:
    """Whether a point at a maximum compression (its normal speed 0) from `phase` is held on the
    surface (sustained contact) rather than unloading: if the hold would press it onto the
    surface, and it vibrates on the surface (its restitution turned back into reloading in this
    impact before it separated: a flight of length zero) or its impacts chatter (the flight
    before this impact was shorter than CHATTER times the contact before it). Either way it
    would bounce, or vibrate, for the rest of the run by ever smaller amounts that any damping
    removes; the elastic energy left in its dent stays in W_normal, a loss."""
    vibrating = any(switch[1:] == ("restitution", "reloading") for switch in point.impact.switches)
    own = [i for i in impacts if i.point == point.name]
    chattering = (phase in ("elastic", "elastoplastic") and len(own) > 1 and own[-2].t_end is not None
                  and own[-1].t_start - own[-2].t_end < CHATTER * (own[-2].t_end - own[-2].t_start))
    if phase == "restitution" or not (vibrating or chattering):
        return False
    a = next(a for a in model.contact_forces(y, {point.index: "sustained"}) if a.point is point)
    return a.F > 0


def begin_impact(model: ReferenceModel, point: ContactPoint, phase: str, t: float, y: np.ndarray, sample: int,
                 impacts: list[PointImpact], integrals: PointIntegrals) -> None:
    """A free point enters `phase`: a new impact, on the undeformed surface, or (reloading)
    back in its own dent along its restitution curve, with its delta_m, delta_r and R_res kept."""
    c = point.contact
    impact = point.impact = PointImpact(t_start=t, i_start=sample, point=point.name)
    if phase == "reloading":
        impact.delta_max, impact.P_max = c.delta_m, c.normal_force("reloading", c.delta_m)
        impact.delta_r, impact.R_res = c.delta_r, c.R_res
    else:
        c.reset()
    integrals.mark(impact, "begin", point)
    impact.own["v_n0"] = -model.delta_and_rate(y, point)[1]
    fix_impact_speed(model, y, point)
    impacts.append(impact)
    point.phase = phase
    begin_slip(model, y, point)


def fix_impact_speed(model: ReferenceModel, y: np.ndarray, point: ContactPoint) -> None:
    """A damped law scales its damping by the normal speed at the start of the impact; an
    impact that starts with none (resting, grazing) is undamped."""
    rate = model.delta_and_rate(y, point)[1]
    point.contact.v0 = rate if rate > 0 else math.inf


def _at_maximum_compression(model: ReferenceModel, point: ContactPoint, phase: str, y: np.ndarray, sample: int,
                            integrals: PointIntegrals) -> None:
    """Fix the point's delta_m, delta_r and R_res, and record them in its impact."""
    c, impact = point.contact, point.impact
    delta_m = model.delta_and_rate(y, point)[0]
    c.at_maximum_compression(delta_m, c.normal_force(phase, delta_m))
    impact.delta_max = delta_m
    impact.P_max = c.normal_force(phase, delta_m)
    impact.delta_r, impact.R_res = c.delta_r, c.R_res
    impact.i_max = sample
    integrals.mark(impact, "at_max", point)


def end_impact(model: ReferenceModel, point: ContactPoint, t: float | None, y: np.ndarray, sample: int | None,
               integrals: PointIntegrals) -> None:
    """A point's impact ends: at its separation (time t, sample `sample`), or, t None, where
    the run ends inside it. Its integrals and normal speed there close its own values."""
    impact = point.impact
    if t is not None:
        impact.t_end, impact.i_end = t, sample
        if point.contact.rate_law:  # a damped law lets go while the point penetrates: its set
            impact.delta_r = max(model.delta_and_rate(y, point)[0], 0.0)
    integrals.mark(impact, "end", point)
    impact.own["v_n1"] = -model.delta_and_rate(y, point)[1]
    point.impact = None
