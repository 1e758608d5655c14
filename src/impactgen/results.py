"""Stage 8 of the pipeline: what a simulation returns, shaped like scipy's solve_ivp result.

`SimulationResult` holds the sampled trajectories, the phase spans, one record per impact and
two summaries: the run's (what a run to a time ends with) and its first impact's (MODEL
section 6, with its energy budget). As in solve_ivp, `t` is (n_points,) and `y` is
(n_states, n_points); a failure is a result with `success` False, not an exception. Both
engines fill the same types, so their results compare key by key.

The phase spans and impacts are impacts.py's, the summaries summaries.py's, the C engine's
records records.py's; the names of theirs that users and the other modules import from here
are listed in `__all__`.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Generic, TypeVar

import numpy as np

from .codegen.spec import point_name, point_number
from .dense import NO_DENSE_OUTPUT, DenseSolution, NoDenseOutput
from .impacts import COEFFICIENT_UNITS, COEFFICIENTS, IMPACT_UNITS, Impact, PhaseSpan, first_of, impact_coefficients
from .records import Tallied, TallyRecords
from .scene import Scene, Solver, replace_solver
from .summaries import (BUDGET, ENERGY_TERMS, SUMMARY_LATER, SUMMARY_LEADING, energy_balance, energy_budget,
                        first_impact_summary, from_tally, run_summary)
from .validity import YieldScale, energy_warning, frozen_friction_warning, validity_warnings

__all__ = [  # defined here, then kept where they were first imported from (impacts, summaries, records)
    "OUTPUT_UNITS", "Ready", "Trajectory", "Columns", "SimulationResult",
    "PhaseSpan", "Impact", "first_of", "impact_coefficients", "COEFFICIENT_UNITS", "COEFFICIENTS", "IMPACT_UNITS",
    "energy_balance", "SUMMARY_LEADING", "SUMMARY_LATER", "ENERGY_TERMS", "BUDGET", "Tallied", "TallyRecords",
    "point_name", "point_number",
]

Part = TypeVar("Part")

# The scalar outputs every model computes at each sample (T1..Tn, the kinetic energy per
# link, come beside them), with their units.
OUTPUT_UNITS = {"x_B": "m", "y_B": "m", "v_Bx": "m/s", "v_By": "m/s", "delta": "m",
                "delta_rate": "m/s", "F": "N", "F_f": "N", "T": "J", "V": "J"}


@dataclass(frozen=True)
class Ready(Generic[Part]):
    """The maker of a result's part that is made already (the reference engine makes its
    parts as it runs; a pickled result carries them made)."""

    value: Part

    def __call__(self) -> Part:
        return self.value


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
        impulses P_normal (N s)[, P_friction (N s)], then each joint's with contact code
        (W_normal_Jk, ...); `state_names` names the rows (8 for the paper's scene).
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
        The run: its end state, energy budget over the whole run, the impacts of every
        contact point (counted, and per point), the time sustained contact began. For a run
        to separation it is the first impact's.
    first_impact : dict
        The run's first impact alone, at whichever point (MODEL section 6), with its energy
        budget.
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
            return from_tally(self.tallied[1], self.n, self.impact_records, self.given_scene.free)
        return first_impact_summary(self)

    @property
    def summary(self) -> dict[str, Any]:
        """The run (for a run to separation, its first impact: the same dict), computed on first
        use and kept."""
        return self.first_impact if self._to_separation() else self._whole_run

    @cached_property
    def _whole_run(self) -> dict[str, Any]:
        """The summary of a run to a time (or of a failed run)."""
        return run_summary(self) if self.tallied is None else from_tally(self.tallied[0], self.n, self.impact_records,
                                                                         self.given_scene.free)

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
        """The links' angles, rad (n rows)."""
        return self.y[: self.n]

    @property
    def u(self) -> np.ndarray:
        """The links' angular speeds, rad/s (n rows)."""
        dof = self.given_scene.dof
        return self.y[dof: dof + self.n]

    @property
    def base(self) -> np.ndarray | None:
        """A free chain's base point: x_0, y_0 (m) and their rates u_x0, u_y0 (m/s), 4 rows; None
        for a pinned chain."""
        if not self.given_scene.free:
            return None
        n, dof = self.n, self.given_scene.dof
        return self.y[[n, n + 1, dof + n, dof + n + 1]]

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
        impact.T_before, impact.T_after, works = energy_budget(traj, i0, i1)
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


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: write them as null."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
