"""The records of a run's phases and impacts, as both engines fill them: one `PhaseSpan` per
phase segment, one `Impact` per impact of each contact point (with its impulses and
coefficients of restitution, `impact_coefficients`), and their units.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from .codegen.spec import point_number


@dataclass
class PhaseSpan:
    phase: str  # "free", "elastic", "elastoplastic", "restitution", "reloading", "sustained"
    t0: float
    t1: float
    ended_by: str  # the event that ended it, or "t_end"
    slip_state: str = ""  # exact Coulomb friction: "slip+", "slip-" or "stick" during the span

    def to_dict(self) -> dict[str, Any]:
        out = {"phase": self.phase, "t0": self.t0, "t1": self.t1, "ended_by": self.ended_by}
        if self.slip_state:
            out["slip_state"] = self.slip_state
        return out


@dataclass
class Impact:
    """One impact: from first contact to separation, with the values fixed at its switches
    (by the engine) and its energies (filled from the samples when the result is made)."""

    t_start: float
    i_start: int  # sample index at first contact
    t_end: float | None = None  # separation; None if the run ended in contact
    i_end: int | None = None
    delta_max: float = 0.0  # m, at maximum compression
    P_max: float = 0.0  # N, the normal force there
    delta_r: float = 0.0  # m, permanent deformation (Eq. 12)
    R_res: float = 0.0  # m, radius of the unloading curve
    switches: list[tuple[float, str, str]] = field(default_factory=list)  # (t, from, to)
    stick_slip: list[tuple[float, str, str]] = field(default_factory=list)  # exact Coulomb: (t, from, to)
    T_before: float = math.nan  # J, kinetic energy at first contact
    T_after: float = math.nan  # J, at separation (or the end of the run)
    W_normal: float = 0.0  # J, work of the normal force over the impact (of every point's: the energy budget's)
    W_friction: float = 0.0  # J
    W_gravity: float = 0.0  # J
    W_normal_point: float = math.nan  # J, work of this point's own normal force over the impact
    W_friction_point: float = math.nan  # J, of its own friction force
    i_max: int | None = None  # sample index at (the latest) maximum compression
    # impulses and coefficients of restitution (docs/model.md section 9; COEFFICIENTS), from
    # the samples at its start, maximum compression and end; NaN until it has ended
    v_n0: float = math.nan  # m/s, the point's normal speed at first contact (negative approaching)
    P_c: float = math.nan  # N s, normal impulse of compression
    P_r: float = math.nan  # N s, of restitution
    P_t: float = math.nan  # N s, tangential (friction) impulse
    e_N: float = math.nan  # kinematic (Newton): -v_n(end) / v_n0
    e_P: float = math.nan  # kinetic (Poisson): P_r / P_c
    e_E: float = math.nan  # energetic (Stronge): sqrt(W_r / -W_c)
    friction_share: float = math.nan  # W_friction / (W_normal + W_friction): friction's share of the loss
    point: str = "tip"  # the contact point: "tip", or "joint k" (the end of link k)

    @property
    def duration(self) -> float | None:
        return None if self.t_end is None else self.t_end - self.t_start

    def coefficients(self) -> dict[str, float]:
        """The impulses and coefficients of restitution (COEFFICIENTS) by name."""
        return {name: getattr(self, name) for name in COEFFICIENTS}

    def to_dict(self) -> dict[str, Any]:
        """One row of the impacts table (JSON and DataFrame)."""
        return {
            "point": self.point, "t_start": self.t_start, "t_end": self.t_end, "duration": self.duration,
            "delta_max": self.delta_max, "delta_r": self.delta_r, "P_max": self.P_max,
            "R_res": self.R_res, "T_before": self.T_before, "T_after": self.T_after,
            "W_normal": self.W_normal, "W_friction": self.W_friction, "W_gravity": self.W_gravity,
            "W_normal_point": self.W_normal_point, "W_friction_point": self.W_friction_point,
            **self.coefficients(),
            "switches": switch_list(self.switches), "stick_slip": switch_list(self.stick_slip),
        }


def first_of(impacts: list[Impact], n: int) -> Impact | None:
    """The run's first impact, at whichever point (of impacts that began together, the first in
    point order: the base, the joints by number, the tip, as the switch records come); None
    without an impact. `n`: the chain's links."""
    return min(impacts, key=lambda impact: (impact.t_start, point_number(impact.point, n)), default=None)


def switch_list(items: list[tuple[float, str, str]]) -> list[dict[str, Any]]:
    """(t, from, to) switches as the summaries and the impacts table write them."""
    return [{"t": t, "from": a, "to": b} for t, a, b in items]


# The impulses and coefficients of restitution of an impact (docs/model.md section 9), with units.
COEFFICIENT_UNITS = {"v_n0": "m/s", "P_c": "N s", "P_r": "N s", "P_t": "N s", "e_N": "1", "e_P": "1", "e_E": "1",
                     "friction_share": "1"}
COEFFICIENTS = tuple(COEFFICIENT_UNITS)
IMPACT_UNITS = {"point": "", "t_start": "s", "t_end": "s", "duration": "s", "delta_max": "m", "delta_r": "m",
                "P_max": "N", "R_res": "m", "T_before": "J", "T_after": "J", "W_normal": "J",
                "W_friction": "J", "W_gravity": "J", "W_normal_point": "J", "W_friction_point": "J",
                **COEFFICIENT_UNITS}


def impact_coefficients(begin, at_max, end, v_n0: float, v_n1: float) -> dict[str, float]:
    """The impulses and coefficients (COEFFICIENTS) of an impact from its integrated states
    (dicts by state name, `Trajectory.states_at`: the works and the impulses) at its start, at its maximum
    compression and at its end, and the normal speed at its start and end. The C engine
    tallies the same arithmetic (tally.c, summarize_coefficients)."""
    W_c, W_r = at_max["W_normal"] - begin["W_normal"], end["W_normal"] - at_max["W_normal"]
    W_f = end.get("W_friction", 0.0) - begin.get("W_friction", 0.0)
    P_c, P_r = at_max["P_normal"] - begin["P_normal"], end["P_normal"] - at_max["P_normal"]
    ratio = W_r / -W_c if W_c != 0 else math.nan
    return {"v_n0": v_n0, "P_c": P_c, "P_r": P_r, "P_t": end.get("P_friction", 0.0) - begin.get("P_friction", 0.0),
            "e_N": -v_n1 / v_n0 if v_n0 != 0 else math.nan, "e_P": P_r / P_c if P_c != 0 else math.nan,
            "e_E": math.sqrt(ratio) if ratio >= 0 else math.nan,
            "friction_share": W_f / (W_c + W_r + W_f) + 0.0 if W_c + W_r + W_f != 0 else math.nan}
