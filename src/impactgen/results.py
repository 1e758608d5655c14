"""Stage 8 of the pipeline: what a simulation returns, shaped like scipy's solve_ivp result.

`SimulationResult` holds the sampled trajectories, the phase spans, one record per impact and
two summaries: the run's (what a run to a time ends with) and its first impact's (MODEL
section 6, with its energy budget). As in solve_ivp, `t` is (n_points,) and `y` is
(n_states, n_points); a failure is a result with `success` False, not an exception. Both
engines fill the same types, so their results compare key by key.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Generic, NamedTuple, TypeVar

import numpy as np

from .codegen.spec import point_name, point_number
from .dense import NO_DENSE_OUTPUT, DenseSolution, NoDenseOutput
from .scene import Scene, Solver, replace_solver
from .validity import YieldScale, energy_warning, frozen_friction_warning, validity_warnings

Part = TypeVar("Part")

# The scalar outputs every model computes at each sample (T1..Tn, the kinetic energy per
# link, come beside them), with their units.
OUTPUT_UNITS = {"x_B": "m", "y_B": "m", "v_Bx": "m/s", "v_By": "m/s", "delta": "m",
                "delta_rate": "m/s", "F": "N", "F_f": "N", "T": "J", "V": "J"}


@dataclass
class PhaseSpan:
    phase: str  # "free", "elastic", "elastoplastic", "restitution", "reloading", "sustained"
    t0: float
    t1: float
    ended_by: str  # the event that ended it, or "t_end"
    slip_state: str = ""  # exact Coulomb friction: "slip+", "slip-" or "stick" during the span

    def to_dict(self) -> dict[str, Any]:
        out = {"phase": self.phase, "t0": self.t0, "t1": self.t1, "ended_by": self.ended_by}
        if self.slip_state:
            out["slip_state"] = self.slip_state
        return out


@dataclass
class Impact:
    """One impact: from first contact to separation, with the values fixed at its switches
    (by the engine) and its energies (filled from the samples when the result is made)."""

    t_start: float
    i_start: int  # sample index at first contact
    t_end: float | None = None  # separation; None if the run ended in contact
    i_end: int | None = None
    delta_max: float = 0.0  # m, at maximum compression
    P_max: float = 0.0  # N, the normal force there
    delta_r: float = 0.0  # m, permanent deformation (Eq. 12)
    R_res: float = 0.0  # m, radius of the unloading curve
    switches: list[tuple[float, str, str]] = field(default_factory=list)  # (t, from, to)
    stick_slip: list[tuple[float, str, str]] = field(default_factory=list)  # exact Coulomb: (t, from, to)
    T_before: float = math.nan  # J, kinetic energy at first contact
    T_after: float = math.nan  # J, at separation (or the end of the run)
    W_normal: float = 0.0  # J, work of the normal force over the impact (of every point's: the energy budget's)
    W_friction: float = 0.0  # J
    W_gravity: float = 0.0  # J
    W_normal_point: float = math.nan  # J, work of this point's own normal force over the impact
    W_friction_point: float = math.nan  # J, of its own friction force
    i_max: int | None = None  # sample index at (the latest) maximum compression
    # impulses and coefficients of restitution (docs/model.md section 9; COEFFICIENTS), from
    # the samples at its start, maximum compression and end; NaN until it has ended
    v_n0: float = math.nan  # m/s, the point's normal speed at first contact (negative approaching)
    P_c: float = math.nan  # N s, normal impulse of compression
    P_r: float = math.nan  # N s, of restitution
    P_t: float = math.nan  # N s, tangential (friction) impulse
    e_N: float = math.nan  # kinematic (Newton): -v_n(end) / v_n0
    e_P: float = math.nan  # kinetic (Poisson): P_r / P_c
    e_E: float = math.nan  # energetic (Stronge): sqrt(W_r / -W_c)
    friction_share: float = math.nan  # W_friction / (W_normal + W_friction): friction's share of the loss
    point: str = "tip"  # the contact point: "tip", or "joint k" (the end of link k)

    @property
    def duration(self) -> float | None:
        return None if self.t_end is None else self.t_end - self.t_start

    def coefficients(self) -> dict[str, float]:
        """The impulses and coefficients of restitution (COEFFICIENTS) by name."""
        return {name: getattr(self, name) for name in COEFFICIENTS}

    def to_dict(self) -> dict[str, Any]:
        """One row of the impacts table (JSON and DataFrame)."""
        return {
            "point": self.point, "t_start": self.t_start, "t_end": self.t_end, "duration": self.duration,
            "delta_max": self.delta_max, "delta_r": self.delta_r, "P_max": self.P_max,
            "R_res": self.R_res, "T_before": self.T_before, "T_after": self.T_after,
            "W_normal": self.W_normal, "W_friction": self.W_friction, "W_gravity": self.W_gravity,
            "W_normal_point": self.W_normal_point, "W_friction_point": self.W_friction_point,
            **self.coefficients(),
            "switches": _switch_list(self.switches), "stick_slip": _switch_list(self.stick_slip),
        }


def tip_impacts(impacts: list[Impact]) -> list[Impact]:
    """The tip's impacts: what a run's summaries and the impact laws are made of (the joints'
    impacts are listed beside them, each naming its point)."""
    return [impact for impact in impacts if impact.point == "tip"]


def _switch_list(items: list[tuple[float, str, str]]) -> list[dict[str, Any]]:
    """(t, from, to) switches as the summaries and the impacts table write them."""
    return [{"t": t, "from": a, "to": b} for t, a, b in items]


@dataclass(frozen=True)
class Ready(Generic[Part]):
    """The maker of a result's part that is made already (the reference engine makes its
    parts as it runs; a pickled result carries them made)."""

    value: Part

    def __call__(self) -> Part:
        return self.value


# The impulses and coefficients of restitution of an impact (docs/model.md section 9), with units.
COEFFICIENT_UNITS = {"v_n0": "m/s", "P_c": "N s", "P_r": "N s", "P_t": "N s", "e_N": "1", "e_P": "1", "e_E": "1",
                     "friction_share": "1"}
COEFFICIENTS = tuple(COEFFICIENT_UNITS)
IMPACT_UNITS = {"point": "", "t_start": "s", "t_end": "s", "duration": "s", "delta_max": "m", "delta_r": "m",
                "P_max": "N", "R_res": "m", "T_before": "J", "T_after": "J", "W_normal": "J",
                "W_friction": "J", "W_gravity": "J", "W_normal_point": "J", "W_friction_point": "J",
                **COEFFICIENT_UNITS}


def impact_coefficients(begin, at_max, end, v_n0: float, v_n1: float) -> dict[str, float]:
    """The impulses and coefficients (COEFFICIENTS) of an impact from its integrated states
    (dicts by state name, `Trajectory.states_at`: the works and the impulses) at its start, at its maximum
    compression and at its end, and the normal speed at its start and end. The C engine
    tallies the same arithmetic (tally.c, summarize_coefficients)."""
    W_c, W_r = at_max["W_normal"] - begin["W_normal"], end["W_normal"] - at_max["W_normal"]
    W_f = end.get("W_friction", 0.0) - begin.get("W_friction", 0.0)
    P_c, P_r = at_max["P_normal"] - begin["P_normal"], end["P_normal"] - at_max["P_normal"]
    ratio = W_r / -W_c if W_c != 0 else math.nan
    return {"v_n0": v_n0, "P_c": P_c, "P_r": P_r, "P_t": end.get("P_friction", 0.0) - begin.get("P_friction", 0.0),
            "e_N": -v_n1 / v_n0 if v_n0 != 0 else math.nan, "e_P": P_r / P_c if P_c != 0 else math.nan,
            "e_E": math.sqrt(ratio) if ratio >= 0 else math.nan,
            "friction_share": W_f / (W_c + W_r + W_f) + 0.0 if W_c + W_r + W_f != 0 else math.nan}


@dataclass
class Trajectory:
    """Samples at every accepted integrator step and at every switch (or at t_eval)."""

    t: np.ndarray  # (N,)
    y: np.ndarray  # (N, nstate): the states, in the columns `state_names` names
    phase: np.ndarray  # (N,) phase name of the step that ended at each sample
    outputs: Mapping[str, np.ndarray]  # x_B, y_B, v_Bx, v_By, delta, delta_rate, F, F_f, T1.., T, V
    # The columns of y by name, as the engine laid them out (the C model's own list,
    # build.CompiledModel.state_names): q1.., u1.., then the integrated states, the works
    # W_normal[, W_friction] and the impulses P_normal[, P_friction]. Read by name, never by
    # a count, so a model with other integrated states (one work per contact point) reads right.
    state_names: tuple[str, ...]

    def states_at(self, i: int) -> dict[str, float]:
        """The states at sample i by name."""
        return dict(zip(self.state_names, self.y[i].tolist()))

    def column(self, name: str) -> np.ndarray | None:
        """State `name` at every sample, or None if this model has no such state."""
        return self.y[:, self.state_names.index(name)] if name in self.state_names else None


class Columns(Mapping):
    """Named columns of a table of samples (rows are samples), read as views when asked
    for: a run's outputs without one array object per output made up front."""

    def __init__(self, index: Mapping[str, int], table: np.ndarray):
        self._index, self._table = index, table

    def __getitem__(self, name: str) -> np.ndarray:
        return self._table[:, self._index[name]]

    def __iter__(self):
        return iter(self._index)

    def __len__(self) -> int:
        return len(self._index)


class Tallied(NamedTuple):
    """A summary as the C engine tallied it during the run (tally.h's ig_summary, field
    for field): over the whole run, or over its first impact. NaN where there is nothing to
    report (t_impact, t_sustained)."""

    T0: float
    Tf: float
    delta_T: float
    delta_max: float
    delta_r: float
    P_max: float
    R_res: float
    t_contact: float
    t_impact: float
    t_sustained: float
    t_final: float
    W_normal: float
    W_friction: float
    W_gravity: float
    residual: float
    n_switches: int
    n_stick_slip: int
    impacts: int
    joint_impacts: int
    first_point: int  # k for joint k, n for the tip; 0 without an impact
    v_n0: float  # the first impact's impulses and coefficients (COEFFICIENTS), NaN until it ended
    P_c: float
    P_r: float
    P_t: float
    e_N: float
    e_P: float
    e_E: float
    friction_share: float
    y_final: tuple[float, ...]  # q, u, then the works and the impulses


_Y_FINAL = len(Tallied._fields) - 1  # y_final, the last field, is the rest of a record's values


class SummaryLayout(NamedTuple):
    """How the C engine's ig_summary record reads, made once per session from its cffi layout."""

    record: Any  # struct.Struct: every field as a Python value, in Tallied's order
    dtype: np.dtype  # the same record as a numpy structured dtype
    budget: Any  # struct.Struct: the BUDGET fields alone, in their order


class TallyRecords:
    """The C engine's two summaries (the run's, its first impact's) as the bytes of their C
    records, each made a `Tallied` when first indexed (a summary reads one of them; a sweep
    reads one's bytes and its energy budget, and makes no `Tallied`). Pickled as the tuple
    of both."""

    __slots__ = ("_layout", "_raw", "_made")

    def __init__(self, layout: SummaryLayout, raw: bytes):
        self._layout, self._raw, self._made = layout, raw, [None, None]

    @property
    def dtype(self) -> np.dtype:
        return self._layout.dtype

    def raw(self, k: int) -> bytes:
        """Summary k as the bytes of its C record (`dtype`)."""
        size = self._layout.record.size
        return self._raw[k * size:(k + 1) * size]

    def budget(self, k: int) -> tuple[float, ...]:
        """The BUDGET fields of summary k (without making its `Tallied`: a sweep's warnings
        read nothing else of it)."""
        return self._layout.budget.unpack_from(self._raw, k * self._layout.record.size)

    def __getitem__(self, k: int) -> Tallied:
        made = self._made[k]
        if made is None:
            record = self._layout.record
            values = record.unpack_from(self._raw, k * record.size)
            made = self._made[k] = Tallied._make(values[:_Y_FINAL] + (values[_Y_FINAL:],))
        return made

    def __len__(self) -> int:
        return 2

    def __reduce__(self):
        return tuple, ((self[0], self[1]),)


def _output(name: str, doc: str) -> property:
    """A read-only view of one output at the samples shown (every step, or t_eval)."""
    return property(lambda self: self._shown.outputs[name], doc=doc)


@dataclass
class SimulationResult:
    """The outcome of `impactgen.simulate`, shaped like scipy's solve_ivp result.

    Attributes
    ----------
    t : ndarray, shape (n_points,)
        Sample times in s: every integrator step and switch, or `t_eval` if it was given.
    y : ndarray, shape (n_states, n_points)
        The states at `t`: q1..qn (rad), u1..un (rad/s), W_normal (J)[, W_friction (J)], the
        impulses P_normal (N s)[, P_friction (N s)].
    q, u : ndarray, shape (n, n_points)
        Link angles and angular speeds.
    delta, delta_rate, F, F_f, x_B, y_B, v_Bx, v_By, T, V : ndarray, shape (n_points,)
        Penetration, its rate, normal and friction force, tip position and velocity,
        kinetic and potential energy (`OUTPUT_UNITS`). `outputs` has them all by name.
    v_B : ndarray, shape (2, n_points)
    T_links : ndarray, shape (n, n_points)
    phase : ndarray of str, shape (n_points,)
    sol : DenseSolution or NoDenseOutput
        y(t) anywhere in the run, if `dense_output=True` was asked for; otherwise a false
        value whose call raises a `SceneError` saying how to ask for it.
    status : {"ok", "no-impact", "failed"}
    success : bool
        False only for "failed"; `message` then says why, and the samples reach the failure.
    message : str
    phases : list of PhaseSpan
    impacts : list of Impact
        One record per impact; `impacts_frame()` gives them as a pandas DataFrame.
    summary : dict
        The run: its end state, energy budget over the whole run, impact count, the time
        sustained contact began. For a run to separation it is the first impact's.
    first_impact : dict
        The first impact alone (MODEL section 6), with its energy budget.
    warnings : list of str
        Where the result leaves the model's range of validity, and whether its energy
        budget fails to close (the integrator did not resolve the motion).
    stats : dict
        Integrator counters and the wall time.
    scene : Scene
        The scene as simulated: the one given, with simulate()'s solver options in it.
    solver : Solver
        Its solver settings (``scene.solver``), read without making that scene.

    Examples
    --------
    >>> import impactgen
    >>> result = impactgen.simulate(impactgen.load_scene("bouncing"))
    >>> result.summary["impacts"] > 100, result.first_impact["t_contact"] < 1e-3
    (True, True)
    >>> result.impacts_frame()[["t_start", "delta_max", "delta_r"]].shape[1]
    3
    """

    given_scene: Scene  # as simulate() was given it: `scene` is it under the run's `solver`
    engine: str
    status: str
    message: str
    # What makes `trajectory`, `phases` and `stats` when first asked for (a summary the C
    # engine tallied, and the warnings, need none of them: a sweep never makes them).
    make_trajectory: Callable[[], Trajectory]
    make_phases: Callable[[], list[PhaseSpan]]
    impact_records: list[Impact]  # as the engine recorded them: their energies wait for `impacts`
    make_stats: Callable[[], dict[str, Any]]
    sampled: Trajectory | None = None  # the samples at t_eval, if asked for
    sol: DenseSolution | NoDenseOutput | None = None  # NO_DENSE_OUTPUT once made
    contact: Mapping[str, YieldScale] | None = None  # each point's contact constants the engine ran with, for `warnings`
    tallied: "TallyRecords | tuple[Tallied, Tallied] | None" = None  # the C engine's summaries (run, first impact)
    solver: Solver | None = None  # the solver settings of the run (None given: the scene's own)

    def __post_init__(self) -> None:
        if self.solver is None:
            self.solver = self.given_scene.solver
        if self.sol is None:  # a call then says that dense output was not asked for, and how to ask
            self.sol = NO_DENSE_OUTPUT

    @property
    def scene(self) -> Scene:
        """The scene as simulated: the one given, with simulate()'s solver options (`solver`)
        in its [solver]. Made when first asked for: a run under options needs no new scene."""
        if self.solver is not self.given_scene.solver:
            self.given_scene = replace_solver(self.given_scene, self.solver)
        return self.given_scene

    @cached_property
    def trajectory(self) -> Trajectory:
        """The samples at every step."""
        return self.make_trajectory()

    @cached_property
    def phases(self) -> list[PhaseSpan]:
        """The phase spans."""
        return self.make_phases()

    @cached_property
    def stats(self) -> dict[str, Any]:
        """Integrator counters and the wall time."""
        return self.make_stats()

    def __getstate__(self) -> dict[str, Any]:
        """Pickled as plain data: the parts made first (what makes them may hold C objects)."""
        state = dict(self.__dict__)
        state["make_trajectory"], state["make_phases"], state["make_stats"] = (
            Ready(self.trajectory), Ready(self.phases), Ready(self.stats))
        return state

    @cached_property
    def impacts(self) -> list[Impact]:
        """The impacts, their energies read from the samples on first use (the summaries and
        the warnings need none of them: a sweep never reads them)."""
        _fill_impact_energies(self.trajectory, self.impact_records)
        return self.impact_records

    @cached_property
    def first_impact(self) -> dict[str, Any]:
        """The first impact (MODEL section 6), computed on first use and kept."""
        if self.tallied is not None:
            return _from_tally(self.tallied[1], self.n, self.impact_records)
        return _first_impact_summary(self)

    @property
    def summary(self) -> dict[str, Any]:
        """The run (for a run to separation, its first impact: the same dict), computed on first
        use and kept."""
        return self.first_impact if self._to_separation() else self._whole_run

    @cached_property
    def _whole_run(self) -> dict[str, Any]:
        """The summary of a run to a time (or of a failed run)."""
        return _run_summary(self) if self.tallied is None else _from_tally(self.tallied[0], self.n, self.impact_records)

    @property
    def summary_tallied(self) -> Tallied | None:
        """What `summary` is made from, as the C engine tallied it (None from the reference
        engine): a sweep reads its columns without building the dict."""
        if self.tallied is None:
            return None
        return self.tallied[1 if self._to_separation() else 0]

    @property
    def summary_record(self) -> tuple[bytes, np.dtype] | None:
        """`summary_tallied` as the bytes of its C record and their numpy dtype (None from the
        reference engine, and from a result that was pickled): a sweep joins a chunk's
        records into one array, with no Python value per field."""
        if not isinstance(self.tallied, TallyRecords):
            return None
        return self.tallied.raw(1 if self._to_separation() else 0), self.tallied.dtype

    def _to_separation(self) -> bool:
        return self.solver.t_end is None and self.status != "failed"

    # -- solve_ivp-like views -------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.given_scene.n

    @property
    def success(self) -> bool:
        return self.status != "failed"

    @property
    def _shown(self) -> Trajectory:
        return self.sampled if self.sampled is not None else self.trajectory

    @property
    def t(self) -> np.ndarray:
        return self._shown.t

    @property
    def y(self) -> np.ndarray:
        return self._shown.y.T

    @property
    def q(self) -> np.ndarray:
        return self.y[: self.n]

    @property
    def u(self) -> np.ndarray:
        return self.y[self.n: 2 * self.n]

    @property
    def state_names(self) -> list[str]:
        return list(self._shown.state_names)

    @property
    def phase(self) -> np.ndarray:
        return self._shown.phase

    @property
    def outputs(self) -> dict[str, np.ndarray]:
        out = dict(self._shown.outputs)
        out.setdefault("F_f", np.zeros_like(self.t))
        return out

    x_B = _output("x_B", "tip position along the surface (m)")
    y_B = _output("y_B", "tip height (m)")
    v_Bx = _output("v_Bx", "tip velocity along the surface (m/s)")
    v_By = _output("v_By", "tip velocity upwards (m/s)")
    delta = _output("delta", "penetration of the tip into the surface (m)")
    delta_rate = _output("delta_rate", "its rate (m/s)")
    F = _output("F", "normal contact force (N)")

    @property
    def F_f(self) -> np.ndarray:
        return self._shown.outputs.get("F_f", np.zeros_like(self.t))

    T = _output("T", "kinetic energy of the chain (J)")
    V = _output("V", "potential energy of gravity (J)")

    @property
    def v_B(self) -> np.ndarray:
        return np.vstack([self.v_Bx, self.v_By])

    @property
    def T_links(self) -> np.ndarray:
        return np.vstack([self._shown.outputs[f"T{i + 1}"] for i in range(self.n)])

    @property
    def W_normal(self) -> np.ndarray:
        return self._shown.column("W_normal")

    @property
    def point_works(self) -> dict[str, dict[str, float]]:
        """Each contact point's own works over the run, J: {"tip": {"W_normal": ...,
        "W_friction": ...}, "joint 2": {...}}, the points with contact code only. They add up
        to the run's W_normal and W_friction (the energy budget's terms)."""
        traj = self.trajectory
        joints = [int(name.rsplit("_J", 1)[1]) for name in traj.state_names if name.startswith("W_normal_J")]
        works = {}
        for point in ("tip", *(point_name(joint, self.n) for joint in joints)):
            first, last = _own_integrals(traj, 0, point), _own_integrals(traj, len(traj.t) - 1, point)
            works[point] = {"W_normal": last["W_normal"] - first["W_normal"],
                            "W_friction": last.get("W_friction", 0.0) - first.get("W_friction", 0.0)}
        return works

    @property
    def W_friction(self) -> np.ndarray:
        """Zero where the model has no friction work."""
        W_f = self._shown.column("W_friction")
        return W_f if W_f is not None else np.zeros_like(self.t)

    @cached_property
    def warnings(self) -> list[str]:
        """Where this result leaves the model's range of validity, and an energy budget that
        does not close (see validity.py)."""
        if isinstance(self.tallied, TallyRecords):  # the C engine's summary, as its record has it
            budget = self.tallied.budget(1 if self._to_separation() else 0)
        elif self.tallied is not None:  # the same, unpickled
            budget = tuple(getattr(self.summary_tallied, name) for name in BUDGET)
        else:
            summary = self.summary
            budget = (summary["T0"], summary["Tf"], *(summary["energy"][k] for k in ENERGY_TERMS))
        return (validity_warnings(self.scene, self.impact_records, self.contact) + energy_warning(self.scene, *budget)
                + self._frozen_friction_warning())

    def _frozen_friction_warning(self) -> list[str]:
        """friction_mode = "frozen": whether the tip's tangential speed reversed in contact."""
        if self.given_scene.contact.friction_mode != "frozen":
            return []
        traj = self.trajectory
        return frozen_friction_warning(self.scene, self.impact_records, traj.t, traj.y)

    def impacts_frame(self):
        """The impacts as a pandas DataFrame, one row per impact (units in `IMPACT_UNITS`).

        Returns
        -------
        pandas.DataFrame
            Columns point ("tip" or "joint k"), t_start, t_end, duration, delta_max, delta_r, P_max, R_res, T_before,
            T_after, W_normal, W_friction, W_gravity, switches (the phase switches as
            "from>to@t" joined by ";") and stick_slip.
        """
        from .errors import ImpactgenError
        try:
            import pandas as pd
        except ImportError:
            raise ImpactgenError("impacts_frame needs pandas: pip install 'impactgen[sweep]'") from None
        rows = []
        for record in self.impacts:
            row = record.to_dict()
            for key in ("switches", "stick_slip"):
                row[key] = ";".join(f"{s['from']}>{s['to']}@{s['t']:.17g}" for s in row[key])
            rows.append(row)
        return pd.DataFrame(rows, columns=list(IMPACT_UNITS) + ["switches", "stick_slip"])

    def to_json_dict(self) -> dict[str, Any]:
        return _finite({
            "scene": self.given_scene.name,
            "engine": self.engine,
            "status": self.status,
            "message": self.message,
            "warnings": self.warnings,
            "summary": self.summary,
            "first_impact": self.first_impact,
            "impacts": [i.to_dict() for i in self.impacts],
            "phases": [p.to_dict() for p in self.phases],
            "stats": self.stats,
        })


def _fill_impact_energies(traj: Trajectory, impacts: list[Impact]) -> None:
    """Kinetic energy before and after each impact and the works over it, from the samples;
    and its point's own works, impulses and coefficients, from the point's own integrals where
    the samples carry them (the C engine's; the reference engine keeps its points' apart)."""
    last = len(traj.t) - 1
    for impact in impacts:
        i0 = impact.i_start
        i1 = impact.i_end if impact.i_end is not None else last
        impact.T_before, impact.T_after, works = _budget(traj, i0, i1)
        impact.W_normal, impact.W_friction, impact.W_gravity = (
            works["W_normal"], works["W_friction"], works["W_gravity"])
        speed = "v_By" if impact.point == "tip" else f"v_y_J{point_number(impact.point, 0)}"
        begin, end = _own_integrals(traj, i0, impact.point), _own_integrals(traj, i1, impact.point)
        if not begin or speed not in traj.outputs:
            continue
        impact.W_normal_point = end["W_normal"] - begin["W_normal"]
        impact.W_friction_point = end.get("W_friction", 0.0) - begin.get("W_friction", 0.0)
        v_n = traj.outputs[speed]
        impact.v_n0 = float(v_n[i0])  # the rest once it has ended (as the C engine tallies them)
        if impact.i_end is not None and impact.i_max is not None:
            at_max = _own_integrals(traj, impact.i_max, impact.point)
            for name, value in impact_coefficients(begin, at_max, end, float(v_n[i0]), float(v_n[i1])).items():
                setattr(impact, name, value)


def _own_integrals(traj: Trajectory, i: int, point: str) -> dict[str, float]:
    """A contact point's own works and impulses at sample i, by the tip's state names (W_normal,
    P_normal, ...): a joint's are its states W_normal_J<k>, ... ({} where the samples have
    none); the tip's are the totals less every joint's works (its impulses are its own)."""
    states = traj.states_at(i)
    if point == "tip":
        for name, value in list(states.items()):
            if name.startswith("W_") and "_J" in name:
                states[name.rsplit("_J", 1)[0]] -= value
        return states
    suffix = f"_J{point_number(point, 0)}"
    return {name[:-len(suffix)]: value for name, value in states.items() if name.endswith(suffix)}


def _budget(traj: Trajectory, i0: int, i1: int) -> tuple[float, float, dict[str, float]]:
    """Kinetic energy at samples i0 and i1, and the energy budget between them."""
    T, V = traj.outputs["T"], traj.outputs["V"]
    T0, Tf, W_g = float(T[i0]), float(T[i1]), float(V[i0]) - float(V[i1])
    s0, s1 = traj.states_at(i0), traj.states_at(i1)
    return T0, Tf, energy_balance(T0, Tf, s1["W_normal"] - s0["W_normal"],
                                  s1.get("W_friction", 0.0) - s0.get("W_friction", 0.0), W_g)


def energy_balance(T0: float, Tf: float, W_n: float, W_f: float, W_g: float) -> dict[str, float]:
    """The works against the change of T from T0 to Tf, and what it leaves of them (residual)."""
    return {"W_normal": W_n, "W_friction": W_f, "W_gravity": W_g, "residual": (Tf - T0) - (W_n + W_f + W_g)}


def _first_impact_summary(result: SimulationResult) -> dict[str, Any]:
    """The first impact as MODEL section 6 lists it, with its energy budget (the whole run
    when there was no impact). An impact the run ended in has t_contact 0."""
    tips = tip_impacts(result.impacts)
    impact = tips[0] if tips else None
    i0 = impact.i_start if impact else 0
    i1 = impact.i_end if impact and impact.i_end is not None else len(result.trajectory.t) - 1
    budget = None  # the impact's energies were read from the same two samples when the result was made
    if impact is not None:
        budget = (impact.T_before, impact.T_after, energy_balance(impact.T_before, impact.T_after, impact.W_normal,
                                                                  impact.W_friction, impact.W_gravity))
    return _summary(result, i0, i1, [impact] if impact else [], count_open=False, budget=budget)


def _run_summary(result: SimulationResult) -> dict[str, Any]:
    """The whole run, from t = 0 to its last sample: the state it ends in and the energy
    budget over every impact and flight. Every impact starts from the undeformed surface in
    this model, so the deepest dent is the largest delta_r (not a sum); t_contact is the
    total time in contact, an impact the run ends in counted to the end."""
    return _summary(result, 0, len(result.trajectory.t) - 1, tip_impacts(result.impacts), count_open=True)


def _summary(result: SimulationResult, i0: int, i1: int, impacts: list[Impact],
             count_open: bool, budget: tuple[float, float, dict[str, float]] | None = None) -> dict[str, Any]:
    """Samples i0 to i1 and the impacts in them; the switches are the first impact's.
    `budget`: what `_budget` gives for the two samples, if already known."""
    traj, n = result.trajectory, result.n
    T0, Tf, energy = _budget(traj, i0, i1) if budget is None else budget
    t_last = float(traj.t[i1])
    first = impacts[0] if impacts else None
    deepest = max(impacts, key=_dent) if len(impacts) > 1 else first
    contact = sum((i.t_end if i.t_end is not None else t_last) - i.t_start
                  for i in impacts if i.t_end is not None or count_open)
    sustained = _sustained_start(result.phases)
    tallied = Tallied(
        T0, Tf, T0 - Tf, max([i.delta_max for i in impacts], default=0.0), deepest.delta_r if deepest else 0.0,
        max([i.P_max for i in impacts], default=0.0), deepest.R_res if deepest else 0.0, float(contact),
        first.t_start if first else math.nan, math.nan if sustained is None else sustained, t_last,
        *(energy[name] for name in ENERGY_TERMS), len(first.switches) if first else 0,
        len(first.stick_slip) if first else 0, len(tip_impacts(result.impacts)),
        sum(i.point != "tip" for i in result.impacts), point_number(result.impacts[0].point, n) if result.impacts else 0,
        *(getattr(first, name) if first else math.nan for name in COEFFICIENTS), tuple(traj.y[i1].tolist()))
    return _from_tally(tallied, n, impacts)


SUMMARY_LEADING = Tallied._fields[:9]  # T0 .. t_impact: the summary's first entries, in its order
SUMMARY_LATER = ("impacts", "joint_impacts", "first_point", "t_sustained", "t_final")  # its entries after the final state
ENERGY_TERMS = ("W_normal", "W_friction", "W_gravity", "residual")  # its energy budget, as energy_balance
BUDGET = ("T0", "Tf", *ENERGY_TERMS)  # what energy_warning reads of a summary, in its order


def _from_tally(s: Tallied, n: int, impacts: list[Impact]) -> dict[str, Any]:
    """A summary dict (MODEL section 6) from its values (as the C engine tallies them, or as
    `_summary` computes them from the samples); the lists of the first impact's switches
    from its record. NaN (nothing to report) is None here. Its keys: SUMMARY_LEADING, the
    lists and the final state, SUMMARY_LATER, "energy" with ENERGY_TERMS (a test holds them)."""
    tips = tip_impacts(impacts)  # the tally is the tip's
    first = tips[0] if tips else None
    (T0, Tf, delta_T, delta_max, delta_r, P_max, R_res, t_contact, t_impact, t_sustained, t_final,
     W_normal, W_friction, W_gravity, residual, _, _, count, joint_count, first_point, *coefficients, y) = s  # Tallied's fields
    return {"T0": T0, "Tf": Tf, "delta_T": delta_T, "delta_max": delta_max, "delta_r": delta_r,
            "P_max": P_max, "R_res": R_res, "t_contact": t_contact,
            "t_impact": None if t_impact != t_impact else t_impact,
            "switches": _switch_list(first.switches) if first else [],
            "stick_slip": _switch_list(first.stick_slip) if first and first.stick_slip else [],
            "u_final": list(y[n: 2 * n]), "q_final": list(y[:n]), "impacts": count,
            "joint_impacts": joint_count, "first_point": first_point or None,
            "t_sustained": None if t_sustained != t_sustained else t_sustained, "t_final": t_final,
            "energy": {"W_normal": W_normal, "W_friction": W_friction, "W_gravity": W_gravity,
                       "residual": residual},
            "coefficients": {name: None if v != v else v for name, v in zip(COEFFICIENTS, coefficients)}}


def _dent(impact: Impact) -> float:
    return impact.delta_r


def _sustained_start(phases: list[PhaseSpan]) -> float | None:
    return next((p.t0 for p in phases if p.phase == "sustained"), None)


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: write them as null."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
