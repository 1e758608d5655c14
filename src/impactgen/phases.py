"""Stage 7 of the pipeline: the phase state machine of MODEL section 4, driving CVODE.

Each phase is one CVODE segment with its own force law (params.phase) and its own active
events with directions, like solve_ivp's terminal events. Python is crossed once per
segment; at each switch the machine records what the model fixes there (delta_m, P_m,
delta_r, R_res) and re-initialises the integrator, since the force law changes.

    free --contact--> elastic --yield--> elastoplastic --max_compression--> restitution
    elastic --max_compression--> restitution             restitution --separation--> free
    restitution --rate rises--> reloading --rate falls--> restitution
    reloading --passes delta_m--> elastic or elastoplastic (the curve it left)
    elastic/elastoplastic --max_compression, impacts chattering--> sustained --lift_off--> free

Sustained contact (scenes run to a time): when a flight is chattering (validity.chattering),
the next impact does not rebound at its maximum compression; the tip is held at that depth
by a constraint force F >= 0 until F falls to 0 (lift-off). The elastic energy stored in
the dent stays in W_normal as a loss. After lift-off the surface level is the tip's height
there, so later impacts start from delta = 0.

With exact Coulomb friction, a stick-slip state (stick_slip.py) runs beside the phase.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .build import CompiledModel
from .codegen.expressions import PHASES
from .contact_constants import (RESIDUAL_LAWS, YIELD_ONSET, ContactConstants, contact_constants,
                                unloading_radius)
from .dense import DenseSolution, StepPolynomials, TimeSampler
from .errors import SolverError
from .results import Impact, PhaseSpan, SimulationResult, Trajectory
from .scene import Scene
from .stick_slip import ENDS as SLIP_ENDS
from .stick_slip import EVENTS as SLIP_EVENTS
from .stick_slip import LABEL as SLIP_LABEL
from .stick_slip import slip_after, slip_at_contact, slip_when_stopped
from .validity import chattering

RISING, FALLING = 1, -1
LAW_CODE = {name: code for code, name in enumerate(PHASES)}  # params.phase of each force law
FIRST_BUFFER = 1024  # samples; doubled while a segment keeps filling it
MAX_SEGMENTS = 100_000  # phase switches in one run: beyond this, stop rather than hang


@dataclass(frozen=True)
class PhaseRule:
    law: str  # which C force law: free, elastic, elastoplastic, restitution
    events: tuple[tuple[str, int], ...]  # (event name, direction) that end the phase


def phase_rules(plastic: bool) -> dict[str, PhaseRule]:
    separation = "separation" if plastic else "contact"  # Hertz only: delta_r = 0
    return {
        "free": PhaseRule("free", (("contact", RISING),)),
        "elastic": PhaseRule("elastic", (("max_compression", FALLING),)
                             + ((("yield", RISING),) if plastic else ())),
        "elastoplastic": PhaseRule("elastoplastic", (("max_compression", FALLING),)),
        "restitution": PhaseRule("restitution", ((separation, FALLING), ("max_compression", RISING))),
        "reloading": PhaseRule("restitution", (("max_compression", FALLING), ("passes_delta_m", RISING))),
        "sustained": PhaseRule("sustained", (("lift_off", FALLING),)),
    }


class CvodeSession:
    """One CVODE integrator for a whole simulation. `open` reuses an idle one of the same
    model and method (a warm process then allocates nothing per run); `close` returns it."""

    _idle: dict[tuple, list["CvodeSession"]] = {}  # (model, method) -> sessions not in use

    @staticmethod
    def _pool_key(model: CompiledModel, scene: Scene) -> tuple:
        return model.spec, str(model.path), scene.solver.method

    @classmethod
    def open(cls, model: CompiledModel, scene: Scene, atol: list[float]) -> "CvodeSession":
        try:
            session = cls._idle.get(cls._pool_key(model, scene), []).pop()
        except IndexError:
            return cls(model, scene, atol)
        lib, ffi = model.lib, model.ffi
        if lib.ig_solver_reset(session.solver, scene.solver.rtol, ffi.new("double[]", atol),
                               scene.solver.max_steps) != 0:
            raise SolverError(f"cannot reset the CVODE solver: {session._message()}")
        return session

    def close(self, scene: Scene) -> None:
        """Hand the integrator back for the next run (only after a run that ended normally)."""
        self._idle.setdefault(self._pool_key(self.model, scene), []).append(self)

    def __init__(self, model: CompiledModel, scene: Scene, atol: list[float]):
        self.model = model
        ffi, lib = model.ffi, model.lib
        err = ffi.new("char[]", 512)
        method = 0 if scene.solver.method == "bdf" else 1
        atol_c = ffi.new("double[]", atol)
        analytic = 1 if model.spec.jacobian else 0
        solver = lib.ig_solver_new(method, analytic, scene.solver.rtol, atol_c, scene.solver.max_steps, err, 512)
        if solver == ffi.NULL:
            raise SolverError(f"cannot create the CVODE solver: {ffi.string(err).decode()}")
        self.solver = ffi.gc(solver, lib.ig_solver_free)
        self.capacity = FIRST_BUFFER
        self.dense_terms = int(lib.ig_dense_terms(self.solver))
        self.dense = False  # keep each step's interpolating polynomial (dense output, t_eval)
        self._alloc()
        # per-segment arguments, allocated once
        nev = max(len(model.event_names), 1)
        self.event_idx = ffi.new("int[]", nev)
        self.event_dirs = ffi.new("int[]", nev)
        self.roots = ffi.new("int[]", nev)
        self.n_out = ffi.new("int *")
        self.y0 = np.empty(model.nstate)
        self.y0_c = ffi.from_buffer("double[]", self.y0)
        self.event_index = {name: i for i, name in enumerate(model.event_names)}

    def _alloc(self) -> None:
        ffi = self.model.ffi
        self.t_samples = np.empty(self.capacity)  # CVODE writes its steps here
        self.y_samples = np.empty((self.capacity, self.model.nstate))
        self.t_buf = ffi.from_buffer("double[]", self.t_samples)
        self.y_buf = ffi.from_buffer("double[]", self.y_samples)
        self.d_samples = np.empty((self.capacity, self.dense_terms, self.model.nstate)) if self.dense else None
        self.d_buf = ffi.from_buffer("double[]", self.d_samples) if self.dense else ffi.NULL

    def keep_polynomials(self, dense: bool) -> None:
        """Ask for (or stop asking for) each step's Taylor coefficients from the next segment on."""
        if dense != self.dense:
            self.dense = dense
            self._alloc()

    def segment(self, params, phase: str, t0: float, y0: np.ndarray, t_stop: float,
                events: tuple[tuple[str, int], ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, list[str]]:
        """Integrate from (t0, y0) until an event or t_stop; return the samples, their step
        polynomials (None unless `keep_polynomials`) and the events that fired. A failure
        raises SolverError carrying the samples reached as `partial`."""
        lib = self.model.lib
        for k, (name, direction) in enumerate(events):
            self.event_idx[k] = self.event_index[name]
            self.event_dirs[k] = direction
        self.y0[:] = y0
        flag = lib.ig_segment_start(self.solver, params, t0, self.y0_c, t_stop, self.event_idx,
                                    self.event_dirs, len(events))
        if flag < 0:
            raise SolverError(self._message(), phase, t0)
        ts, ys, ds = [], [], []
        n_out, roots = self.n_out, self.roots
        while True:
            flag = lib.ig_segment_advance(self.solver, self.t_buf, self.y_buf, self.d_buf, self.capacity,
                                          n_out, roots)
            k = n_out[0]
            ts.append(self.t_samples[:k].copy())
            ys.append(self.y_samples[:k].copy())
            if self.dense:
                ds.append(self.d_samples[:k].copy())
            if flag == lib.IG_BUFFER_FULL:
                self.capacity *= 2
                self._alloc()
                continue
            if flag < 0:
                t_fail = float(ts[-1][-1]) if k else (float(ts[-2][-1]) if len(ts) > 1 else t0)
                error = SolverError(self._message(), phase, t_fail)
                error.partial = (np.concatenate(ts), np.concatenate(ys), np.concatenate(ds) if ds else None)
                raise error
            break
        fired = [events[i][0] for i in range(len(events)) if flag == lib.IG_ROOT and roots[i] != 0]
        if len(ts) == 1:
            return ts[0], ys[0], (ds[0] if ds else None), fired
        return np.concatenate(ts), np.concatenate(ys), (np.concatenate(ds) if ds else None), fired

    def use_jacobian(self, analytic: bool) -> None:
        if self.model.lib.ig_solver_use_jacobian(self.solver, 1 if analytic else 0) != 0:
            raise SolverError(self._message())

    def set_atol(self, atol: list[float]) -> None:
        values = self.model.ffi.new("double[]", atol)
        if self.model.lib.ig_solver_set_atol(self.solver, values) != 0:
            raise SolverError(self._message())

    def outputs(self, params, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        ffi, model = self.model.ffi, self.model
        t = np.ascontiguousarray(t, dtype=float)
        y = np.ascontiguousarray(y, dtype=float)
        out = np.empty((len(t), len(model.output_names)))
        model.lib.ig_outputs(params, len(t), ffi.from_buffer("double[]", t), ffi.from_buffer("double[]", y),
                             ffi.from_buffer("double[]", out))
        return out

    def stats(self) -> dict[str, int]:
        st = self.model.ffi.new("ig_stats *")
        self.model.lib.ig_solver_stats(self.solver, st)
        return {k: int(getattr(st, k)) for k in ("nsteps", "nfev", "njev", "nlinsetups",
                                                   "netfails", "nnlsfails", "ngev")}

    def _message(self) -> str:
        text = self.model.ffi.string(self.model.lib.ig_solver_message(self.solver)).decode(errors="replace")
        return likely_cause(text or "CVODE failed without a message")


def likely_cause(message: str) -> str:
    """Add to a CVODE message what usually causes it and what to try."""
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


def default_atol(scene: Scene, nstate: int) -> list[float]:
    """solver.atol for angles and speeds; the works (J) get atol scaled by a typical energy."""
    n, atol = scene.n, scene.solver.atol
    energy_scale = max(sum(scene.chain.mass) * max(scene.chain.gravity, 1.0) * sum(scene.chain.length), 1e-30)
    return [atol] * (2 * n) + [atol * energy_scale] * (nstate - 2 * n)


def contact_atol(scene: Scene, consts: ContactConstants, free_atol: list[float], y: np.ndarray,
                 out: dict[str, float]) -> list[float]:
    """Absolute tolerances inside one impact, scaled to it at its first instant.

    The penetration is a difference of tip heights, so the angles must be resolved to a
    fraction of it: a Hertz estimate delta_est = (15 m_eff v_n^2 / (16 E* R^1/2))^(2/5), with
    the approach speed v_n and the effective mass m_eff ~ 2 T / |v_B|^2, sets their atol
    (floored at 1e-15 rad, the double precision of a tip height of order 1 m). Speeds and
    works get rtol times their size at contact. Never looser than the scene's atol."""
    n, rtol = scene.n, scene.solver.rtol
    v_tip2 = out["v_Bx"] ** 2 + out["v_By"] ** 2
    m_total = sum(scene.chain.mass)
    m_eff = min(2.0 * out["T"] / v_tip2, m_total) if v_tip2 > 0 else m_total
    v_n = max(out["delta_rate"], 0.0)
    delta_est = (15.0 * m_eff * v_n ** 2 / (16.0 * consts.E_star * math.sqrt(consts.R))) ** 0.4
    angle = 1e-2 * rtol * delta_est / sum(scene.chain.length)
    speed = max(rtol * max(abs(u) for u in y[n:2 * n].tolist()), 1e-300)
    work = max(rtol * out["T"], 1e-300)
    return ([min(max(angle, 1e-15), a) for a in free_atol[:n]]
            + [min(a, speed) for a in free_atol[n:2 * n]]
            + [min(a, work) for a in free_atol[2 * n:]])


def surface_height(scene: Scene) -> float:
    if scene.surface_height is not None:
        return scene.surface_height
    return sum(L * math.sin(q) for L, q in zip(scene.chain.length, scene.q0))


def fill_params(model: CompiledModel, scene: Scene, consts: ContactConstants):
    params = model.ffi.new("model_params *")
    values = {f"L{i + 1}": L for i, L in enumerate(scene.chain.length)}
    values.update({f"m{i + 1}": m for i, m in enumerate(scene.chain.mass)})
    values.update(g=scene.chain.gravity, y_s=surface_height(scene), E_star=consts.E_star,
                  R=consts.R, delta_c=consts.delta_c, P_c=consts.P_c, C_j=consts.C_j, B=consts.B,
                  delta_m=0.0, delta_r=0.0, R_res=consts.R, mu=scene.contact.friction,
                  eps=scene.contact.friction_eps, slip=1.0)
    for name in model.param_names:
        setattr(params, name, values[name])
    return params


def set_params(model: CompiledModel, params, **values: float) -> None:
    """Set the named parameters that this (pruned) model has; skip the others."""
    for name, value in values.items():
        if name in model.param_names:
            setattr(params, name, value)


def run(model: CompiledModel, scene: Scene, t_eval: np.ndarray | None = None, dense_output: bool = False,
        residual_law: str = "marghitu-zhao") -> SimulationResult:
    """Simulate `scene` with the compiled `model` from phase to phase.

    `t_eval` (sorted times) adds samples read from CVODE's interpolating polynomials;
    `dense_output` keeps those polynomials as `result.sol`. A solver failure ends the run
    with status "failed" and the samples reached so far."""
    started = time.perf_counter()
    consts = contact_constants(scene)
    plastic, coulomb = model.spec.plastic, model.spec.coulomb
    rules = phase_rules(plastic)
    residual = RESIDUAL_LAWS[residual_law]
    params = fill_params(model, scene, consts)
    free_atol = default_atol(scene, model.nstate)
    session = CvodeSession.open(model, scene, free_atol)
    session.keep_polynomials(dense_output or t_eval is not None)
    out_index = {name: i for i, name in enumerate(model.output_names)}
    analytic = bool(model.spec.jacobian)

    def output(y_now: np.ndarray, t_now: float, name: str, **temporary: float) -> float:
        """One output at one state, with some parameters changed for the question only."""
        saved = {k: getattr(params, k) for k in temporary}
        for k, v in temporary.items():
            setattr(params, k, v)
        value = session.outputs(params, np.array([t_now]), y_now[None, :])[0][out_index[name]]
        for k, v in saved.items():
            setattr(params, k, v)
        return float(value)

    def outputs_at(t_now: np.ndarray, y_rows: np.ndarray) -> dict[str, np.ndarray]:
        return dict(zip(model.output_names, session.outputs(params, t_now, y_rows).T))

    def impact_begins(y_now: np.ndarray, out_now: list[float]) -> None:
        named = {k: out_now[out_index[k]] for k in ("v_Bx", "v_By", "delta_rate", "T")}
        session.set_atol(contact_atol(scene, consts, free_atol, y_now, named))
        if coulomb:
            v_Bx, tip_speed = named["v_Bx"], math.hypot(named["v_Bx"], named["v_By"])
            F_now = out_now[out_index["F"]]
            hold = output(y_now, t, "F_f", slip=0.0) if abs(v_Bx) <= 1e-12 * tip_speed else 0.0
            params.slip = slip_at_contact(v_Bx, tip_speed, F_now, hold, scene.contact.friction)

    y = np.concatenate([scene.q0, scene.u0, np.zeros(model.nstate - 2 * scene.n)])
    t = 0.0
    if coulomb:
        params.slip = 1.0  # free flight: no friction, whatever the state
    first_row = session.outputs(params, np.array([t]), y[None, :])
    first = first_row[0].tolist()  # Python floats: the switch logic works on scalars
    delta0, rate0 = first[out_index["delta"]], first[out_index["delta_rate"]]
    touching = delta0 >= -1e-12 * max(1.0, sum(scene.chain.length))
    tip_speed = abs(first[out_index["v_Bx"]]) + abs(first[out_index["v_By"]])
    if abs(rate0) <= 1e-12 * tip_speed:  # rounding of a tangential start
        rate0 = 0.0
    phase = "elastic" if touching and rate0 > 0 else "free"
    t_end = scene.solver.t_end if scene.solver.t_end is not None else scene.solver.t_max
    if touching and rate0 <= 0 and scene.solver.t_end is None:
        # a degenerate start: touching, but moving along or away from the surface
        session.close(scene)
        return _no_impact_at_start(scene, model, y, first, rate0, started)

    ts, ys, outs, labels = [np.array([t])], [y[None, :]], [first_row], [(phase, 1)]
    dense_breaks: list[float] = [t]
    dense_pieces: list[StepPolynomials] = []
    sampler = TimeSampler(t_eval) if t_eval is not None else None
    spans: list[PhaseSpan] = []
    impacts: list[Impact] = []
    n_samples = 1
    if phase == "elastic":
        impacts.append(Impact(t_start=t, i_start=0))
        impact_begins(y, first)
    status, message = "ok", ""

    def record(phase_now: str, seg_t: np.ndarray, seg_y: np.ndarray, seg_d: np.ndarray | None) -> np.ndarray:
        """Keep a segment's samples (and polynomials, and t_eval samples); return its outputs."""
        nonlocal n_samples
        seg_out = session.outputs(params, seg_t, seg_y)
        ts.append(seg_t), ys.append(seg_y), outs.append(seg_out)
        labels.append((phase_now, len(seg_t)))
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
                                  "shorten solver.t_end", phase, t)
            rule = rules[phase]
            params.phase = LAW_CODE[rule.law]
            events = rule.events
            if coulomb and phase != "free":
                events = events + SLIP_ENDS[params.slip]
            if analytic:  # the analytic Jacobian does not know the constraint forces
                session.use_jacobian(phase != "sustained" and not (coulomb and phase != "free" and params.slip == 0))
            try:
                seg_t, seg_y, seg_d, fired = session.segment(params, phase, t, y, t_end, events)
            except SolverError as error:
                partial = getattr(error, "partial", None)
                if partial is not None and len(partial[0]):
                    record(phase, *partial)
                raise
            seg_out = record(phase, seg_t, seg_y, seg_d)
            friction_state = SLIP_LABEL[params.slip] if coulomb and phase != "free" else ""
            if friction_state == "stick":
                _check_stick(seg_out, out_index, scene.contact.friction, phase, float(seg_t[-1]))
            t, y, last = float(seg_t[-1]), seg_y[-1].copy(), seg_out[-1].tolist()
            spans.append(PhaseSpan(phase, spans[-1].t1 if spans else 0.0, t, fired[0] if fired else "t_end",
                                   friction_state))
            if not fired:
                status, message = _end_without_event(scene, impacts, phase)
                break
            impact = impacts[-1] if impacts else None
            fired_all = fired
            contact_fired = [e for e in fired if e not in SLIP_EVENTS]
            if coulomb and len(contact_fired) < len(fired) and phase != "free":
                old = params.slip
                hold = output(y, t, "F_f", slip=0.0)
                params.slip = slip_after(fired, old, last[out_index["F"]], hold, scene.contact.friction)
                impact.stick_slip.append((t, SLIP_LABEL[old], SLIP_LABEL[params.slip]))
            if not contact_fired:
                continue  # only the friction state changed
            fired = contact_fired
            new_phase = _next_phase(phase, fired, plastic, params, consts)
            if new_phase == "elastic" and phase == "free":  # a new impact
                set_params(model, params, delta_m=0.0, delta_r=0.0, R_res=consts.R)
                impacts.append(Impact(t_start=t, i_start=n_samples - 1))
                impact = impacts[-1]
                impact_begins(y, last)
            elif new_phase == "restitution" and phase in ("elastic", "elastoplastic"):
                delta_m, P_m = last[out_index["delta"]], last[out_index["F"]]
                delta_r = residual(delta_m, consts.delta_c) if plastic else 0.0
                R_res = unloading_radius(P_m, delta_m, delta_r, consts.E_star) if plastic else consts.R
                set_params(model, params, delta_m=delta_m, delta_r=delta_r, R_res=R_res)
                impact.delta_max, impact.P_max, impact.delta_r, impact.R_res = delta_m, P_m, delta_r, R_res
                if model.spec.sustained and len(impacts) > 1 and chattering(impacts[-2], impacts[-1]) and \
                        output(y, t, "F", phase=LAW_CODE["sustained"]) > 0.0:
                    new_phase = "sustained"  # hold the tip: no rebound into ever shorter flights
            if impact is not None and phase != "free":
                impact.switches.append((t, phase, new_phase))
            if coulomb and "free" not in (phase, new_phase) and params.slip != 0.0 and \
                    len(contact_fired) == len(fired_all):
                here = {k: last[out_index[k]] for k in ("v_Bx", "v_By", "F")}
                _slip_direction_check(params, here, lambda: output(y, t, "F_f", slip=0.0),
                                      scene.contact.friction, t, impact)
            if new_phase == "free":
                impact.t_end, impact.i_end = t, n_samples - 1
                if scene.solver.t_end is None:
                    break
                if phase == "sustained":  # the surface is where the tip left it
                    set_params(model, params, y_s=params.y_s - last[out_index["delta"]])
                session.set_atol(free_atol)
            phase = new_phase
    except SolverError as error:
        status, message = "failed", str(error)

    trajectory = Trajectory(
        t=np.concatenate(ts), y=np.concatenate(ys),
        phase=np.repeat(np.array([name for name, _ in labels]), [count for _, count in labels]),
        outputs={name: col for name, col in zip(model.output_names, np.concatenate(outs).T)},
    )
    stats = session.stats()
    if status != "failed":  # a failed integrator is not handed to the next run
        session.close(scene)
    stats.update(segments=len(spans), samples=n_samples, wall_s=time.perf_counter() - started)
    sampled = Trajectory(*sampler.gathered(model.nstate, model.output_names)) if sampler else None
    sol = DenseSolution(dense_breaks, dense_pieces, model.nstate) if dense_output else None
    return SimulationResult(scene, "c", status, message, trajectory, spans, impacts, stats, sampled, sol)


def _slip_direction_check(params, here: dict[str, float], holding_force: Callable[[], float],
                          mu: float, t: float, impact: Impact) -> None:
    """After a contact event with no stick-slip event: a slip whose tip has stopped, or moves
    the other way, is decided as at a stop. Its own event can coincide with the contact event
    and go unreported: a single bar stops sliding exactly when it stops penetrating.
    `here` holds v_Bx, v_By and F at the switch."""
    v_x, v_y = here["v_Bx"], here["v_By"]
    if v_x * params.slip > 1e-9 * math.hypot(v_x, v_y):
        return
    old = params.slip
    params.slip = slip_when_stopped(here["F"], holding_force(), mu)
    if params.slip != old:
        impact.stick_slip.append((t, SLIP_LABEL[old], SLIP_LABEL[params.slip]))


def _end_without_event(scene: Scene, impacts: list[Impact], phase: str) -> tuple[str, str]:
    """Status and message of a run that reached its end time rather than an event."""
    if scene.solver.t_end is not None:
        return "ok", ""
    if not impacts:
        return "no-impact", f"no contact within solver.t_max = {scene.solver.t_max:g} s"
    return "ok", (f"no separation within solver.t_max = {scene.solver.t_max:g} s: the tip came to rest "
                  f"on the surface (phase {phase!r}); the summary's impact has no end")


def _check_stick(out: np.ndarray, out_index: dict[str, int], mu: float, phase: str, t: float) -> None:
    """A stuck tip never needs more than mu F: if it did, a slip event was missed."""
    F, F_f = out[:, out_index["F"]], out[:, out_index["F_f"]]
    excess = np.abs(F_f) - mu * F
    if np.max(excess) > 1e-6 * mu * max(float(np.max(F)), 1e-300):
        raise SolverError("the stuck tip needed a friction force beyond mu F and no slip event "
                          "fired; tighten solver.rtol", phase, t)


def _no_impact_at_start(scene: Scene, model: CompiledModel, y: np.ndarray, first: list[float],
                        rate0: float, started: float) -> SimulationResult:
    motion = "along" if rate0 == 0 else "away from"
    trajectory = Trajectory(np.array([0.0]), y[None, :], np.array(["free"]),
                            {name: np.array([v]) for name, v in zip(model.output_names, first)})
    return SimulationResult(scene, "c", "no-impact",
                            f"the tip touches the surface but moves {motion} it (d(delta)/dt = "
                            f"{rate0:.3g} m/s): no impact", trajectory, [], [],
                            {"segments": 0, "samples": 1, "wall_s": time.perf_counter() - started})


def _next_phase(phase: str, fired: list[str], plastic: bool, params, consts: ContactConstants) -> str:
    """The phase after `phase` when the events `fired` (MODEL section 4)."""
    if phase == "free":
        return "elastic"
    if phase == "sustained":
        return "free"  # lift-off
    if phase in ("elastic", "elastoplastic"):
        return "restitution" if "max_compression" in fired else "elastoplastic"
    if phase == "restitution":
        return "free" if ("separation" in fired or "contact" in fired) else "reloading"
    # reloading: back past delta_m onto the loading curve it left, or unloading again
    if "passes_delta_m" in fired:
        return "elastoplastic" if plastic and params.delta_m >= YIELD_ONSET * consts.delta_c else "elastic"
    return "restitution"
