"""The text `impactgen run` prints: the first impact, the whole run, the impacts table."""
from __future__ import annotations

import math

def one_line(text: str) -> str:
    """One printable line whatever a message holds: breaks become spaces, and other control
    characters (which str.splitlines may also take for line breaks) are escaped."""
    text = " ".join(text.splitlines())
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


IMPACT_ROWS_SHOWN = (5, 3)  # the per-impact table shows the first and the last few impacts


def _phase_line(result) -> str:
    """The first impact's phases, times from its start in microseconds (a contact lasts
    about 0.5 ms: absolute times in 4 figures would hide it)."""
    tips = [impact for impact in result.impacts if impact.point == "tip"]
    if not tips:
        return "phases: " + ", ".join(f"{p.phase} [{p.t0:.9g}, {p.t1:.9g}] s" for p in result.phases[:12])
    impact = tips[0]
    end = impact.t_end if impact.t_end is not None else math.inf
    spans = [p for p in result.phases if p.phase != "free" and impact.t_start <= p.t0 <= end][:12]
    us = 1e6
    text = ", ".join(f"{p.phase}{' (' + p.slip_state + ')' if p.slip_state else ''} "
                     f"{(p.t0 - impact.t_start) * us:.6g}-{(p.t1 - impact.t_start) * us:.6g}"
                     for p in spans)
    return f"phases of impact 1 (us from its start at t = {impact.t_start:.9g} s): {text}"


def _impacts_table(result) -> list[str]:
    head, tail = IMPACT_ROWS_SHOWN
    rows = list(enumerate(result.impacts, start=1))
    shown = rows if len(rows) <= head + tail + 1 else rows[:head] + [None] + rows[-tail:]
    points = any(i.point != "tip" for i in result.impacts)  # several contact points: say whose
    lines = [f"{'impact':>6}{format('point', '>9') if points else ''} {'t_start (s)':>13} {'duration (us)':>14} "
             f"{'delta_max (m)':>14} {'delta_r (m)':>12} {'P_max (N)':>10} {'T before (J)':>13} {'T after (J)':>12}"]
    for row in shown:
        if row is None:
            lines.append(f"{'...':>6} ({len(rows) - head - tail} more)")
            continue
        k, i = row
        duration = f"{i.duration * 1e6:14.6g}" if i.duration is not None else f"{'(open)':>14}"
        lines.append(f"{k:>6}{f' {i.point:>8}' if points else ''} {i.t_start:13.7g} {duration} {i.delta_max:14.4g} "
                     f"{i.delta_r:12.4g} {i.P_max:10.4g} {i.T_before:13.6g} {i.T_after:12.6g}")
    return lines


def _coefficient_lines(c: dict) -> list[str]:
    """The impact's coefficients of restitution and impulses (docs/impact-laws.md), once it ended."""
    if c["e_N"] is None:
        return []
    return [f"  restitution       e_N = {c['e_N']:.5f}, e_P = {c['e_P']:.5f}, e_E = {c['e_E']:.5f} "
            f"(v_n0 = {c['v_n0']:.4g} m/s; impactgen compare: the rigid-body laws)",
            f"  impulses          P_c = {c['P_c']:.5g} N s, P_r = {c['P_r']:.5g} N s, P_t = {c['P_t']:.5g} N s, "
            f"friction's share of the loss {c['friction_share']:.3f}"]


def format_summary(result) -> str:
    """The text `impactgen run` prints: the first impact, then the whole run if it went on."""
    first, run = result.first_impact, result.summary
    lines = [f"{result.scene.name} ({result.engine} engine): {result.status}"
             + (f", {result.message}" if result.message else ""), _phase_line(result)]
    if result.impacts:
        s = first
        e = s["energy"]
        lines += [
            "first impact:",
            f"  max deformation   delta_m = {s['delta_max']:.6g} m",
            f"  permanent         delta_r = {s['delta_r']:.6g} m",
            f"  max force         P_m     = {s['P_max']:.6g} N",
            f"  unloading radius  R_res   = {s['R_res']:.6g} m",
            f"  impact duration           = {s['t_contact']:.6g} s",
            f"  kinetic energy    T0 = {s['T0']:.6g} J, Tf = {s['Tf']:.6g} J, Delta T = {s['delta_T']:.4g} J",
            f"  energy budget     W_normal = {e['W_normal']:.4g} J, W_friction = {e['W_friction']:.4g} J, "
            f"W_gravity = {e['W_gravity']:.4g} J, residual = {e['residual']:.2g} J",
            "  speeds after      u = [" + ", ".join(f"{v:.6g}" for v in s["u_final"]) + "] rad/s",
        ]
        lines += _coefficient_lines(s["coefficients"])
        if s["stick_slip"]:
            lines.append("  stick-slip        " + ", ".join(f"{w['from']} -> {w['to']} at {w['t']:.9g} s"
                                                         for w in s["stick_slip"]))
    if run is not first:
        e = run["energy"]
        sustained = (f", sustained contact from t = {run['t_sustained']:.6g} s"
                     if run["t_sustained"] is not None else "")
        joints = f" at the tip, {run['joint_impacts']} at the joints" if run["joint_impacts"] else ""
        lines += [
            f"whole run to t = {run['t_final']:.6g} s: {run['impacts']} impacts{joints}{sustained}",
            "  final angles      q = [" + ", ".join(f"{v:.6g}" for v in run["q_final"]) + "] rad",
            "  final speeds      u = [" + ", ".join(f"{v:.6g}" for v in run["u_final"]) + "] rad/s",
            f"  kinetic energy    T(0) = {run['T0']:.6g} J, T(end) = {run['Tf']:.6g} J",
            f"  energy budget     W_normal = {e['W_normal']:.4g} J, W_friction = {e['W_friction']:.4g} J, "
            f"W_gravity = {e['W_gravity']:.4g} J, residual = {e['residual']:.2g} J",
            f"  deepest dent      delta_r = {run['delta_r']:.6g} m, largest force P_m = {run['P_max']:.6g} N",
        ]
    if len(result.impacts) > 1:
        lines += ["impacts:"] + ["  " + line for line in _impacts_table(result)]
    lines.append(f"solver            {result.stats.get('nsteps', 0)} steps, {result.stats.get('nfev', 0)} RHS "
                 f"calls, {result.stats.get('wall_s', 0.0) * 1e3:.2f} ms")
    return "\n".join(lines)
