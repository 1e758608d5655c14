"""Stage 7 of the pipeline: run the generated C phase machine against CVODE's root finder.

The machine (model_machine.c, printed from templates/machine.c.j2) decides everything of
MODEL section 4: which force law and which events with directions each machine state has,
and what each switch records (delta_m, P_m, delta_r, R_res, stick/slip, sustained contact,
lift-off, later impacts). This wrapper integrates one segment at a time (session.py), asks
the machine what comes next at each root, and records the samples, the phase spans and one
`Impact` per impact. Python is crossed once per segment.
"""
from __future__ import annotations

import time

import numpy as np

from .build import CompiledModel
from .codegen.machine import STATES
from .codegen.thresholds import THRESHOLD
from .dense import DenseSolution, StepPolynomials, TimeSampler
from .errors import SolverError
from .model_params import fill_params
from .results import Impact, PhaseSpan, SimulationResult, Trajectory
from .scene import Scene
from .session import CvodeSession, uses_jacobian

MAX_SEGMENTS = 100_000  # phase switches in one run: beyond this, stop rather than hang
STICK_EXCESS = THRESHOLD["STICK_EXCESS"]
SLIP_LABEL = {+1.0: "slip+", -1.0: "slip-", 0.0: "stick"}
STATE_NAMES = np.array(STATES)  # the phase label of each sample, by machine state


class Machine:
    """The C phase machine of one run, with the names the results use."""

    def __init__(self, model: CompiledModel, params):
        self.params, self.lib = params, model.lib
        self.state = model.ffi.new("model_machine *")
        self.atol_now = model.ffi.new("double[]", model.nstate)
        self.coulomb = model.spec.coulomb

    @property
    def phase(self) -> str:
        return STATES[self.state.state]  # the C enum follows codegen.machine.STATES

    @property
    def slip_state(self) -> str:
        """The stick-slip label of a contact phase with exact Coulomb friction, else ""."""
        in_contact = self.state.state != self.lib.MODEL_MACHINE_FREE
        return SLIP_LABEL[self.state.slip] if self.coulomb and in_contact else ""

    def atol(self, scene: Scene):
        self.lib.model_machine_atol(self.state, self.params, scene.solver.rtol, scene.solver.atol,
                                    self.atol_now)
        return self.atol_now


def run(model: CompiledModel, scene: Scene, t_eval: np.ndarray | None = None,
        dense_output: bool = False) -> SimulationResult:
    """Simulate `scene` with the compiled `model` from phase to phase.

    `t_eval` (sorted times) adds samples read from CVODE's interpolating polynomials;
    `dense_output` keeps those polynomials as `result.sol`. A solver failure ends the run
    with status "failed" and the samples reached so far."""
    started = time.perf_counter()
    lib = model.lib
    params = fill_params(model, scene)
    machine = Machine(model, params)
    m = machine.state
    y = np.concatenate([scene.q0, scene.u0, np.zeros(model.nstate - 2 * scene.n)])
    t = 0.0
    run_to_time = scene.solver.t_end is not None
    start = lib.model_machine_start(m, params, t, model.ffi.from_buffer("double[]", y), int(run_to_time))
    session = CvodeSession.open(model, scene, machine.atol(scene))
    session.keep_polynomials(dense_output or t_eval is not None)
    first_row = session.outputs(params, np.array([t]), y[None, :])
    if start in (lib.MODEL_START_ALONG, lib.MODEL_START_AWAY):
        session.close(scene)
        return _no_impact_at_start(scene, model, y, first_row[0].tolist(), start == lib.MODEL_START_ALONG,
                                   started)
    t_end = scene.solver.t_end if run_to_time else scene.solver.t_max

    ts, ys, outs = [np.array([t])], [y[None, :]], [first_row]
    codes, counts = [m.state], [1]  # the machine state of each run of samples
    dense_breaks: list[float] = [t]
    dense_pieces: list[StepPolynomials] = []
    sampler = TimeSampler(t_eval) if t_eval is not None else None
    spans: list[PhaseSpan] = []
    impacts: list[Impact] = []
    n_samples = 1
    if start == lib.MODEL_START_CONTACT:
        impacts.append(Impact(t_start=t, i_start=0))
        session.set_atol(machine.atol(scene))
    status, message = "ok", ""
    analytic = uses_jacobian(model, scene)

    def outputs_at(t_now: np.ndarray, y_rows: np.ndarray) -> dict[str, np.ndarray]:
        return dict(zip(model.output_names, session.outputs(params, t_now, y_rows).T))

    def record(phase_now: str, seg_t: np.ndarray, seg_y: np.ndarray, seg_d: np.ndarray | None) -> np.ndarray:
        """Keep a segment's samples (and polynomials, and t_eval samples); return its outputs."""
        nonlocal n_samples
        seg_out = session.outputs(params, seg_t, seg_y)
        ts.append(seg_t), ys.append(seg_y), outs.append(seg_out)
        codes.append(STATES.index(phase_now))
        counts.append(len(seg_t))
        n_samples += len(seg_t)
        if seg_d is not None and len(seg_t):
            piece = StepPolynomials(seg_t, seg_d)
            dense_pieces.append(piece)
            dense_breaks.append(float(seg_t[-1]))
            if sampler is not None:
                sampler.segment(float(seg_t[-1]), piece, outputs_at, phase_now)
        return seg_out

    try:
        while True:
            if len(spans) >= MAX_SEGMENTS:
                raise SolverError(f"more than {MAX_SEGMENTS} phase switches (chattering impacts?); "
                                  "shorten solver.t_end", machine.phase, t)
            phase, slip_state = machine.phase, machine.slip_state
            n_events = lib.model_machine_events(m, session.event_idx, session.event_dirs)
            if analytic:  # the analytic Jacobian does not know the constraint forces
                session.use_jacobian(not lib.model_machine_constrained(m))
            try:
                seg_t, seg_y, seg_d, fired = session.segment(params, phase, t, y, t_end, n_events)
            except SolverError as error:
                partial = getattr(error, "partial", None)
                if partial is not None and len(partial[0]):
                    record(phase, *partial)
                raise
            seg_out = record(phase, seg_t, seg_y, seg_d)
            if slip_state == "stick":
                _check_stick(seg_out, model.output_names, scene.contact.friction, phase, float(seg_t[-1]))
            t, y = float(seg_t[-1]), seg_y[-1].copy()
            ended_by = [model.event_names[session.event_idx[k]] for k in range(n_events) if session.roots[k]]
            spans.append(PhaseSpan(phase, spans[-1].t1 if spans else 0.0, t,
                                   ended_by[0] if fired and ended_by else "t_end", slip_state))
            if not fired:
                status, message = _end_without_event(scene, impacts, phase)
                break
            act = lib.model_machine_switch(m, params, t, model.ffi.from_buffer("double[]", y), session.roots)
            if act & lib.MODEL_ACT_IMPACT_BEGIN:
                impacts.append(Impact(t_start=t, i_start=n_samples - 1))
            impact = impacts[-1] if impacts else None
            if act & lib.MODEL_ACT_SLIP:
                impact.stick_slip.append((t, slip_state, machine.slip_state))
            if act & lib.MODEL_ACT_MAX_COMPRESSION:
                impact.delta_max, impact.P_max, impact.delta_r, impact.R_res = m.delta_max, m.P_max, m.delta_r, m.R_res
            new_phase = machine.phase
            if impact is not None and phase != "free" and new_phase != phase:
                impact.switches.append((t, phase, new_phase))
            if act & lib.MODEL_ACT_IMPACT_END:
                impact.t_end, impact.i_end = t, n_samples - 1
            if act & lib.MODEL_ACT_END:
                break
            if act & lib.MODEL_ACT_TOLERANCES:
                session.set_atol(machine.atol(scene))
    except SolverError as error:
        status, message = "failed", str(error)

    trajectory = Trajectory(
        t=np.concatenate(ts), y=np.concatenate(ys),
        phase=STATE_NAMES[np.repeat(codes, counts)],
        outputs={name: col for name, col in zip(model.output_names, np.concatenate(outs).T)},
    )
    stats = session.stats()
    if status != "failed":  # a failed integrator is not handed to the next run
        session.close(scene)
    stats.update(segments=len(spans), samples=n_samples, wall_s=time.perf_counter() - started)
    sampled = Trajectory(*sampler.gathered(model.nstate, model.output_names)) if sampler else None
    sol = DenseSolution(dense_breaks, dense_pieces, model.nstate) if dense_output else None
    return SimulationResult(scene, "c", status, message, trajectory, spans, impacts, stats, sampled, sol)


def _end_without_event(scene: Scene, impacts: list[Impact], phase: str) -> tuple[str, str]:
    """Status and message of a run that reached its end time rather than an event."""
    if scene.solver.t_end is not None:
        return "ok", ""
    if not impacts:
        return "no-impact", f"no contact within solver.t_max = {scene.solver.t_max:g} s"
    return "ok", (f"no separation within solver.t_max = {scene.solver.t_max:g} s: the tip came to rest "
                  f"on the surface (phase {phase!r}); the summary's impact has no end")


def _check_stick(out: np.ndarray, output_names: tuple[str, ...], mu: float, phase: str, t: float) -> None:
    """A stuck tip never needs more than mu F: if it did, a slip event was missed."""
    F, F_f = out[:, output_names.index("F")], out[:, output_names.index("F_f")]
    excess = np.abs(F_f) - mu * F
    if np.max(excess) > STICK_EXCESS * mu * max(float(np.max(F)), 1e-300):
        raise SolverError("the stuck tip needed a friction force beyond mu F and no slip event "
                          "fired; tighten solver.rtol", phase, t)


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
