"""Stage 7 of the pipeline: run the generated C phase machine against CVODE's root finder.

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

import numpy as np

from .build import CompiledModel
from .codegen.machine import STATES
from .dense import DenseSolution, StepPolynomials, TimeSampler
from .errors import SolverError
from .model_params import fill_params
from .results import Impact, PhaseSpan, SimulationResult, Trajectory
from .scene import Scene
from .session import CvodeSession, MachineRun, Segment

MAX_SEGMENTS = 100_000  # phase switches in one run: beyond this, stop rather than hang
SLIP_LABEL = {+1.0: "slip+", -1.0: "slip-", 0.0: "stick"}
STATE_NAMES = np.array(STATES)  # the phase label of each sample, by machine state


class Machine:
    """The C phase machine of one run, with the names the results use."""

    def __init__(self, model: CompiledModel, params):
        self.params, self.lib = params, model.lib
        self.state = model.ffi.new("model_machine *")
        self.atol_now = model.ffi.new("double[]", model.nstate)
        self.coulomb = model.spec.coulomb

    def slip_label(self, state: int, slip: float) -> str:
        """The stick-slip label of a contact state under exact Coulomb friction, else ""."""
        return SLIP_LABEL[slip] if self.coulomb and state != self.lib.MODEL_MACHINE_FREE else ""

    def atol(self, scene: Scene):
        self.lib.model_machine_atol(self.state, self.params, scene.solver.rtol, scene.solver.atol,
                                    self.atol_now)
        return self.atol_now


def run(model: CompiledModel, scene: Scene, t_eval: np.ndarray | None = None,
        dense_output: bool = False, record_steps: bool = True) -> SimulationResult:
    """Simulate `scene` with the compiled `model` from phase to phase.

    `t_eval` (sorted times) adds samples read from CVODE's interpolating polynomials;
    `dense_output` keeps those polynomials as `result.sol`. Without `record_steps` (and
    without either of those) the samples are only the start, each phase switch and the end:
    all the summaries need. A solver failure ends the run with status "failed" and the
    samples reached so far."""
    started = time.perf_counter()
    lib = model.lib
    params = fill_params(model, scene)
    machine = Machine(model, params)
    m = machine.state
    y = np.concatenate([scene.q0, scene.u0, np.zeros(model.nstate - 2 * scene.n)])
    run_to_time = scene.solver.t_end is not None
    start = lib.model_machine_start(m, params, 0.0, model.ffi.from_buffer("double[]", y), int(run_to_time))
    state0 = m.state
    session = CvodeSession.open(model, scene, machine.atol(scene))
    first_row = session.outputs(params, np.array([0.0]), y[None, :])
    if start in (lib.MODEL_START_ALONG, lib.MODEL_START_AWAY):
        session.close(scene)
        return _no_impact_at_start(scene, model, y, first_row[0].tolist(), start == lib.MODEL_START_ALONG,
                                   started)
    t_end = scene.solver.t_end if run_to_time else scene.solver.t_max
    polynomials = dense_output or t_eval is not None
    session.keep_polynomials(polynomials)
    ran = session.run(m, params, 0.0, y, t_end, scene.solver.atol, MAX_SEGMENTS,
                      every_step=record_steps or polynomials, with_params=t_eval is not None)
    spans, impacts = _spans_and_impacts(machine, model.event_names, ran.segments,
                                        start == lib.MODEL_START_CONTACT)
    status, message = _status(lib, scene, machine, ran, impacts)

    # the samples: the start, then what the run wrote, segment by segment (rows cuts[j] to
    # cuts[j + 1] of the run's; a failed segment's rows last), each labelled by its state
    cuts = [0, *(seg.sample + 1 for seg in ran.segments), len(ran.t)]
    states = [state0, *(seg.state for seg in ran.segments), m.state]
    trajectory = Trajectory(
        t=np.concatenate([[0.0], ran.t]), y=np.concatenate([y[None, :], ran.y]),
        phase=STATE_NAMES[np.repeat(states, [1, *(b - a for a, b in zip(cuts[:-1], cuts[1:]))])],
        outputs=dict(zip(model.output_names, np.concatenate([first_row, ran.outputs]).T)),
    )
    sampler = TimeSampler(t_eval) if t_eval is not None else None
    sol = None
    if polynomials:
        pieces = _step_pieces(session, model, ran, cuts, states, params, sampler)
        if dense_output:
            sol = DenseSolution([0.0, *(float(p.t_ends[-1]) for p in pieces)], pieces, model.nstate)
    stats = session.stats()
    if status != "failed":  # a failed integrator is not handed to the next run
        session.close(scene)
    stats.update(segments=len(spans), samples=len(trajectory.t), wall_s=time.perf_counter() - started)
    sampled = Trajectory(*sampler.gathered(model.nstate, model.output_names)) if sampler else None
    return SimulationResult(scene, "c", status, message, trajectory, spans, impacts, stats, sampled, sol)


def _spans_and_impacts(machine: Machine, event_names: tuple[str, ...], segments: list[Segment],
                       contact_at_start: bool) -> tuple[list[PhaseSpan], list[Impact]]:
    """The phase spans and the impacts, from the machine's record of each segment (sample
    indices count the start as sample 0)."""
    spans: list[PhaseSpan] = []
    impacts = [Impact(t_start=0.0, i_start=0)] if contact_at_start else []
    t0 = 0.0
    for seg in segments:
        phase, new_phase = STATES[seg.state], STATES[seg.next_state]
        slip = machine.slip_label(seg.state, seg.slip)
        spans.append(PhaseSpan(phase, t0, seg.t, event_names[seg.event] if seg.event >= 0 else "t_end", slip))
        t0, act, i = seg.t, seg.act, seg.sample + 1
        if act & machine.lib.MODEL_ACT_IMPACT_BEGIN:
            impacts.append(Impact(t_start=seg.t, i_start=i))
        impact = impacts[-1] if impacts else None
        if act & machine.lib.MODEL_ACT_SLIP:
            impact.stick_slip.append((seg.t, slip, machine.slip_label(seg.next_state, seg.next_slip)))
        if act & machine.lib.MODEL_ACT_MAX_COMPRESSION:
            impact.delta_max, impact.P_max, impact.delta_r, impact.R_res = (
                seg.delta_max, seg.P_max, seg.delta_r, seg.R_res)
        if impact is not None and phase != "free" and new_phase != phase:
            impact.switches.append((seg.t, phase, new_phase))
        if act & machine.lib.MODEL_ACT_IMPACT_END:
            impact.t_end, impact.i_end = seg.t, i
    return spans, impacts


def _status(lib, scene: Scene, machine: Machine, ran: MachineRun, impacts: list[Impact]) -> tuple[str, str]:
    """Status and message of the run from how ig_run returned."""
    if ran.flag == lib.IG_RUN_DONE:
        return "ok", ""
    if ran.flag == lib.IG_REACHED_END:
        return _end_without_event(scene, impacts, STATES[ran.segments[-1].state])
    message = ran.message
    if ran.flag == lib.IG_ERR_SEGMENTS:
        message = f"more than {MAX_SEGMENTS} phase switches (chattering impacts?); shorten solver.t_end"
    return "failed", str(SolverError(message, STATES[machine.state.state], ran.t_last))


def _step_pieces(session: CvodeSession, model: CompiledModel, ran: MachineRun, cuts: list[int],
                 states: list[int], params, sampler: TimeSampler | None) -> list[StepPolynomials]:
    """Each segment's step polynomials (a failed segment's last), and its samples at t_eval
    read with the parameters it ran under."""
    pieces = []
    for j, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        if b == a:
            continue
        piece = StepPolynomials(ran.t[a:b], ran.dense[a:b])
        pieces.append(piece)
        if sampler is not None:
            seg_params = ran.segments[j].params if j < len(ran.segments) else params
            sampler.segment(float(ran.t[b - 1]), piece, _outputs_at(session, model, seg_params),
                            STATES[states[j + 1]])
    return pieces


def _outputs_at(session: CvodeSession, model: CompiledModel, params):
    """The outputs at interpolated samples, under the parameters of their segment."""
    return lambda t, y: dict(zip(model.output_names, session.outputs(params, t, y).T))


def _end_without_event(scene: Scene, impacts: list[Impact], phase: str) -> tuple[str, str]:
    """Status and message of a run that reached its end time rather than an event."""
    if scene.solver.t_end is not None:
        return "ok", ""
    if not impacts:
        return "no-impact", f"no contact within solver.t_max = {scene.solver.t_max:g} s"
    return "ok", (f"no separation within solver.t_max = {scene.solver.t_max:g} s: the tip came to rest "
                  f"on the surface (phase {phase!r}); the summary's impact has no end")


def _no_impact_at_start(scene: Scene, model: CompiledModel, y: np.ndarray, first: list[float],
                        along: bool, started: float) -> SimulationResult:
    rate0 = 0.0 if along else first[model.output_names.index("delta_rate")]
    motion = "along" if along else "away from"
    trajectory = Trajectory(np.array([0.0]), y[None, :], np.array(["free"]),
                            {name: np.array([v]) for name, v in zip(model.output_names, first)})
    return SimulationResult(scene, "c", "no-impact",
                            f"the tip touches the surface but moves {motion} it (d(delta)/dt = "
                            f"{rate0:.3g} m/s): no impact", trajectory, [], [],
                            {"segments": 0, "samples": 1, "wall_s": time.perf_counter() - started})
