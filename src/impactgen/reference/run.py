"""A run of the reference engine: the phase loop over the points, one solve_ivp segment per
phase, the events applied point by point, the samples recorded and checked."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..dense import DenseSolution, TimeSampler
from ..errors import SceneError, SolverError
from ..results import PhaseSpan, Ready, Trajectory
from ..scene import Scene
from .events import segment_events, split_event
from .machine import begin_slip, end_impact, fix_impact_speed, normal_start, release_overloaded, segment_label, switch
from .model import ContactPoint, ReferenceModel
from .result import PointImpact, PointIntegrals, ReferenceResult
from .segment import METHODS, Segment, solve_ivp_segment

MAX_SEGMENTS = 100_000  # phase and stick-slip switches in one run: beyond this, stop
FLOOR_DEPTH = 0.01  # the floor net: deeper than this fraction of the shortest link below the surface fails
START_TOUCH = 1e-12  # a point within this fraction of the chain's length (1 m at least) touches at the start


def simulate(scene: Scene, method: str = "Radau", rtol: float | None = None,
             atol: float | None = None, model: ReferenceModel | None = None,
             integrate=solve_ivp_segment, engine: str = "reference", t_eval: np.ndarray | None = None,
             dense_output: bool = False) -> ReferenceResult:
    """Run `scene` through the phases with solve_ivp; the result has the C engine's shape.
    `model` and `integrate` let a benchmark put another right-hand side or integrator
    under the same phase loop. solver.max_steps is checked after each phase segment (solve_ivp
    has no step limit of its own). A failure ends the run with status "failed".

    Every joint that can reach the surface and the tip are contact points, each with its own
    phase and impacts (`PointImpact`); a run to separation ends when, after the first
    contact, no point touches the surface any more."""
    if method not in METHODS and integrate is solve_ivp_segment:
        raise SceneError("method", f"{method!r} is not one of {', '.join(METHODS)}")
    run = _Run(scene, model or ReferenceModel.from_scene(scene), method, rtol, atol, integrate, engine, t_eval,
               dense_output)
    return run.no_impact() or run.to_the_end()


@dataclass
class _Recorder:
    """The samples of the run, segment by segment, with their outputs and labels."""

    t: list = field(default_factory=list)
    y: list = field(default_factory=list)
    phase: list = field(default_factory=list)
    outputs: list = field(default_factory=list)
    count: int = 0

    def add(self, model: ReferenceModel, t: np.ndarray, y: np.ndarray, label: str) -> None:
        """Samples of one segment, listed as `label` (the phases of the points in contact)."""
        self.t.append(t)
        self.y.append(y)
        self.phase.append(np.full(len(t), label))
        self.outputs.append(model.outputs(t, y))
        self.count += len(t)

    def trajectory(self, state_names: tuple[str, ...]) -> Trajectory:
        outputs = {k: np.concatenate([o[k] for o in self.outputs]) for k in self.outputs[0]}
        return Trajectory(np.concatenate(self.t), np.concatenate(self.y), np.concatenate(self.phase), outputs,
                          state_names)


def under_floor(model: ReferenceModel, t: np.ndarray, y: np.ndarray) -> tuple[int, str] | None:
    """The floor net, written again from the chain: point k's height is sum_{i <= k} L_i sin q_i,
    from a free chain's base at y_0 (point 0, then checked too). The first sample where a point
    lies deeper below the surface than FLOOR_DEPTH of the shortest link, and the message naming
    it; None if none."""
    n, free = model.n, model.chain.free
    heights = np.cumsum(model.chain.L[:, None] * np.sin(y[:, :n].T), axis=0)
    if free:  # every point moves with the base, itself point 0
        heights = np.vstack([np.zeros(len(t)), heights]) + y[:, n + 1]
    heights = heights - model.contact.y_s
    below = heights < -FLOOR_DEPTH * model.chain.L.min()
    hits = np.flatnonzero(below.any(axis=0))
    if not len(hits):
        return None
    k = int(hits[0])
    point = int(np.flatnonzero(below[:, k])[0]) + (0 if free else 1)  # its index: 0 the base, n the tip
    name = "the tip" if point == n else ("the base" if point == 0 else f"joint {point}")
    return k, (f"{name} is {-heights[point, k]:.3g} m below the surface at t = {t[k]:.6g} s (deeper than "
               f"{100 * FLOOR_DEPTH:g} % of the shortest link, beyond any contact's depth): the chain went "
               "through the surface")


def coincident(model: ReferenceModel, events: dict, fired: list[str], t_before: float, y_before: np.ndarray,
               t: float, y: np.ndarray) -> list[str]:
    """The events of the points without one in `fired` that crossed in their direction in the
    segment's last step, from (t_before, y_before) to the event point (t, y): their roots lie
    within rounding of the first one's, at or past it. solve_ivp reports the roots in a step in
    time order up to the first terminal one, so another point's a rounding later went
    unreported (both ends of a rod lying flat on the surface reach their maximum compression at
    once), as a root finder that reports every root at the time it returns would not. A point
    with an event keeps the one it had (at a reload's peak, back at delta_m within rounding, it
    turns: it does not pass delta_m)."""
    if not fired:
        return []
    switching = {id(split_event(model, name)[0]) for name in fired}
    crossed = []
    for name, event in events.items():
        if id(split_event(model, name)[0]) in switching:
            continue
        now, then = event(t, y), event(t_before, y_before)
        if (event.direction < 0 and then > 0 >= now) or (event.direction > 0 and then < 0 <= now):
            crossed.append(name)
    return crossed


class _Run:
    """One run as the phase loop goes: the model with its points' phases, the time and state,
    the samples, spans, impacts and each point's integrals, the counters and dense pieces."""

    def __init__(self, scene: Scene, model: ReferenceModel, method: str, rtol: float | None, atol: float | None,
                 integrate, engine: str, t_eval: np.ndarray | None, dense_output: bool):
        self.started = time.perf_counter()
        self.scene, self.model, self.method, self.integrate = scene, model, method, integrate
        self.engine = engine
        self.rtol = scene.solver.rtol if rtol is None else rtol
        atol_q = scene.solver.atol if atol is None else atol
        self.state_names = model.state_names
        self.nstate = len(self.state_names)  # q, u, the works, the impulses
        energy_scale = max(sum(scene.chain.mass) * max(scene.chain.gravity, 1.0) * sum(scene.chain.length), 1e-30)
        self.atol_integrals = atol_q * energy_scale
        self.atol = np.full(self.nstate, atol_q)
        self.atol[2 * model.dof:] = self.atol_integrals
        self.dense_output = dense_output
        self.dense = dense_output or t_eval is not None
        self.sampler = TimeSampler(t_eval) if t_eval is not None else None
        self.breaks: list[float] = [0.0]
        self.pieces: list = []
        self.t_final = scene.solver.t_end if scene.solver.t_end is not None else scene.solver.t_max
        self.to_separation = scene.solver.t_end is None
        self.t, self.y = 0.0, model.initial_state(scene)
        self.rec = _Recorder()
        self.integrals = PointIntegrals(model)
        self.impacts: list[PointImpact] = []
        self.spans: list[PhaseSpan] = []
        self.stats = {"nsteps": 0, "nfev": 0, "njev": 0}
        self.status, self.message = "ok", ""
        touch = START_TOUCH * max(1.0, sum(scene.chain.length))
        self.start = {id(p): normal_start(model, self.y, p, touch) for p in model.points}
        for p in model.points:  # touching and moving into the surface: in contact from the start
            touching, rate = self.start[id(p)]
            p.phase = "elastic" if touching and rate > 0 else "free"

    def no_impact(self) -> ReferenceResult | None:
        """A run to separation whose tip starts on the surface without moving into it, no point
        in contact: no impact (docs/model.md section 5b; as the C engine decides)."""
        model = self.model
        touching, rate = self.start[id(model.tip)]
        if not (touching and rate <= 0 and self.to_separation and not model.touching()):
            return None
        self.rec.add(model, np.array([0.0]), self.y[None, :], "free")
        message = f"the tip touches the surface but does not approach it (d(delta)/dt = {rate:.3g} m/s): no impact"
        stats = {"nsteps": 0, "nfev": 0, "njev": 0, "segments": 0, "samples": 1}
        return ReferenceResult(self.scene, self.engine, "no-impact", message, Ready(self.rec.trajectory(self.state_names)),
                               Ready([]), [], Ready(stats), several_points=len(model.points) > 1)

    def to_the_end(self) -> ReferenceResult:
        """The run from its start, segment by segment, to separation or to its end time."""
        self.begin_contacts()
        try:
            while self.next_segment():
                pass
        except SolverError as error:
            self.status, self.message = "failed", str(error)
        return self.result()

    def begin_contacts(self) -> None:
        """The impacts of the points in contact at the start, and the first sample."""
        model, y = self.model, self.y
        for point in model.touching():
            begin_slip(model, y, point)
        for point in model.touching():
            point.impact = PointImpact(t_start=0.0, i_start=0, point=point.name)
            self.integrals.mark(point.impact, "begin", point)
            point.impact.own["v_n0"] = -model.delta_and_rate(y, point)[1]
            fix_impact_speed(model, y, point)
            self.impacts.append(point.impact)
        release_overloaded(model, y, self.t)
        self.rec.add(model, np.array([self.t]), y[None, :], segment_label(model)[0])

    def next_segment(self) -> bool:
        """Integrate one phase segment to its first event, record it, apply its events. False
        when the run ends."""
        model = self.model
        in_contact = model.touching()
        label, friction = segment_label(model)
        if len(self.spans) >= MAX_SEGMENTS:
            raise SolverError(f"more than {MAX_SEGMENTS} phase switches; shorten solver.t_end", label, self.t)
        events = segment_events(model, self.y)
        seg = self.integrate_segment(in_contact, label, events)
        self.record(seg, in_contact, label)
        before = (float(seg.t[-2]), seg.y[-2]) if len(seg.t) > 1 else (self.t, self.y)
        self.t, self.y = float(seg.t[-1]), seg.y[-1, :self.nstate].copy()
        fired = seg.fired + coincident(model, events, seg.fired, *before, self.t, seg.y[-1])
        self.spans.append(PhaseSpan(label, self.spans[-1].t1 if self.spans else 0.0, self.t,
                                    fired[0] if fired else "t_end", friction))
        if not fired:
            self.ended_without_event()
            return False
        return not self.apply(fired)

    def integrate_segment(self, in_contact: list[ContactPoint], label: str, events: dict) -> Segment:
        """One segment from (t, y), each point in contact integrating its own works and
        impulses as extra states when several are; a failure keeps the samples it made."""
        more = self.integrals.extra_states(in_contact)
        y0 = np.concatenate([self.y, np.zeros(more)]) if more else self.y
        atol = np.concatenate([self.atol, np.full(more, self.atol_integrals)]) if more else self.atol
        extra = {"dense": True} if self.dense else {}
        tip = self.model.tip  # the integrators pass point n's phase on to rhs (ReferenceModel.rhs)
        try:
            seg = self.integrate(self.model, tip.phase, self.t, y0, self.t_final, events, self.method, self.rtol, atol,
                                 **extra)
        except SolverError as error:
            partial = getattr(error, "partial", None)
            if partial is not None and len(partial[0]):
                self.rec.add(self.model, partial[0], partial[1][:, :self.nstate], label)
            raise
        for key in ("nsteps", "nfev", "njev"):
            self.stats[key] += getattr(seg, key)
        return seg

    def record(self, seg: Segment, in_contact: list[ContactPoint], label: str) -> None:
        """Keep a segment's samples, its points' integrals and its dense pieces, after the
        floor net and the step limit: either fails the run (kept up to the sample found)."""
        model, nstate = self.model, self.nstate
        seg_y = seg.y[:, :nstate]
        below = under_floor(model, seg.t, seg_y)
        if below is not None:  # kept up to the sample found under the floor
            k = below[0]
            self.rec.add(model, seg.t[:k + 1], seg_y[:k + 1], label)
            self.integrals.sums = self.integrals.at(in_contact, self.y, seg.y[k])
            raise SolverError(below[1], label, float(seg.t[k]))
        self.rec.add(model, seg.t, seg_y, label)
        if len(seg.t):
            self.integrals.sums = self.integrals.at(in_contact, self.y, seg.y[-1])
        if seg.nsteps > self.scene.solver.max_steps:
            raise SolverError(f"{seg.nsteps} steps in one phase, more than solver.max_steps = "
                              f"{self.scene.solver.max_steps}", label, float(seg.t[-1]))
        if self.dense and seg.sol is not None and len(seg.t):
            piece = seg.sol if seg.y.shape[1] == nstate else (lambda tt, sol=seg.sol: sol(tt)[:nstate])
            self.breaks.append(float(seg.t[-1]))
            self.pieces.append(piece)
            if self.sampler is not None:
                self.sampler.segment(float(seg.t[-1]), piece, model.outputs, label)

    def ended_without_event(self) -> None:
        """The run reached t_end (a run to a time), or t_max with no contact or no separation."""
        solver = self.scene.solver
        if not self.impacts and self.to_separation:
            self.status, self.message = "no-impact", f"no contact within solver.t_max = {solver.t_max:g} s"
        elif self.to_separation:
            self.message = f"no separation within solver.t_max = {solver.t_max:g} s"

    def apply(self, fired: list[str]) -> bool:
        """Apply the events that fired, point by point; True when a run to separation is over
        (a point separated and none touches)."""
        model = self.model
        by_point: dict[int, list[str]] = {}
        for name in fired:
            point, event = split_event(model, name)
            by_point.setdefault(id(point), []).append(event)
        separated = False
        for point in model.points:
            if id(point) in by_point:
                separated |= switch(model, point, by_point[id(point)], self.t, self.y, self.rec.count - 1,
                                    self.impacts, self.integrals)
        release_overloaded(model, self.y, self.t)
        return separated and self.to_separation and not model.touching()

    def result(self) -> ReferenceResult:
        """The result: an impact the run ends in is closed at the last sample."""
        model = self.model
        last = self.rec.y[-1][-1]
        for point in model.points:
            if point.impact is not None:
                end_impact(model, point, None, last, None, self.integrals)
        trajectory = self.rec.trajectory(self.state_names)
        self.stats.update(segments=len(self.spans), samples=self.rec.count,
                          wall_s=time.perf_counter() - self.started, method=self.method)
        sampled = (Trajectory(*self.sampler.gathered(self.nstate, list(trajectory.outputs)), self.state_names)
                   if self.sampler else None)
        sol = DenseSolution(self.breaks, self.pieces, self.nstate) if self.dense_output else None
        return ReferenceResult(self.scene, self.engine, self.status, self.message, Ready(trajectory), Ready(self.spans),
                               self.impacts, Ready(self.stats), sampled, sol, several_points=len(model.points) > 1)
