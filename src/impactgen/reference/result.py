"""The reference engine's records: each point's impacts with its own works and coefficients,
each point's integrals as the run goes, and the result that gathers them."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from ..results import Impact, SimulationResult, impact_coefficients, point_name

if TYPE_CHECKING:
    from .model import ContactPoint, ReferenceModel


@dataclass
class PointImpact(Impact):
    """An impact of one contact point. `W_normal` and `W_friction` (and the energy budget) are
    those of every contact force over the impact's time, as for any impact; `W_normal_point`
    and `W_friction_point` are this point's own, and the impulses and coefficients
    (docs/model.md section 9) are this point's, from its own normal speed and forces."""

    # its integrals (W_normal[, W_friction], P_normal[, P_friction]) at its start, maximum
    # compression and end, and its normal speed at its start and end; filled by the engine
    own: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def use_own_values(self, names: tuple[str, ...]) -> None:
        """This point's works, impulses and coefficients from its own integrals (`names`:
        the integrals' names, as the state carries them)."""
        marks = {key: dict(zip(names, values)) for key, values in self.own.items() if key in ("begin", "at_max", "end")}
        if "begin" not in marks or "end" not in marks:
            return
        begin, end = marks["begin"], marks["end"]
        self.W_normal_point = end["W_normal"] - begin["W_normal"]
        self.W_friction_point = end.get("W_friction", 0.0) - begin.get("W_friction", 0.0)
        self.v_n0 = self.own["v_n0"]
        if self.i_end is not None and "at_max" in marks:
            values = impact_coefficients(begin, marks["at_max"], end, self.own["v_n0"], self.own["v_n1"])
            for name, value in values.items():
                setattr(self, name, value)


@dataclass
class ReferenceResult(SimulationResult):
    """The reference engine's result: its impacts are those of each contact point
    (`PointImpact`), with each point's own works and coefficients."""

    several_points: bool = False  # joints can touch: the points' own integrals differ from the totals

    @cached_property
    def impacts(self) -> list[Impact]:
        """The impacts (their energies from the samples), each with its point's own values."""
        impacts = SimulationResult.impacts.func(self)
        names = self.trajectory.state_names
        names = names[names.index("W_normal"):]  # the works, then the impulses
        if self.several_points:  # a single point: its own values are the totals, as made already
            for impact in impacts:
                impact.use_own_values(names)
        return impacts

    @property
    def point_works(self) -> dict[str, dict[str, float]]:
        """The works of each point's own forces over the run, by point name ("base" of a free
        chain, "joint 1", ..., "tip"), as {"W_normal": J, "W_friction": J}; their sums are the run's W_normal and
        W_friction (every contact force acts within an impact of its point)."""
        first = 0 if "x_0" in self.trajectory.state_names else 1  # a free chain's base is point 0
        works = {point_name(k, self.n): {"W_normal": 0.0, "W_friction": 0.0} for k in range(first, self.n + 1)}
        for impact in self.impacts:
            works[impact.point]["W_normal"] += impact.W_normal_point
            works[impact.point]["W_friction"] += impact.W_friction_point
        return works


class PointIntegrals:
    """Each point's own works and impulses, summed as the run goes: a segment with one point
    in contact gives it the change of the state's totals; one with several integrates each
    point's own (extra states after the totals, for that segment only, so that a run with one
    point in contact at a time integrates exactly the states it always did)."""

    def __init__(self, model: "ReferenceModel"):
        self.model = model
        self.width = model.nstate - 2 * model.dof
        self.sums = {id(p): np.zeros(self.width) for p in model.points}

    def extra_states(self, touching: list["ContactPoint"]) -> int:
        return self.width * len(touching) if len(touching) > 1 else 0

    def at(self, touching: list["ContactPoint"], y_begin: np.ndarray, row: np.ndarray) -> dict[int, np.ndarray]:
        """The sums at a sample `row` (the extended state) of a segment that began at `y_begin`."""
        n, sums = self.model.dof, dict(self.sums)
        base = self.model.nstate
        if len(touching) == 1:
            p = touching[0]
            sums[id(p)] = sums[id(p)] + (row[2 * n:base] - y_begin[2 * n:base])
        elif touching:
            for j, p in enumerate(touching):
                sums[id(p)] = sums[id(p)] + row[base + j * self.width: base + (j + 1) * self.width]
        return sums

    def mark(self, impact: PointImpact, key: str, point: "ContactPoint") -> None:
        """Record the point's sums now in its impact as `key` ("begin", "at_max", "end")."""
        impact.own[key] = self.sums[id(point)].tolist()
