"""The C engine's integrator of a run, reused across runs of a warm process (stage 7, with phases.py).

`EngineSession` owns one `ig_solver` of the C runtime (native/solver.h: CVODE's BDF or Adams,
the plain-C DOPRI5 pair, ERK, or "auto", which hands a stiff segment from the pair to BDF)
and runs the generated phase machine on it in C (ig_run), segment after segment, until the
machine ends the run, the end time or a failure; it hands back the samples (every step, or
only each segment's end), the switch records and, for dense output, each step's
interpolating polynomial. `likely_cause` turns an integrator's message into one that says
what to try.
"""
from __future__ import annotations

import struct
from typing import NamedTuple

import numpy as np

from .build import CompiledModel
from .codegen.spec import STATES, point_name
from .errors import SolverError
from .records import SwitchRecord, TallyRecords, record_layout, summary_layout, switch_record_layout
from .scene import EXPLICIT_METHODS, Scene, Solver
from .summaries import BUDGET

FIRST_BUFFER = 1024  # samples; doubled while a run keeps filling it
RECORD_CAPACITY = 64  # switch records per C call of a run (at least one per contact point)


class Machine:
    """The C phase machine of a session (its buffer `state`), with the names and the switch
    actions (MODEL_ACT_* bits) the results read, looked up in the library once."""

    def __init__(self, model: CompiledModel, state):
        lib, spec = model.lib, model.spec
        self.state = state
        self.free = lib.MODEL_MACHINE_FREE
        self.acts = (lib.MODEL_ACT_IMPACT_BEGIN, lib.MODEL_ACT_SLIP, lib.MODEL_ACT_MAX_COMPRESSION,
                     lib.MODEL_ACT_IMPACT_END)
        self.points = (*spec.joints, spec.links)  # each contact point's number, in the machine's order (point[k])
        self.names = {number: point_name(number, spec.links) for number in self.points}
        self.tip = spec.links  # the chain's end: the point whose phases are the run's
        self.tip_index = lib.MODEL_TIP_POINT
        self.rate_law = spec.rate_law  # a damped law records the depth it lets go at as the impact's delta_r
        # the C machine's labels (model_machine_slip_name) of a point in contact, read once
        in_contact = lib.MODEL_MACHINE_ELASTIC
        self.slip_labels = {slip: model.ffi.string(lib.model_machine_slip_name(in_contact, slip)).decode()
                            for slip in (+1.0, -1.0, 0.0)}

    def slip_label(self, state: int, slip: float) -> str:
        """The stick-slip label of a contact state under exact Coulomb friction, else ""."""
        return self.slip_labels[slip] if state != self.free else ""

    def phase_now(self) -> str:
        """The phase the machine is in, as the phase spans list it: the tip's bare phase while
        no other point is in contact, else the points in contact, named ("base: elastoplastic")."""
        point, free = self.state.point, self.free
        touching = [(self.names[number], STATES[point[k].state]) for k, number in enumerate(self.points)
                    if point[k].state != free]
        if all(name == self.names[self.tip] for name, _ in touching):
            return STATES[point[self.tip_index].state]
        return ", ".join(f"{name}: {state}" for name, state in touching)

    def in_contact(self) -> list[str]:
        """The points in contact now, in point order, by name."""
        point, free = self.state.point, self.free
        return [self.names[number] for k, number in enumerate(self.points) if point[k].state != free]


class MachineRun(NamedTuple):
    """What one `EngineSession.run` gives back: the samples (rows), the switch records as C
    wrote them (every point's, in time order, at one switch in point order), ig_run's last
    return code with the message of a failure, and the time the run stopped."""

    t: np.ndarray
    y: np.ndarray
    outputs: np.ndarray
    dense: np.ndarray | None
    records: list[SwitchRecord]
    record_params: list | None  # a copy of the model_params each record's segment ran under (cffi), when asked for
    flag: int
    message: str
    t_last: float
    summaries: TallyRecords  # over the whole run, over its first impact (ig_summarize)


class EngineSession:
    """One integrator (the scene's method) for a whole simulation, with the run's C buffers
    (the phase machine, the tolerances, the samples). `open` reuses an idle one of the same
    model and method (a warm process then allocates nothing per run); `close` returns it."""

    _idle: dict[tuple, list["EngineSession"]] = {}  # (model, method) -> sessions not in use

    @classmethod
    def open(cls, model: CompiledModel, solver: Solver) -> "EngineSession":
        """An idle session of this model and `solver`'s method, or a new one; `begin` a run on it."""
        key = model.lib, solver.method  # one library per build, hashed by identity
        try:
            return cls._idle.get(key, []).pop()
        except IndexError:
            return cls(model, solver, key)

    def close(self) -> None:
        """Hand the integrator back for the next run (only after a run that ended normally)."""
        self._idle.setdefault(self.pool_key, []).append(self)

    def __init__(self, model: CompiledModel, solver: Solver, pool_key: tuple):
        self.model = model
        self.pool_key = pool_key  # where `close` hands it back (`open` made it)
        ffi = model.ffi
        self.method = method_code(model.lib, solver.method)
        self.analytic = 1 if uses_jacobian(model, solver) else 0
        self.capacity = FIRST_BUFFER
        self.dense = False  # keep each step's interpolating polynomial (dense output, t_eval)
        # the run's arguments, allocated once
        self.machine = ffi.new("model_machine *")
        self.phase_machine = Machine(model, self.machine)
        self.atol_now = ffi.new("double[]", model.nstate)
        self.solver = self._new_solver(solver)
        self.dense_terms = int(model.lib.ig_dense_terms(self.solver))
        self.records = ffi.new("ig_segment[]", RECORD_CAPACITY)
        self._record_bytes = ffi.buffer(self.records)
        self._record_layout = switch_record_layout(ffi)
        self.n_records = ffi.new("int *")
        self.n_out = ffi.new("int *")
        self.t_now = ffi.new("double *")
        self.y0 = np.empty(model.nstate)
        self.works_at_start = (0.0,) * (model.nstate - 2 * model.spec.dof)  # the integrated states: works, impulses
        self.y0_c = ffi.from_buffer("double[]", self.y0)
        self.output_index = {name: k for k, name in enumerate(model.output_names)}
        self._stats = ffi.new("ig_stats *")
        self._stats_bytes = ffi.buffer(self._stats)
        self._stats_record = struct.Struct("=" + record_layout(ffi, "ig_stats"))
        self.stats_names = tuple(name for name, _ in ffi.typeof("ig_stats").fields)
        self.tally = ffi.new("ig_tally *")
        self.summaries = ffi.new("ig_summary[2]")  # the run's, its first impact's
        self._summary_args = (self.tally, self.summaries, self.summaries + 1)
        self._summary_bytes = ffi.buffer(self.summaries)
        self._summary_layout = summary_layout(ffi, BUDGET)
        self._alloc()

    def _new_solver(self, solver: Solver):
        """The integrator, made with `solver`'s tolerances (each run's `begin` resets them)."""
        ffi, lib = self.model.ffi, self.model.lib
        self.atol_now[0:self.model.nstate] = [solver.atol] * self.model.nstate
        err = ffi.new("char[]", 512)
        made = lib.ig_solver_new(self.method, self.analytic, solver.rtol, self.atol_now, solver.max_steps, err, 512)
        if made == ffi.NULL:
            raise SolverError(f"cannot create the integrator: {ffi.string(err).decode()}")
        return ffi.gc(made, lib.ig_solver_free)

    def begin(self, params, scene: Scene, solver: Solver) -> int:
        """Start the machine at the scene's initial state, at t = 0, under `params` (which
        the run goes on with): sample 0 and the tally begun there, and, when an impact can
        follow, the integrator reset with `solver`'s tolerances as the machine scales them
        (ig_run_begin). Returns the machine's MODEL_START_*."""
        self.y0_c[0:len(self.y0)] = scene.motion_start + self.works_at_start  # (cffi converts faster than numpy)
        self.t_now[0] = 0.0
        start = self.model.lib.ig_run_begin(self.solver, self.machine, params, 0.0, self.y0_c,
                                            solver.t_end is not None, solver.rtol, solver.atol, solver.max_steps,
                                            self.atol_now, self.t_buf, self.y_buf, self.out_buf, self.tally)
        if start < 0:
            raise SolverError(f"cannot reset the integrator: {self._message()}")
        return start

    def _alloc(self) -> None:
        ffi = self.model.ffi
        self.t_samples = np.empty(self.capacity)  # the integrator writes its steps here
        self.y_samples = np.empty((self.capacity, self.model.nstate))
        self.t_buf = ffi.from_buffer("double[]", self.t_samples)
        self.y_buf = ffi.from_buffer("double[]", self.y_samples)
        self.out_samples = np.empty((self.capacity, len(self.model.output_names)))
        self.out_buf = ffi.from_buffer("double[]", self.out_samples)
        self.d_samples = np.empty((self.capacity, self.dense_terms, self.model.nstate)) if self.dense else None
        self.d_buf = ffi.from_buffer("double[]", self.d_samples) if self.dense else ffi.NULL

    def keep_polynomials(self, dense: bool) -> None:
        """Ask for (or stop asking for) each step's Taylor coefficients from the next segment on."""
        if dense != self.dense:
            self.dense = dense
            self._alloc()

    def run(self, params, t_stop: float, atol: float, max_segments: int, every_step: bool,
            with_params: bool = False) -> "MachineRun":
        """Run the phase machine (`machine`, started by `begin`) to t_stop in C (ig_run), one
        call per buffer's worth: every step a sample when `every_step`, else only each
        segment's end. The samples begin with the start, sample 0. `with_params` keeps a
        copy of the parameters of each record's segment (to evaluate outputs between its
        samples). The run's summaries are tallied in C on the way."""
        ffi, lib = self.model.ffi, self.model.lib
        dense = self.dense and every_step
        if dense:
            self.d_samples[0] = 0.0  # the start ends no step: it has no polynomial
        chunks: list[tuple[np.ndarray, ...]] = []
        records: list[SwitchRecord] = []
        record_params: list | None = [] if with_params else None
        base = 0  # samples before this call's buffers
        self.n_out[0] = 1  # the start, written by begin
        while True:
            flag = lib.ig_run(self.solver, self.machine, params, self.t_now, self.y0_c, t_stop, t_stop, atol,
                              max_segments - len(records), every_step, self.t_buf, self.y_buf, self.out_buf,
                              self.d_buf if dense else ffi.NULL, self.capacity, self.n_out, self.records,
                              RECORD_CAPACITY, self.n_records, self.tally)
            k = self.n_out[0]
            chunks.append((self.t_samples[:k].copy(), self.y_samples[:k].copy(), self.out_samples[:k].copy(),
                           self.d_samples[:k].copy() if dense else None))
            rows = self._record_layout.iter_unpack(self._record_bytes[:self.n_records[0] * self._record_layout.size])
            records += map(SwitchRecord._make, rows if not base else [(r[0], base + r[1]) + r[2:] for r in rows])
            if with_params:
                new = ffi.new
                record_params.extend(new("model_params *", self.records[j].params) for j in range(self.n_records[0]))
            base += k
            self.n_out[0] = 0
            if flag == lib.IG_BUFFER_FULL and every_step:
                self.capacity *= 2
                self._alloc()
            if flag not in (lib.IG_BUFFER_FULL, lib.IG_SEGMENTS_FULL):
                break
        if len(chunks) == 1:
            t, y, out, d = chunks[0]
        else:
            t, y, out, d = (np.concatenate(parts) if parts[0] is not None else None for parts in zip(*chunks))
        message = self._message() if flag < 0 else ""
        return MachineRun._make((t, y, out, d, records, record_params, int(flag), message, float(self.t_now[0]),
                                 self._summarized()))

    def _summarized(self) -> TallyRecords:
        """The run's two summaries, tallied in C now (the session's buffers serve the next
        run), read into Python when asked for."""
        self.model.lib.ig_summarize(*self._summary_args)
        return TallyRecords(self._summary_layout, self._summary_bytes[:])

    def without_run(self) -> tuple[np.ndarray, TallyRecords]:
        """The outputs at the start, and the summaries of a run that ends where it begins
        (the tip touches the surface without pressing in: no impact)."""
        return self.out_samples[0].copy(), self._summarized()

    def outputs(self, params, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        ffi, model = self.model.ffi, self.model
        t = np.ascontiguousarray(t, dtype=float)
        y = np.ascontiguousarray(y, dtype=float)
        out = np.empty((len(t), len(model.output_names)))
        model.lib.ig_outputs(params, len(t), ffi.from_buffer("double[]", t), ffi.from_buffer("double[]", y),
                             ffi.from_buffer("double[]", out))
        return out

    def counters(self) -> tuple[int, ...]:
        """The solver's counters now, in the order of ig_stats (`stats_names`)."""
        self.model.lib.ig_solver_stats(self.solver, self._stats)
        return self._stats_record.unpack_from(self._stats_bytes)

    def _message(self) -> str:
        text = self.model.ffi.string(self.model.lib.ig_solver_message(self.solver)).decode(errors="replace")
        return likely_cause(text or "the integrator failed without a message")


def method_code(lib, method: str) -> int:
    """The library's IG_METHOD_<NAME> of a method named in a scene (scene.METHODS)."""
    return getattr(lib, f"IG_METHOD_{method.upper()}")


def uses_jacobian(model: CompiledModel, solver: Solver) -> bool:
    """Whether the integrator gets the model's analytic Jacobian: the model has one and the
    method is implicit (the explicit Runge-Kutta methods use none)."""
    return bool(model.spec.jacobian) and solver.method not in EXPLICIT_METHODS


def likely_cause(message: str) -> str:
    """Add to an integrator's message what usually causes it and what to try."""
    lower = message.lower()
    if "max_steps" in lower:
        hint = ("the phase needs more steps than allowed: raise solver.max_steps, loosen solver.rtol, "
                "or use method = \"bdf\" if stiff friction (a small contact.friction_eps) is the cause")
    elif "error test failed" in lower or "convergence test failed" in lower or "convfail" in lower:
        hint = ("the problem is too stiff or not smooth enough here for these tolerances: use "
                "method = \"bdf\", a larger contact.friction_eps, or a looser solver.rtol")
    elif "right-hand side" in lower or "rhs" in lower or "repeated recoverable" in lower:
        hint = ("the right-hand side stopped being finite: check for extreme parameters "
                "(moduli, radii, masses) or speeds")
    elif "too much accuracy" in lower:
        hint = "the tolerances are below what double precision resolves: raise solver.rtol or solver.atol"
    else:
        return message
    return f"{message}; likely cause: {hint}"
