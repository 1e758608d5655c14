"""Stage 7 of the pipeline: run the C phase machine on the C integrators' root finding.

The machine (native/model_machine.c, plain C written once for every model) decides everything of
MODEL section 4: which force law and which events with directions each machine state has,
and what each switch records (delta_max, P_max, delta_r, R_res, stick/slip, sustained contact,
lift-off, later impacts). Its loop runs in C (ig_run in the glue, through session.py): a
whole impact is one C call. This module turns what the loop recorded, the samples and the
switch records (one per point that switched, tally.h), into the result: one `Impact` per
impact of each point, the phase spans and the trajectory's phases (the tip's: the chain's
end), and the samples at `t_eval` or the dense output.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import Any, NamedTuple

import numpy as np

from .build import CompiledModel
from .codegen.spec import STATES, point_name
from .dense import DenseSolution, StepPolynomials, TimeSampler
from .errors import SolverError
from .model_params import fill_params
from .records import SwitchRecord, TallyRecords
from .results import Columns, Impact, PhaseSpan, Ready, SimulationResult, Trajectory
from .scene import Scene, Solver
from .session import EngineSession, Machine, MachineRun
from .validity import YieldScale

MAX_SEGMENTS = 100_000  # phase switches in one run: beyond this, stop rather than hang


def run(model: CompiledModel, scene: Scene, solver: Solver | None = None, t_eval: np.ndarray | None = None,
        dense_output: bool = False, record_steps: bool = True) -> SimulationResult:
    """Simulate `scene` under `solver` (default: the scene's own) with the compiled `model`
    from phase to phase.

    `t_eval` (sorted times) adds samples read from the integrator's interpolating polynomials;
    `dense_output` keeps those polynomials as `result.sol`. Without `record_steps` (and
    without either of those) the samples are only the start, each phase switch and the end:
    all the summaries need. A solver failure ends the run with status "failed" and the
    samples reached so far."""
    started = time.perf_counter()
    lib = model.lib
    if solver is None:
        solver = scene.solver
    params = fill_params(model, scene)
    session = EngineSession.open(model, solver)
    machine = session.phase_machine
    m = machine.state
    polynomials = dense_output or t_eval is not None
    session.keep_polynomials(polynomials)  # before begin: it may make new sample buffers
    start = session.begin(params, scene, solver)
    tip = m.point[machine.tip_index]
    tip_start = tip.state, tip.slip
    if start in (lib.MODEL_START_ALONG, lib.MODEL_START_AWAY):
        first_row, tallied = session.without_run()
        session.close()
        return _no_impact_at_start(scene, solver, model, session.y0.copy(), first_row.tolist(),
                                   start == lib.MODEL_START_ALONG, started, tallied)
    at_start = machine.in_contact()
    ran = session.run(params, solver.t_max if solver.t_end is None else solver.t_end, solver.atol, MAX_SEGMENTS,
                      every_step=record_steps or polynomials, with_params=t_eval is not None)
    impacts = _impacts(machine, ran.records, at_start)
    status, message = _status(lib, solver, machine, ran, impacts)
    reached_end = ran.flag == lib.IG_REACHED_END  # the last segment ended at the end time, not at a switch

    segments = partial(_segments, ran.records, machine.tip, *tip_start)
    trajectory = partial(_trajectory, ran, segments, session.output_index, model.state_names)
    sampler = TimeSampler(t_eval) if t_eval is not None else None
    sol = None
    if polynomials:
        pieces = _step_pieces(session, model, ran, segments(), params, sampler)
        if dense_output:
            sol = DenseSolution([0.0, *(float(p.t_ends[-1]) for p in pieces)], pieces, model.nstate)
    counters = session.counters()
    if status != "failed":  # a failed integrator is not handed to the next run
        session.close()
    stats = partial(_stats, session.stats_names, counters, segments, reached_end, len(ran.t),
                    time.perf_counter() - started)
    sampled = Trajectory(*sampler.gathered(model.nstate, model.output_names), model.state_names) if sampler else None
    contact = _yield_scales(model, params) if model.spec.contact_model == "three-phase" else None
    spans = partial(_spans, machine, model.event_names, segments, ran, reached_end)
    return SimulationResult(scene, "c", status, message, trajectory, spans, impacts, stats, sampled, sol, contact,
                            ran.summaries, solver)


def _yield_scales(model: CompiledModel, params) -> dict[str, YieldScale]:
    """Each contact point's constants, as the C model derived them, for the warnings."""
    numbers = (*model.spec.joints, model.spec.links)  # the records' order: the joints, then the tip
    return {point_name(number, model.spec.links): YieldScale(point.R, point.delta_c, params.B)
            for number, point in zip(numbers, params.point)}


class Segments(NamedTuple):
    """The run's segments as the tip went through them (the run's phases are the tip's: the
    chain's end), read from the switch records: segment j ends at switch j (ends[j]: the
    index of its first record) and the last one at the run's last sample."""

    ends: list[int]  # index in the records of each switch's first record
    cuts: list[int]  # sample 0, then each switch's: segment j from cuts[j] to cuts[j + 1] (the last to the last sample)
    states: list[int]  # the tip's machine state in each segment (the last: where the run stopped)
    slips: list[float]  # and its stick-slip state


def _segments(records: list[SwitchRecord], tip: int, state: int, slip: float) -> Segments:
    """The run's segments from its switch records (a switch's records share its sample),
    the tip beginning in (state, slip) and staying in what its last record went to."""
    ends, cuts, states, slips = [], [0], [], []
    sample = -1
    for j, rec in enumerate(records):
        if rec.sample != sample:  # a switch's first record
            sample = rec.sample
            ends.append(j)
            cuts.append(sample)
            states.append(state)
            slips.append(slip)
        if rec.point == tip:
            state, slip = rec.next_state, rec.next_slip
    return Segments(ends, cuts, states + [state], slips + [slip])


def _trajectory(ran: MachineRun, segments: Callable[[], Segments], output_index: dict[str, int],
                state_names: tuple[str, ...]) -> Trajectory:
    """The samples of a run (made when first asked for: a summary needs none)."""
    return Trajectory(ran.t, ran.y, _phase_labels(segments(), len(ran.t)), Columns(output_index, ran.outputs),
                      state_names)


def _phase_labels(segments: Segments, n_samples: int) -> np.ndarray:
    """The phase of the step that ended at each sample (the start: the state it began in)."""
    cuts = [*segments.cuts, n_samples - 1]
    states = [segments.states[0], *segments.states]
    return np.repeat(np.array([STATES[s] for s in states]), [1, *np.diff(cuts)])


def _impacts(machine: Machine, records: list[SwitchRecord], at_start: list[str]) -> list[Impact]:
    """Every point's impacts, from its switch records, in the order they began (at one time in
    point order, as the records come); `at_start`: the points in contact from the start."""
    impacts = [Impact(0.0, 0, point=name) for name in at_start]
    latest = {impact.point: impact for impact in impacts}  # each point's impact going on (or last)
    names, label, free = machine.names, machine.slip_label, machine.free
    BEGIN, SLIP, MAX_COMPRESSION, END = machine.acts
    # each record unpacked in SwitchRecord's field order (a field read by name costs a descriptor call)
    for t, sample, state, slip, _, act, next_state, next_slip, delta_max, P_max, delta_r, R_res, point in records:
        name = names[point]
        if act & BEGIN:
            impact = latest[name] = Impact(t, sample, point=name)
            impacts.append(impact)
        else:
            impact = latest.get(name)
            if impact is None:  # a flight before the point's first impact
                continue
        if act & SLIP:
            impact.stick_slip.append((t, label(state, slip), label(next_state, next_slip)))
        if act & MAX_COMPRESSION:
            impact.delta_max, impact.P_max, impact.delta_r, impact.R_res = delta_max, P_max, delta_r, R_res
            impact.i_max = sample
        if state != free and next_state != state:
            impact.switches.append((t, STATES[state], STATES[next_state]))
        if act & END:
            impact.t_end, impact.i_end = t, sample
            if machine.rate_law:
                impact.delta_r = delta_r
    return impacts


def _spans(machine: Machine, event_names: tuple[str, ...], segments: Callable[[], Segments], ran: MachineRun,
           reached_end: bool) -> list[PhaseSpan]:
    """The phase spans, one per segment (a failed run's last segment has none): made when first
    asked for (a summary needs none)."""
    seg, label, records = segments(), machine.slip_label, ran.records
    ends = [(records[j].t, event_names[records[j].event] if records[j].event >= 0 else "t_end") for j in seg.ends]
    if reached_end:
        ends.append((ran.t_last, "t_end"))
    spans, t0 = [], 0.0
    for (t1, event), state, slip in zip(ends, seg.states, seg.slips):
        spans.append(PhaseSpan(STATES[state], t0, t1, event, label(state, slip)))
        t0 = t1
    return spans


def _stats(names: tuple[str, ...], counters: tuple[int, ...], segments: Callable[[], Segments], reached_end: bool,
           samples: int, wall_s: float) -> dict[str, Any]:
    """The integrator's counters by name, then the run's segments (those a switch ended, and
    one that reached the end time), samples and wall time (made when first asked for)."""
    ended = len(segments().ends) + reached_end
    return {**dict(zip(names, counters)), "segments": ended, "samples": samples, "wall_s": wall_s}


def _status(lib, solver: Solver, machine: Machine, ran: MachineRun, impacts: list[Impact]) -> tuple[str, str]:
    """Status and message of the run from how ig_run returned."""
    if ran.flag == lib.IG_RUN_DONE:
        return "ok", ""
    if ran.flag == lib.IG_REACHED_END:
        return _end_without_event(solver, impacts, machine.phase_now())
    message = ran.message
    if ran.flag == lib.IG_ERR_SEGMENTS:
        message = f"more than {MAX_SEGMENTS} phase switches (chattering impacts?); shorten solver.t_end"
    return "failed", str(SolverError(message, machine.phase_now(), ran.t_last))


def _step_pieces(session: EngineSession, model: CompiledModel, ran: MachineRun, segments: Segments, params,
                 sampler: TimeSampler | None) -> list[StepPolynomials]:
    """Each segment's step polynomials (a failed segment's last), and its samples at t_eval
    read with the parameters it ran under."""
    pieces = []
    cuts = [*segments.cuts, len(ran.t) - 1]
    for j, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        if b == a:
            continue
        piece = StepPolynomials(ran.t[a + 1:b + 1], ran.dense[a + 1:b + 1])
        pieces.append(piece)
        if sampler is not None:
            seg_params = ran.record_params[segments.ends[j]] if j < len(segments.ends) else params
            sampler.segment(float(ran.t[b]), piece, _outputs_at(session, model, seg_params),
                            STATES[segments.states[j]])
    return pieces


def _outputs_at(session: EngineSession, model: CompiledModel, params):
    """The outputs at interpolated samples, under the parameters of their segment."""
    return lambda t, y: dict(zip(model.output_names, session.outputs(params, t, y).T))


def _end_without_event(solver: Solver, impacts: list[Impact], phase: str) -> tuple[str, str]:
    """Status and message of a run that reached its end time rather than an event."""
    if solver.t_end is not None:
        return "ok", ""
    if not impacts:
        return "no-impact", f"no contact within solver.t_max = {solver.t_max:g} s"
    return "ok", (f"no separation within solver.t_max = {solver.t_max:g} s: the chain came to "
                  f"rest on the surface (phase {phase!r}); the summary's impact has no end")


def _no_impact_at_start(scene: Scene, solver: Solver, model: CompiledModel, y: np.ndarray, first: list[float],
                        along: bool, started: float, tallied: TallyRecords) -> SimulationResult:
    rate0 = 0.0 if along else first[model.output_names.index("delta_rate")]
    motion = "along" if along else "away from"
    trajectory = Trajectory(np.array([0.0]), y[None, :], np.array(["free"]),
                            {name: np.array([v]) for name, v in zip(model.output_names, first)}, model.state_names)
    return SimulationResult(scene, "c", "no-impact",
                            f"the tip touches the surface but moves {motion} it (d(delta)/dt = "
                            f"{rate0:.3g} m/s): no impact", Ready(trajectory), Ready([]), [],
                            Ready({"segments": 0, "samples": 1, "wall_s": time.perf_counter() - started}),
                            tallied=tallied, solver=solver)
