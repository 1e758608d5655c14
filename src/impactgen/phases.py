"""Stage 7 of the pipeline: run the generated C phase machine on the C integrators' root finding.

The machine (model_machine.c, printed from templates/machine.c.j2) decides everything of
MODEL section 4: which force law and which events with directions each machine state has,
and what each switch records (delta_m, P_m, delta_r, R_res, stick/slip, sustained contact,
lift-off, later impacts). Its loop runs in C (ig_run in the glue, through session.py): a
whole impact is one C call. This module turns what the loop recorded, the samples and one
record per phase segment, into the result: the phase spans, one `Impact` per impact, the
trajectory, and the samples at `t_eval` or the dense output.
"""
from __future__ import annotations

import time
from functools import partial
from typing import Any

import numpy as np

from .build import CompiledModel
from .codegen.spec import STATES
from .dense import DenseSolution, StepPolynomials, TimeSampler
from .errors import SolverError
from .model_params import fill_params
from .results import (Columns, Impact, PhaseSpan, Ready, SimulationResult, TallyRecords, Trajectory,
                      point_name, point_number)
from .scene import Scene, Solver
from .session import EngineSession, Machine, MachineRun, Segment
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
    tip = m.point[lib.MODEL_TIP_POINT]
    state0 = tip.state
    if start in (lib.MODEL_START_ALONG, lib.MODEL_START_AWAY):
        first_row, tallied = session.without_run()
        session.close()
        return _no_impact_at_start(scene, solver, model, session.y0.copy(), first_row.tolist(),
                                   start == lib.MODEL_START_ALONG, started, tallied)
    in_contact = start == lib.MODEL_START_CONTACT
    joints_at_start = [model.lib.model_joint_number(k) for k in range(len(model.spec.joints))
                       if m.point[k].state != machine.free] if model.spec.joints else []
    ran = session.run(params, solver.t_max if solver.t_end is None else solver.t_end, solver.atol, MAX_SEGMENTS,
                      every_step=record_steps or polynomials, with_params=t_eval is not None)
    impacts = _impacts(machine, ran.segments, in_contact)
    if model.spec.joints:
        n = model.spec.links  # in time order; at one time, joints first (as the floor net numbers the points)
        impacts = sorted(impacts + _joint_impacts(machine, ran.joint_records, joints_at_start, n),
                         key=lambda impact: (impact.t_start, point_number(impact.point, n)))
    status, message = _status(lib, solver, machine, ran, impacts)

    trajectory = partial(_trajectory, ran, state0, tip.state, session.output_index, model.state_names)
    sampler = TimeSampler(t_eval) if t_eval is not None else None
    sol = None
    if polynomials:
        pieces = _step_pieces(session, model, ran, *_runs(ran.segments, len(ran.t), state0, tip.state), params, sampler)
        if dense_output:
            sol = DenseSolution([0.0, *(float(p.t_ends[-1]) for p in pieces)], pieces, model.nstate)
    counters = session.counters()
    if status != "failed":  # a failed integrator is not handed to the next run
        session.close()
    stats = partial(_stats, session.stats_names, counters, len(ran.segments), len(ran.t), time.perf_counter() - started)
    sampled = Trajectory(*sampler.gathered(model.nstate, model.output_names), model.state_names) if sampler else None
    contact = _yield_scales(model, params) if model.spec.plastic else None
    spans = partial(_spans, machine, model.event_names, ran.segments)
    return SimulationResult(scene, "c", status, message, trajectory, spans, impacts, stats, sampled, sol, contact,
                            ran.summaries, solver)


def _yield_scales(model: CompiledModel, params) -> dict[str, YieldScale]:
    """Each contact point's constants, as the C model derived them, for the warnings."""
    numbers = (*model.spec.joints, model.spec.links)  # the records' order: the joints, then the tip
    return {point_name(number, model.spec.links): YieldScale(point.R, point.delta_c, params.B)
            for number, point in zip(numbers, params.point)}


def _trajectory(ran: MachineRun, state0: int, state_end: int, output_index: dict[str, int],
                state_names: tuple[str, ...]) -> Trajectory:
    """The samples of a run (made when first asked for: a summary needs none)."""
    return Trajectory(ran.t, ran.y, _phase_labels(ran.segments, len(ran.t), state0, state_end),
                      Columns(output_index, ran.outputs), state_names)


def _runs(segments: list[Segment], n_samples: int, state0: int, state_end: int) -> tuple[list[int], list[int]]:
    """The samples as runs of one machine state: the start, then each segment's (after
    sample cuts[j] to sample cuts[j + 1]; a failed segment's rows last), in states[j + 1]."""
    cuts = [0, *(seg.sample for seg in segments), n_samples - 1]
    return cuts, [state0, *(seg.state for seg in segments), state_end]


def _phase_labels(segments: list[Segment], n_samples: int, state0: int, state_end: int) -> np.ndarray:
    """The phase of the step that ended at each sample (the start: the state it began in)."""
    cuts, states = _runs(segments, n_samples, state0, state_end)
    return np.repeat(np.array([STATES[s] for s in states]), [1, *np.diff(cuts)])


def _impacts(machine: Machine, segments: list[Segment], contact_at_start: bool) -> list[Impact]:
    """The impacts, from the machine's record of each segment's end."""
    impacts = [Impact(0.0, 0)] if contact_at_start else []
    label, free = machine.slip_label, machine.free
    BEGIN, SLIP, MAX_COMPRESSION, END = machine.acts
    # each record unpacked in Segment's field order (a field read by name costs a descriptor call)
    for t, sample, state, slip, _, act, next_state, next_slip, delta_max, P_max, delta_r, R_res, _point in segments:
        if act & BEGIN:
            impacts.append(Impact(t, sample))
        if not impacts:  # a flight before the first impact
            continue
        impact = impacts[-1]
        if act & SLIP:
            impact.stick_slip.append((t, label(state, slip), label(next_state, next_slip)))
        if act & MAX_COMPRESSION:
            impact.delta_max, impact.P_max, impact.delta_r, impact.R_res = delta_max, P_max, delta_r, R_res
            impact.i_max = sample
        if state != free and next_state != state:
            impact.switches.append((t, STATES[state], STATES[next_state]))
        if act & END:
            impact.t_end, impact.i_end = t, sample
    return impacts


def _joint_impacts(machine: Machine, records: list[Segment], at_start: list[int], n: int) -> list[Impact]:
    """The joints' impacts, from the records of their switches (`_impacts` per joint)."""
    impacts = []
    for joint in sorted({seg.point for seg in records} | set(at_start)):
        mine = _impacts(machine, [seg for seg in records if seg.point == joint], joint in at_start)
        for impact in mine:
            impact.point = point_name(joint, n)
        impacts += mine
    return impacts


def _spans(machine: Machine, event_names: tuple[str, ...], segments: list[Segment]) -> list[PhaseSpan]:
    """The phase spans, one per segment: made when first asked for (a summary needs none)."""
    spans, t0, label = [], 0.0, machine.slip_label
    for seg in segments:
        event = event_names[seg.event] if seg.event >= 0 else "t_end"
        spans.append(PhaseSpan(STATES[seg.state], t0, seg.t, event, label(seg.state, seg.slip)))
        t0 = seg.t
    return spans


def _stats(names: tuple[str, ...], counters: tuple[int, ...], segments: int, samples: int,
           wall_s: float) -> dict[str, Any]:
    """The integrator's counters by name, then the run's segments, samples and wall time (made
    when first asked for)."""
    return {**dict(zip(names, counters)), "segments": segments, "samples": samples, "wall_s": wall_s}


def _status(lib, solver: Solver, machine: Machine, ran: MachineRun, impacts: list[Impact]) -> tuple[str, str]:
    """Status and message of the run from how ig_run returned."""
    if ran.flag == lib.IG_RUN_DONE:
        return "ok", ""
    if ran.flag == lib.IG_REACHED_END:
        return _end_without_event(solver, impacts, STATES[ran.segments[-1].state])
    message = ran.message
    if ran.flag == lib.IG_ERR_SEGMENTS:
        message = f"more than {MAX_SEGMENTS} phase switches (chattering impacts?); shorten solver.t_end"
    return "failed", str(SolverError(message, STATES[machine.state.point[lib.MODEL_TIP_POINT].state], ran.t_last))


def _step_pieces(session: EngineSession, model: CompiledModel, ran: MachineRun, cuts: list[int],
                 states: list[int], params, sampler: TimeSampler | None) -> list[StepPolynomials]:
    """Each segment's step polynomials (a failed segment's last), and its samples at t_eval
    read with the parameters it ran under."""
    pieces = []
    for j, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        if b == a:
            continue
        piece = StepPolynomials(ran.t[a + 1:b + 1], ran.dense[a + 1:b + 1])
        pieces.append(piece)
        if sampler is not None:
            seg_params = ran.segment_params[j] if j < len(ran.segments) else params
            sampler.segment(float(ran.t[b]), piece, _outputs_at(session, model, seg_params),
                            STATES[states[j + 1]])
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
    return "ok", (f"no separation within solver.t_max = {solver.t_max:g} s: the tip came to rest "
                  f"on the surface (phase {phase!r}); the summary's impact has no end")


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
