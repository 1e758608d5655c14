"""One chunk of a sweep's cases, as a worker process or a Dask task runs it: in one C call
(batch.py) the cases the batch can take, the others case by case through `simulate`; the
rows gathered column by column (ChunkColumns) into what the driver (run.py) writes."""
from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..engines import simulate
from ..errors import ImpactgenError, SceneError
from ..codegen.spec import point_name
from ..export import trajectory_columns
from ..results import COEFFICIENTS, ENERGY_TERMS, SUMMARY_LATER, SUMMARY_LEADING
from ..scene import Scene, scene_from_dict, scene_with
from ..summaries import PER_POINT, chain_points
from . import batch, execute

STATUS_INVALID = "invalid"  # the scene checks refused the case's values


@dataclass(frozen=True)
class CaseOptions:
    """What every case of a sweep shares besides its scene."""

    keep_trajectories: frozenset[int] = frozenset()  # case indices whose samples are kept


def run_case(out: "ChunkColumns", base: Scene, index: int, overrides: dict[str, Any],
             keep_trajectory: bool = False) -> None:
    """One case of the scene `base`, added to the chunk's columns `out`: its summary as the
    engine tallied it (made columns for the whole chunk at once, `summary_columns`), status,
    message, warnings, time."""
    started = time.perf_counter()
    try:
        scene = scene_with(base, overrides)
    except SceneError as exc:
        out.add(None, STATUS_INVALID, str(exc), "", time.perf_counter() - started)
        return
    try:
        result = simulate(scene, record_steps=keep_trajectory, warn=False)  # the summaries need no steps
    except ImpactgenError as exc:  # a build failure: the row says so, the sweep goes on
        out.add(None, "failed", str(exc), "", time.perf_counter() - started)
        return
    if keep_trajectory:
        out.trajectories[index] = trajectory_columns(result)  # with units
    record, status, message = result.summary_record, result.status, result.message
    summary = (record, (scene.n, scene.dof)) if record is not None else None
    warnings = " | ".join(result.warnings)
    del result  # freed within the case's time (about 4 us), as the engine's own loop frees it
    out.add(summary, status, message, warnings, time.perf_counter() - started)


SCALARS = (*SUMMARY_LEADING, "n_switches", "n_stick_slip")  # the summary's leading scalars, its lists counted


def summary_column_names(n: int, free: bool = False) -> list[str]:
    """The result columns of a sweep's table for an n-link scene (`free`: a free chain), in
    their order: the names a fit's measurements are given by (u_final[2], coefficients.e_N,
    ...); the impacts per point as point_impacts.tip, point_impacts.joint 2, ..."""
    return [*SCALARS, *(f"u_final[{i + 1}]" for i in range(n)), *(f"q_final[{i + 1}]" for i in range(n)),
            *(column for name in SUMMARY_LATER for column in _later_names(name, n, free)),
            *(f"energy.{name}" for name in ENERGY_TERMS), *(f"coefficients.{name}" for name in COEFFICIENTS)]


def _later_names(name: str, n: int, free: bool) -> list[str]:
    """The columns of a summary entry after the final state: one, or one per point (PER_POINT)."""
    if name not in PER_POINT:
        return [name]
    return [f"{name}.{point_name(k, n)}" for k in chain_points(n, free)]


Record = tuple[bytes, np.dtype]  # a summary's C record and its dtype (SimulationResult.summary_record)
# with each record, the model's links and coordinates (n, and a free chain's base point's two)


def summary_columns(records: list[tuple[Record, tuple[int, int]] | None]) -> dict[str, np.ndarray]:
    """The summaries of a chunk's cases (with their link counts) as the table's columns, as
    `SimulationResult.summary` names its fields: the lists counted (n_switches, ...) or spread
    (u_final[1], ...), the energy budget as energy.W_normal, ... The records of one model are
    joined into one structured array (a Python value per field would cost about 3 us a case).
    A case without a summary (refused, or not built), or with fewer links than another, has
    NaN there."""
    first = records[0] if records else None
    if first is not None and all(r is not None and r[0][1] is first[0][1] for r in records):
        # the common chunk: one model (one session's dtype) for every case, its columns as they are
        return _record_columns(np.frombuffer(b"".join(r[0][0] for r in records), first[0][1]), *first[1])
    cases = [k for k, r in enumerate(records) if r is not None]
    if not cases:
        return {}
    models: dict[np.dtype, list[int]] = {}  # the cases of each record layout (one per model)
    for k in cases:
        models.setdefault(records[k][0][1], []).append(k)
    n = max(records[k][1][0] for k in cases)
    free = any(records[k][1][1] > records[k][1][0] for k in cases)  # (n, dof): a free chain's base point's two
    columns = {name: np.full(len(records), np.nan) for name in summary_column_names(n, free)}
    integers: set[str] = set()
    for dtype, rows in models.items():
        part = _record_columns(np.frombuffer(b"".join(records[k][0][0] for k in rows), dtype), *records[rows[0]][1])
        for name, values in part.items():
            columns[name][rows] = values
            if values.dtype.kind == "i":
                integers.add(name)
    if len(cases) == len(records):  # every case has the integer fields: integers, as in one model's chunk
        columns.update({name: columns[name].astype(np.int64) for name in integers})
    return columns


def _record_columns(table: np.ndarray, n: int, dof: int) -> dict[str, np.ndarray]:
    """The columns of a structured array of summary records of an n-link model with `dof`
    coordinates (n, and a free chain's base point's two; contiguous, integers as int64 as
    Python's ints make them)."""
    y = table["y_final"]
    columns = {name: _column(table[name]) for name in SCALARS}
    columns.update({f"u_final[{i + 1}]": y[:, dof + i].copy() for i in range(n)})
    columns.update({f"q_final[{i + 1}]": y[:, i].copy() for i in range(n)})
    for name in SUMMARY_LATER:
        if name in PER_POINT:  # an array by point number: one column per point, by its name
            columns.update({f"{name}.{point_name(k, n)}": _column(table[name][:, k])
                            for k in chain_points(n, dof > n)})
        else:
            columns[name] = _column(table[name])
    columns.update({f"energy.{name}": _column(table[name]) for name in ENERGY_TERMS})
    columns.update({f"coefficients.{name}": _column(table[name]) for name in COEFFICIENTS})  # the first impact's
    return columns


def _column(field: np.ndarray) -> np.ndarray:
    return field.astype(np.int64) if field.dtype.kind == "i" else field.copy()


@dataclass
class ChunkRows:
    """The rows of a chunk as columns, and the trajectories kept: what a worker sends back.
    Columns cost the driver, which shares the cores with the workers, one conversion per
    column instead of one per value, and a column of plain numbers comes as an array: one
    buffer to unpickle and to hand to pandas."""

    columns: dict[str, np.ndarray | list[Any]]
    trajectories: dict[int, dict[str, tuple[np.ndarray, str]]]

    def __len__(self) -> int:
        return len(self.columns.get("case", ()))

    @staticmethod
    def joined(parts: list["ChunkRows"]) -> dict[str, np.ndarray | list[Any]]:
        """The columns of `parts` end to end, the parts in the order of their first case (a
        sweep's chunks are mostly runs of consecutive cases, which are then in order already;
        None where a part lacks a column)."""
        parts = sorted(parts, key=lambda part: part.columns["case"][0] if len(part) else -1)
        out: dict[str, np.ndarray | list[Any]] = {}
        for name in dict.fromkeys(name for part in parts for name in part.columns):
            pieces = [part.columns.get(name) for part in parts]
            if all(isinstance(p, np.ndarray) for p in pieces) and len({p.dtype for p in pieces}) == 1:
                out[name] = np.concatenate(pieces)
            else:
                out[name] = list(itertools.chain.from_iterable(_as_list(p, len(part)) for part, p in zip(parts, pieces)))
        return out


class ChunkColumns:
    """A chunk's rows as its cases finish, a list per column (`rows` makes them `ChunkRows`).
    Not a dict per row: every row lives until the chunk is sent, and the garbage collector
    scans the dicts in its passes (about 2.5 us a case in 500-case chunks)."""

    def __init__(self, cases: execute.Chunk):
        self.cases = cases
        self.summaries: list[tuple[Record, tuple[int, int]] | None] = []  # with the case's links and coordinates
        self.status: list[str] = []
        self.message: list[str] = []
        self.warnings: list[str] = []
        self.wall_s: list[float] = []
        self.trajectories: dict[int, dict[str, tuple[np.ndarray, str]]] = {}
        self.batch: batch.BatchRows | None = None  # every case's row, from one C call (instead of `add`)

    def add(self, summary: tuple[Record, tuple[int, int]] | None, status: str, message: str, warnings: str,
            wall_s: float) -> None:
        """The next case's row (the cases' order)."""
        self.summaries.append(summary)
        self.status.append(status)
        self.message.append(message)
        self.warnings.append(warnings)
        self.wall_s.append(wall_s)

    def rows(self) -> ChunkRows:
        """case, the varied keys (None where a case lacks one), status, message, warnings,
        wall_s, then the summaries' columns."""
        keys = dict.fromkeys(key for _, overrides in self.cases for key in overrides)
        columns = {"case": _packed([index for index, _ in self.cases])}
        columns.update({key: _packed([overrides.get(key) for _, overrides in self.cases]) for key in keys})
        ran = self.batch
        if ran is not None:
            n = len(self.cases)
            columns.update(status=["ok"] * n, message=[""] * n, warnings=[""] * n, wall_s=ran.wall_s)
            return ChunkRows({**columns, **_record_columns(ran.records, ran.links, ran.dof)}, self.trajectories)
        columns.update(status=self.status, message=self.message, warnings=self.warnings,
                       wall_s=np.array(self.wall_s, dtype=float))
        return ChunkRows({**columns, **summary_columns(self.summaries)}, self.trajectories)


def lost_rows(lost: execute.Lost) -> ChunkRows:
    """Rows with status "failed" for the cases of a chunk that could not be run: nothing is
    silently missing."""
    out = ChunkColumns(lost.chunk)
    for _ in lost.chunk:
        out.add(None, "failed", lost.reason, "", 0.0)
    return out.rows()


def _as_list(column: np.ndarray | list[Any] | None, rows: int) -> list[Any]:
    """A chunk's column as plain values, or None for each of its rows if it has no such column."""
    if column is None:
        return [None] * rows
    return column.tolist() if isinstance(column, np.ndarray) else column


NUMBER_TYPES = (float, int, np.float64, np.int64)  # column values sent as an array (bool is not int here)


def _packed(values: list[Any]) -> np.ndarray | list[Any]:
    """A column of one plain number type as an array; anything else (text, None) as it is."""
    kind = type(values[0]) if values else None
    if kind in NUMBER_TYPES and all(type(v) is kind for v in values):
        try:
            return np.array(values, dtype=kind)
        except OverflowError:  # an int beyond 64 bits: kept as Python's, as the row gave it
            return values
    return values


def run_chunk(scene_dict: dict[str, Any], cases: execute.Chunk, options: CaseOptions) -> ChunkRows:
    """The rows of some cases of one scene (what a worker process or Dask task runs): in one C
    call (batch.py) those it can take, the others case by case through `simulate`."""
    base = scene_from_dict(scene_dict)
    out = ChunkColumns(cases)
    ran = _batched(base, cases, options)
    if ran is None:
        for index, overrides in cases:
            run_case(out, base, index, overrides, index in options.keep_trajectories)
        return out.rows()
    if not ran.again.any():  # the common chunk: every case in C
        out.batch = ran
        return out.rows()
    record = ran.records.dtype
    for k, (index, overrides) in enumerate(cases):
        if ran.again[k]:
            run_case(out, base, index, overrides, index in options.keep_trajectories)
        else:
            out.add(((ran.records[k].tobytes(), record), (base.n, base.dof)), "ok", "", "", ran.wall_s[k])
    return out.rows()


def _batched(base: Scene, cases: execute.Chunk, options: CaseOptions) -> batch.BatchRows | None:
    """The chunk's cases run in one C call (batch.run_plan), or None when the batch cannot take
    them: cases that vary different keys, or keys that are no model parameter nor initial element."""
    keys = tuple(cases[0][1]) if cases else ()
    if not keys or any(tuple(overrides) != keys for _, overrides in cases):
        return None
    plan = batch.plan_for(base, keys)
    if plan is None:
        return None
    values, usable = batch.case_values(keys, [overrides for _, overrides in cases])
    if options.keep_trajectories:
        usable &= np.array([index not in options.keep_trajectories for index, _ in cases])
    return batch.run_plan(plan, values, usable)
