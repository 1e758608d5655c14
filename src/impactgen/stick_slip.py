"""Exact Coulomb friction (MODEL section 5): the stick-slip state kept beside the contact phase.

`slip` is +1 or -1 while the tip slips along +x or -x, so that F_f = -mu F slip, and 0 while it
sticks, when F_f is the constraint force that holds v_Bx at 0 (computed in the generated C).
Events end each state, as solve_ivp's terminal events with directions do:

    slip +1 --v_Bx falls to 0--> stick if the force needed to hold it is within mu F, else slip -1
    slip -1 --v_Bx rises to 0--> stick, or slip +1
    stick --F_f rises to +mu F--> slip -1        stick --F_f falls to -mu F--> slip +1

No regularization: the friction force jumps where Coulomb's law says it does, and the
integrator restarts there, so the stiffness of a steep regularized sign never appears.
"""
from __future__ import annotations

import math

RISING, FALLING = 1, -1

# Events (name, direction) that end each stick-slip state.
ENDS = {
    +1.0: (("slip_stops", FALLING),),
    -1.0: (("slip_stops", RISING),),
    0.0: (("slip_backward", FALLING), ("slip_forward", FALLING)),
}

LABEL = {+1.0: "slip+", -1.0: "slip-", 0.0: "stick"}
EVENTS = frozenset(name for ends in ENDS.values() for name, _ in ends)


def slip_when_stopped(F: float, F_hold: float, mu: float) -> float:
    """The state at v_Bx = 0: stick when the force F_hold that holds the tip is strictly within
    mu F (so the stick events start on their positive side); otherwise slip the way the tip
    is pushed, against F_hold."""
    if abs(F_hold) < mu * F:
        return 0.0
    return -math.copysign(1.0, F_hold) if F_hold != 0.0 else 0.0


def slip_at_contact(v_Bx: float, tip_speed: float, F: float, F_hold: float, mu: float) -> float:
    """The state when a contact begins: slipping the way the tip moves, or, for a tip that
    arrives with no tangential speed, as at a stop."""
    if abs(v_Bx) > 1e-12 * max(tip_speed, 1e-300):
        return math.copysign(1.0, v_Bx)
    return slip_when_stopped(F, F_hold, mu)


def slip_after(fired: list[str], slip: float, F: float, F_hold: float, mu: float) -> float:
    """The state after the stick-slip events `fired` ended state `slip`."""
    if slip == 0.0:
        return -1.0 if "slip_backward" in fired else +1.0
    new = slip_when_stopped(F, F_hold, mu)
    # At a stop the holding force lies within mu F or pushes the tip back the way it came;
    # a holding force pushing it on (possible only by rounding, |F_hold| ~ mu F) means stick.
    return 0.0 if new == slip else new
