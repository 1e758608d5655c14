"""The text `impactgen run` prints: the first impact, the whole run, the impacts table."""
from __future__ import annotations

import math

from ..results import Impact, energy_balance, first_of


def one_line(text: str) -> str:
    """One printable line whatever a message holds: breaks become spaces, and other control
    characters (which str.splitlines may also take for line breaks) are escaped."""
    text = " ".join(text.splitlines())
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


IMPACT_ROWS_SHOWN = (5, 3)  # the per-impact table shows the first and the last few impacts
PHASES_SHOWN = 12  # the first impact's phases beyond these are left out (a long sustained contact)
US = 1e6  # the phases of an impact are given in microseconds from its start (a contact lasts about 0.5 ms)


def first_impact(result) -> Impact | None:
    """The run's first impact, of whichever contact point (the tip or a joint); None without one."""
    return first_of(result.impacts, result.n)


def _point_name(point: str) -> str:
    return "the tip" if point == "tip" else point


def _phase_line(result, impact: Impact | None) -> str:
    """The first impact's phases, from its own switch record (so a joint's too), times from its
    start in microseconds (absolute times in 4 figures would hide a contact of 0.5 ms)."""
    if impact is None:
        return "phases: " + ", ".join(f"{p.phase} [{p.t0:.9g}, {p.t1:.9g}] s" for p in result.phases[:12])
    spans, since, phase = [], impact.t_start, None
    for t, left, entered in impact.switches:
        if left != "free":
            spans.append(f"{left} {(since - impact.t_start) * US:.6g}-{(t - impact.t_start) * US:.6g}")
        since, phase = t, entered
    if impact.t_end is None:  # the run ended in this contact
        spans.append(f"{phase or 'elastic'} {(since - impact.t_start) * US:.6g}- (open)")
    number = result.impacts.index(impact) + 1
    return (f"phases of impact {number} (us from its start at t = {impact.t_start:.9g} s): "
            + ", ".join(spans[:PHASES_SHOWN]))


def _impacts_table(result) -> list[str]:
    """One row per impact (the first and the last few of a long run), named by its point and
    with the impacts table's column names (`impacts_frame`, the JSON's "impacts")."""
    head, tail = IMPACT_ROWS_SHOWN
    rows = list(enumerate(result.impacts, start=1))
    shown = rows if len(rows) <= head + tail + 1 else rows[:head] + [None] + rows[-tail:]
    lines = [f"{'impact':>6} {'point':>8} {'t_start (s)':>13} {'duration (us)':>14} {'delta_max (m)':>14} "
             f"{'delta_r (m)':>12} {'P_max (N)':>10} {'T_before (J)':>13} {'T_after (J)':>12}"]
    for row in shown:
        if row is None:
            lines.append(f"{'...':>6} ({len(rows) - head - tail} more)")
            continue
        k, i = row
        duration = f"{i.duration * US:14.6g}" if i.duration is not None else f"{'(open)':>14}"
        lines.append(f"{k:>6} {i.point:>8} {i.t_start:13.7g} {duration} {i.delta_max:14.4g} "
                     f"{i.delta_r:12.4g} {i.P_max:10.4g} {i.T_before:13.6g} {i.T_after:12.6g}")
    return lines


def _coefficient_lines(impact: Impact) -> list[str]:
    """The impact's coefficients of restitution and impulses (docs/impact-laws.md), once it ended."""
    c = impact.coefficients()
    if not math.isfinite(c["e_N"]):
        return []
    return [f"  restitution       e_N = {c['e_N']:.5f}, e_P = {c['e_P']:.5f}, e_E = {c['e_E']:.5f} "
            f"(v_n0 = {c['v_n0']:.4g} m/s; impactgen compare: the rigid-body laws)",
            f"  impulses          P_c = {c['P_c']:.5g} N s, P_r = {c['P_r']:.5g} N s, P_t = {c['P_t']:.5g} N s, "
            f"friction's share of the loss {c['friction_share']:.3f}"]


def _energy_line(e: dict) -> str:
    return (f"  energy budget     W_normal = {e['W_normal']:.4g} J, W_friction = {e['W_friction']:.4g} J, "
            f"W_gravity = {e['W_gravity']:.4g} J, residual = {e['residual']:.2g} J")


def _first_impact_lines(result, impact: Impact) -> list[str]:
    """The first impact, wherever it happened, from its own record: the values the JSON's
    "impacts"[k] holds, under the same names."""
    n = result.n
    i_end = impact.i_end if impact.i_end is not None else len(result.trajectory.t) - 1
    dof = result.given_scene.dof
    u_after = result.trajectory.y[i_end][dof:dof + n]
    duration = (f"{impact.duration:.6g} s" if impact.duration is not None
                else "(open: the run ended in contact)")
    energy = energy_balance(impact.T_before, impact.T_after, impact.W_normal, impact.W_friction, impact.W_gravity)
    lines = [
        f"first impact: {_point_name(impact.point)}, t_start = {impact.t_start:.9g} s",
        f"  max deformation   delta_max = {impact.delta_max:.6g} m",
        f"  permanent         delta_r   = {impact.delta_r:.6g} m",
        f"  max force         P_max     = {impact.P_max:.6g} N",
        f"  unloading radius  R_res     = {impact.R_res:.6g} m",
        f"  contact time      t_contact = {duration}",
        f"  kinetic energy    T0 = {impact.T_before:.6g} J, Tf = {impact.T_after:.6g} J, "
        f"delta_T = {impact.T_before - impact.T_after:.4g} J",
        _energy_line(energy),
        "  speeds after      u = [" + ", ".join(f"{v:.6g}" for v in u_after) + "] rad/s",
    ]
    lines += _coefficient_lines(impact)
    if impact.stick_slip:
        lines.append("  stick-slip        " + ", ".join(f"{a} -> {b} at {t:.9g} s" for t, a, b in impact.stick_slip))
    return lines


def format_summary(result) -> str:
    """The text `impactgen run` prints: the first impact (of whichever point), the whole run if
    it went on, and the impacts."""
    first = first_impact(result)
    lines = [f"{result.scene.name} ({result.engine} engine): {result.status}"
             + (f", {result.message}" if result.message else ""), _phase_line(result, first)]
    if first is not None:
        lines += _first_impact_lines(result, first)
    else:
        lines.append("no impact")
    run = result.summary
    if run is not result.first_impact:
        sustained = (f", sustained contact from t = {run['t_sustained']:.6g} s"
                     if run["t_sustained"] is not None else "")
        points = ", ".join(f"{count} at the {point}" if point in ("base", "tip") else f"{count} at {point}"
                           for point, count in run["point_impacts"].items() if count)
        struck = [count for count in run["point_impacts"].values() if count]
        joints = f" ({points})" if len(struck) > 1 else ""  # (a run whose impacts are all at one point: as before)
        lines += [
            f"whole run to t = {run['t_final']:.6g} s: {run['impacts']} impacts{joints}{sustained}",
            "  final angles      q = [" + ", ".join(f"{v:.6g}" for v in run["q_final"]) + "] rad",
            "  final speeds      u = [" + ", ".join(f"{v:.6g}" for v in run["u_final"]) + "] rad/s",
            f"  kinetic energy    T0 = {run['T0']:.6g} J, Tf = {run['Tf']:.6g} J",
            _energy_line(run["energy"]),
            f"  deepest dent      delta_r = {run['delta_r']:.6g} m, largest force P_max = {run['P_max']:.6g} N"
            + (" (of every point's impacts)" if joints else ""),
        ]
        if result.given_scene.free:  # where the base point ended, and how fast it went
            x, y, vx, vy = result.base[:, -1]
            lines.append(f"  base point        (x, y) = ({x:.6g}, {y:.6g}) m, (vx, vy) = ({vx:.6g}, {vy:.6g}) m/s")
    if result.impacts:
        lines += ["impacts:"] + ["  " + line for line in _impacts_table(result)]
    lines.append(f"solver            {result.stats.get('nsteps', 0)} steps, {result.stats.get('nfev', 0)} RHS "
                 f"calls, {result.stats.get('wall_s', 0.0) * 1e3:.2f} ms")
    return "\n".join(lines)
