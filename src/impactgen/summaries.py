"""The summaries of a result (MODEL section 6): the whole run's and its first impact's, with
their energy budgets, as dicts. Every contact point's impacts make them: the first impact is
the run's first at whichever point, with that point's own record and coefficients; the run's
record is over every point's impacts. The C engine tallies them during the run
(records.Tallied, read by `from_tally`); the reference engine's are computed from its samples
(`run_summary`, `first_impact_summary`), field for field the same.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from .codegen.spec import BASE_POINT, point_name, point_number
from .impacts import COEFFICIENT_UNITS, COEFFICIENTS, IMPACT_UNITS, Impact, first_of, switch_list
from .records import Tallied

if TYPE_CHECKING:  # (annotations only: results.py imports this module)
    from .results import SimulationResult, Trajectory

SUMMARY_LEADING = Tallied._fields[:9]  # T0 .. t_impact: the summary's first entries, in its order
SUMMARY_LATER = ("impacts", "point_impacts", "first_point", "t_sustained", "t_final")  # its entries after the final state
PER_POINT = ("point_impacts",)  # its entries by point name ({"joint 2": 30, "tip": 472}; point_impacts.tip in a table)
ENERGY_TERMS = ("W_normal", "W_friction", "W_gravity", "residual")  # its energy budget, as energy_balance
BUDGET = ("T0", "Tf", *ENERGY_TERMS)  # what energy_warning reads of a summary, in its order
# The unit of each number of a summary, by its key ("1": a count or a ratio): the summary
# dict's, and a sweep table's column of the same name (its energy.* and coefficients.* columns
# by the name after the dot, point_impacts.tip by point_impacts, u_final[i] by u_final). The
# impact's own values as IMPACT_UNITS.
SUMMARY_UNITS = {"T0": "J", "Tf": "J", "delta_T": "J",
                 **{name: IMPACT_UNITS[name] for name in ("delta_max", "delta_r", "P_max", "R_res")},
                 "t_contact": "s", "t_impact": "s", "u_final": "rad/s", "q_final": "rad", "impacts": "1",
                 "point_impacts": "1", "first_point": "1", "t_sustained": "s", "t_final": "s",
                 **{name: "J" for name in ENERGY_TERMS}, **COEFFICIENT_UNITS}


def summary_unit(name: str) -> str | None:
    """The unit of a summary's value or a sweep's column (`SUMMARY_UNITS`): "delta_r",
    "energy.W_normal", "coefficients.e_N", "point_impacts.tip", "u_final[2]"; None for a name it
    does not know."""
    head = name.partition(".")[0]
    key = head if head in PER_POINT else name.rpartition(".")[2].split("[", 1)[0]
    return SUMMARY_UNITS.get(key)


def energy_budget(traj: Trajectory, i0: int, i1: int) -> tuple[float, float, dict[str, float]]:
    """Kinetic energy at samples i0 and i1, and the energy budget between them."""
    T, V = traj.outputs["T"], traj.outputs["V"]
    T0, Tf, W_g = float(T[i0]), float(T[i1]), float(V[i0]) - float(V[i1])
    s0, s1 = traj.states_at(i0), traj.states_at(i1)
    return T0, Tf, energy_balance(T0, Tf, s1["W_normal"] - s0["W_normal"],
                                  s1.get("W_friction", 0.0) - s0.get("W_friction", 0.0), W_g)


def energy_balance(T0: float, Tf: float, W_n: float, W_f: float, W_g: float) -> dict[str, float]:
    """The works against the change of T from T0 to Tf, and what it leaves of them (residual)."""
    return {"W_normal": W_n, "W_friction": W_f, "W_gravity": W_g, "residual": (Tf - T0) - (W_n + W_f + W_g)}


def first_impact_summary(result: SimulationResult) -> dict[str, Any]:
    """The first impact as MODEL section 6 lists it (at whichever point), with its energy budget
    (the whole run when there was no impact). An impact the run ended in has t_contact 0."""
    impact = first_of(result.impacts, result.n)
    i0 = impact.i_start if impact else 0
    i1 = impact.i_end if impact and impact.i_end is not None else len(result.trajectory.t) - 1
    budget = None  # the impact's energies were read from the same two samples when the result was made
    if impact is not None:
        budget = (impact.T_before, impact.T_after, energy_balance(impact.T_before, impact.T_after, impact.W_normal,
                                                                  impact.W_friction, impact.W_gravity))
    return _summary(result, i0, i1, [impact] if impact else [], count_open=False, budget=budget)


def run_summary(result: SimulationResult) -> dict[str, Any]:
    """The whole run, from t = 0 to its last sample: the state it ends in and the energy
    budget over every impact of every point and every flight. Every impact starts from the
    undeformed surface in this model, so the deepest dent is the largest delta_r (not a sum);
    t_contact is the total time in contact of every impact, one the run ends in counted to the
    end."""
    return _summary(result, 0, len(result.trajectory.t) - 1, result.impacts, count_open=True)


def _summary(result: SimulationResult, i0: int, i1: int, impacts: list[Impact],
             count_open: bool, budget: tuple[float, float, dict[str, float]] | None = None) -> dict[str, Any]:
    """Samples i0 to i1 and the impacts in them; the switches and coefficients are the run's
    first impact's. `budget`: what `energy_budget` gives for the two samples, if already known."""
    traj, n, free = result.trajectory, result.n, result.given_scene.free
    T0, Tf, energy = energy_budget(traj, i0, i1) if budget is None else budget
    t_last = float(traj.t[i1])
    first = first_of(impacts, n)
    deepest = min(impacts, key=lambda impact: _dent_order(impact, n), default=None)
    contact = sum((i.t_end if i.t_end is not None else t_last) - i.t_start
                  for i in impacts if i.t_end is not None or count_open)
    sustained = _sustained_start(result.impacts)
    run_first = first_of(result.impacts, n)
    counts = [0] * (n + 1)
    for impact in result.impacts:
        counts[point_number(impact.point, n)] += 1
    tallied = Tallied(
        T0, Tf, T0 - Tf, max([i.delta_max for i in impacts], default=0.0), deepest.delta_r if deepest else 0.0,
        max([i.P_max for i in impacts], default=0.0), deepest.R_res if deepest else 0.0, float(contact),
        first.t_start if first else math.nan, math.nan if sustained is None else sustained, t_last,
        *(energy[name] for name in ENERGY_TERMS), len(first.switches) if first else 0,
        len(first.stick_slip) if first else 0, len(result.impacts), tuple(counts),
        point_number(run_first.point, n) if run_first else no_point(free),
        *(getattr(first, name) if first else math.nan for name in COEFFICIENTS), tuple(traj.y[i1].tolist()))
    return from_tally(tallied, n, impacts, free)


def no_point(free: bool) -> int:
    """first_point without an impact: 0, which a free chain's base point is; -1 for a free chain."""
    return -1 if free else 0


def chain_points(n: int, free: bool) -> range:
    """The numbers of an n-link chain's points that a summary counts impacts at, in point
    order: a free chain's base (0), the joints, the tip (n); a pinned chain's pivot is none."""
    return range(BASE_POINT if free else BASE_POINT + 1, n + 1)


def point_counts(counts: tuple[int, ...], n: int, free: bool) -> dict[str, int]:
    """Tallied.point_impacts (by point number) by point name, in point order (`chain_points`)."""
    return {point_name(k, n): counts[k] for k in chain_points(n, free)}


def from_tally(s: Tallied, n: int, impacts: list[Impact], free: bool = False) -> dict[str, Any]:
    """A summary dict (MODEL section 6) from its values (as the C engine tallies them, or as
    `_summary` computes them from the samples); the lists of the first impact's switches
    from its record. NaN (nothing to report) is None here. Its keys: SUMMARY_LEADING, the
    lists and the final state, SUMMARY_LATER, "energy" with ENERGY_TERMS (a test holds them).
    A free chain's final state (`free`) has its base point after the angles: u_final and
    q_final are the links' own."""
    first = first_of(impacts, n)  # the tally's first impact: the run's first, at whichever point
    dof = n + 2 if free else n
    (T0, Tf, delta_T, delta_max, delta_r, P_max, R_res, t_contact, t_impact, t_sustained, t_final,
     W_normal, W_friction, W_gravity, residual, _, _, count, counts, first_point, *coefficients, y) = s  # Tallied's fields
    return {"T0": T0, "Tf": Tf, "delta_T": delta_T, "delta_max": delta_max, "delta_r": delta_r,
            "P_max": P_max, "R_res": R_res, "t_contact": t_contact,
            "t_impact": None if t_impact != t_impact else t_impact,
            "switches": switch_list(first.switches) if first else [],
            "stick_slip": switch_list(first.stick_slip) if first and first.stick_slip else [],
            "u_final": list(y[dof: dof + n]), "q_final": list(y[:n]), "impacts": count,
            "point_impacts": point_counts(counts, n, free),
            "first_point": None if first_point == no_point(free) else first_point,
            "t_sustained": None if t_sustained != t_sustained else t_sustained, "t_final": t_final,
            "energy": {"W_normal": W_normal, "W_friction": W_friction, "W_gravity": W_gravity,
                       "residual": residual},
            "coefficients": {name: None if v != v else v for name, v in zip(COEFFICIENTS, coefficients)}}


def _dent_order(impact: Impact, n: int) -> tuple[float, float, int]:
    """The deepest dent first; of equal dents, the impact that began first, then in point order
    (as tally.c's fold_impact)."""
    return -impact.delta_r, impact.t_start, point_number(impact.point, n)


def _sustained_start(impacts: list[Impact]) -> float | None:
    """When the first point went into sustained contact (any point's switch into it)."""
    return min((t for impact in impacts for t, _, to in impact.switches if to == "sustained"), default=None)
