"""Run a sweep: every case through `simulate`, one row per case, where execute.py puts it.

A case that fails (a solver failure, or a combination the scene checks refuse) is a row with
its status and message; the sweep goes on. With an output folder every finished chunk is
written at once as its own Parquet part, so an interrupted sweep keeps its rows, and the same
command resumes, computing only the missing cases. Two sweeps into one folder are refused.
"""
from __future__ import annotations

import collections
import contextlib
import fcntl
import itertools
import json
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from ..engines import simulate
from ..errors import ImpactgenError, SceneError, ValidityWarning, excerpt, warn
from ..export import trajectory_columns, write_parquet, write_table
from ..results import COEFFICIENTS, ENERGY_TERMS, SUMMARY_LATER, SUMMARY_LEADING
from ..scene import Scene, scene_from_dict, scene_with
from . import batch, execute
from .spec import SweepSpec

STATUS_INVALID = "invalid"  # the scene checks refused the case's values
RESULT_FILE = "sweep.parquet"
# Everything else in the folder starts with "_" (or "."), which Parquet readers skip
# (pandas.read_parquet, pyarrow.dataset, dask.dataframe): the folder reads as one dataset,
# each case once.
PARTS, STAMP, TRAJECTORIES, FIGURES = "_parts", "_sweep.json", "_trajectories", "_figures"
LOCK = ".lock"  # held while a sweep writes into the folder, removed when it finishes
OLD_NAMES = {"parts": PARTS, "sweep.json": STAMP, "trajectories": TRAJECTORIES, "figures": FIGURES}  # before 0.2

Progress = Callable[[int], None]  # called with the number of cases just finished


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
    summary = (record, scene.n) if record is not None else None
    warnings = " | ".join(result.warnings)
    del result  # freed within the case's time (about 4 us), as the engine's own loop frees it
    out.add(summary, status, message, warnings, time.perf_counter() - started)


SCALARS = (*SUMMARY_LEADING, "n_switches", "n_stick_slip")  # the summary's leading scalars, its lists counted


Record = tuple[bytes, np.dtype]  # a summary's C record and its dtype (SimulationResult.summary_record)


def summary_columns(records: list[tuple[Record, int] | None]) -> dict[str, np.ndarray]:
    """The summaries of a chunk's cases (with their link counts) as the table's columns, as
    `SimulationResult.summary` names its fields: the lists counted (n_switches, ...) or spread
    (u_final[1], ...), the energy budget as energy.W_normal, ... The records of one model are
    joined into one structured array (a Python value per field would cost about 3 us a case).
    A case without a summary (refused, or not built), or with fewer links than another, has
    NaN there."""
    first = records[0] if records else None
    if first is not None and all(r is not None and r[0][1] is first[0][1] for r in records):
        # the common chunk: one model (one session's dtype) for every case, its columns as they are
        return _record_columns(np.frombuffer(b"".join(r[0][0] for r in records), first[0][1]), first[1])
    cases = [k for k, r in enumerate(records) if r is not None]
    if not cases:
        return {}
    models: dict[np.dtype, list[int]] = {}  # the cases of each record layout (one per model)
    for k in cases:
        models.setdefault(records[k][0][1], []).append(k)
    n = max(records[k][1] for k in cases)
    names = [*SCALARS, *(f"u_final[{i + 1}]" for i in range(n)), *(f"q_final[{i + 1}]" for i in range(n)),
             *SUMMARY_LATER, *(f"energy.{name}" for name in ENERGY_TERMS),
             *(f"coefficients.{name}" for name in COEFFICIENTS)]
    columns = {name: np.full(len(records), np.nan) for name in names}
    integers: set[str] = set()
    for dtype, rows in models.items():
        part = _record_columns(np.frombuffer(b"".join(records[k][0][0] for k in rows), dtype), records[rows[0]][1])
        for name, values in part.items():
            columns[name][rows] = values
            if values.dtype.kind == "i":
                integers.add(name)
    if len(cases) == len(records):  # every case has the integer fields: integers, as in one model's chunk
        columns.update({name: columns[name].astype(np.int64) for name in integers})
    return columns


def _record_columns(table: np.ndarray, n: int) -> dict[str, np.ndarray]:
    """The columns of a structured array of summary records of an n-link model (contiguous,
    integers as int64 as Python's ints make them)."""
    y = table["y_final"]
    columns = {name: _column(table[name]) for name in SCALARS}
    columns.update({f"u_final[{i + 1}]": y[:, n + i].copy() for i in range(n)})
    columns.update({f"q_final[{i + 1}]": y[:, i].copy() for i in range(n)})
    columns.update({name: _column(table[name]) for name in SUMMARY_LATER})
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
        self.summaries: list[tuple[Record, int] | None] = []  # with the case's link count
        self.status: list[str] = []
        self.message: list[str] = []
        self.warnings: list[str] = []
        self.wall_s: list[float] = []
        self.trajectories: dict[int, dict[str, tuple[np.ndarray, str]]] = {}
        self.batch: batch.BatchRows | None = None  # every case's row, from one C call (instead of `add`)

    def add(self, summary: tuple[Record, int] | None, status: str, message: str, warnings: str,
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
            return ChunkRows({**columns, **_record_columns(ran.records, ran.links)}, self.trajectories)
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
        return np.array(values, dtype=kind)
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
            out.add(((ran.records[k].tobytes(), record), base.n), "ok", "", "", ran.wall_s[k])
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


def evenly_chosen(count: int, total: int) -> frozenset[int]:
    """`count` case indices spread evenly over `total` cases, first and last included."""
    if count <= 0 or total == 0:
        return frozenset()
    return frozenset(int(i) for i in np.unique(np.linspace(0, total - 1, min(count, total)).round()))


STRUCTURAL = ("chain.links", "contact.model", "contact.friction", "contact.friction_mode", "solver.t_end",
              "solver.jacobian", "solver.method")  # keys whose values may choose another compiled model


def structural_keys(spec: SweepSpec) -> list[str]:
    return [a.key for a in spec.axes if a.key.split("[")[0] in STRUCTURAL]


def structure_order(spec: SweepSpec) -> np.ndarray:
    """Case indices with the cases of one model structure together (links, contact model,
    friction on or off and its kind), so a worker loads each compiled model once; made from
    the structural keys' columns alone (a million cases are never made at once for it)."""
    structural = structural_keys(spec)
    codes = []
    for key in reversed(structural):  # np.lexsort sorts by its last key first
        column = spec.column(key)
        if key == "contact.friction":  # on or off: the friction's size is no structure
            codes.append(column > 0 if isinstance(column, np.ndarray) else np.array([v > 0 for v in column]))
            continue
        codes.append(np.unique(np.array([repr(v) for v in column], dtype=object), return_inverse=True)[1])
    if not codes:
        return np.arange(spec.count(), dtype=np.int64)
    return np.lexsort(codes).astype(np.int64)  # stable: case order within a structure


class OutputFolder:
    """Parts written chunk by chunk, a lock against a second sweep, and the final table."""

    def __init__(self, path: Path, scene: Scene, spec: SweepSpec):
        self.path = path
        self.parts = path / PARTS
        self.meta = {"impactgen.scene": scene.to_toml(), "impactgen.sweep": spec.describe()}
        try:
            path.mkdir(parents=True, exist_ok=True)
            self._lock = open(path / LOCK, "w")
        except OSError as exc:
            raise SceneError("--out", f"cannot use the folder {path}: {exc}") from None
        try:  # a lock on the open file: it ends with the last process holding it (none is a worker)
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._lock.close()
            raise SceneError("--out", f"another sweep is writing into {path}; wait for it or choose "
                                      "another folder") from None
        execute.NOT_FOR_WORKERS.add(self._lock.fileno())
        try:
            _rename_old_layout(path)
            self.parts.mkdir(exist_ok=True)
        except OSError as exc:
            self.close()
            raise SceneError("--out", f"cannot use the folder {path}: {exc}") from None
        stamp = path / STAMP
        described = {"scene": self.meta["impactgen.scene"], "sweep": spec.describe()}
        if stamp.exists() and json.loads(stamp.read_text()) != described:
            self.close()
            raise SceneError("--out", f"{path} holds a different sweep (another scene or "
                                      "specification); choose another folder to start a new one")
        stamp.write_text(json.dumps(described, indent=1) + "\n")

    def done(self) -> list:
        """The parts finished in earlier runs, as DataFrames (a resume computes only the rest)."""
        import pyarrow.parquet as pq
        return [pq.read_table(part).to_pandas() for part in sorted(self.parts.glob("part-*.parquet"))]

    def write_part(self, chunk: ChunkRows) -> None:
        import pyarrow as pa
        first = min(chunk.columns["case"])
        write_table(pa.Table.from_pydict(chunk.columns),
                    self.parts / f"part-{first:09d}-{os.getpid()}-{time.monotonic_ns()}.parquet")

    def write_trajectory(self, case: int, columns: dict[str, tuple[np.ndarray, str]]) -> None:
        folder = self.path / TRAJECTORIES
        folder.mkdir(exist_ok=True)
        write_parquet(folder / f"case-{case}.parquet", columns, {"case": str(case)})

    def write_result(self, frame) -> Path:
        import pyarrow as pa
        table = pa.Table.from_pandas(frame, preserve_index=False)
        path = self.path / RESULT_FILE
        write_table(table.replace_schema_metadata({**(table.schema.metadata or {}), **self.meta}), path)
        _write_dataset_metadata(path)
        return path

    def finish(self) -> None:
        """The sweep is complete: its lock file goes (the lock itself is held until `close`)."""
        with contextlib.suppress(OSError):
            (self.path / LOCK).unlink()

    def close(self) -> None:
        execute.NOT_FOR_WORKERS.discard(self._lock.fileno())
        fcntl.flock(self._lock, fcntl.LOCK_UN)
        self._lock.close()


def _write_dataset_metadata(result: Path) -> None:
    """`_metadata` beside the table, naming it the dataset's only file: dask.dataframe reads
    a folder's every *.parquet, at any depth (the parts too), unless that file is there."""
    import pyarrow.parquet as pq
    footer = pq.read_metadata(result)
    footer.set_file_path(result.name)
    temporary = result.with_name("_metadata.tmp")
    pq.write_metadata(pq.read_schema(result), temporary, metadata_collector=[footer])
    os.replace(temporary, result.with_name("_metadata"))


def _rename_old_layout(path: Path) -> None:
    """A folder written before the names began with "_" (parts/, sweep.json, ...) takes the
    new names, so that it resumes and reads as one dataset."""
    for old, new in OLD_NAMES.items():
        if (path / old).exists() and not (path / new).exists():
            (path / old).rename(path / new)


def run_sweep(scene: Scene, spec: SweepSpec, workers: int | None = None, out: Path | None = None,
              progress: Progress | None = None, scheduler: str | None = None,
              trajectories: int | Iterable[int] = 0, on_resume: Callable[[int], None] | None = None):
    """Run every case of `spec` on `scene` and return the table (a pandas DataFrame).

    `scheduler` runs the chunks on a Dask cluster (an address, or "local"); otherwise a local
    pool of `workers` processes (default: every usable core) runs them. `trajectories` keeps
    the samples of that many evenly chosen cases (or of the listed case numbers) in
    `out/_trajectories/case-N.parquet`. `on_resume` hears how many cases an earlier run
    into `out` had finished (they are not run again). Every argument is checked before any
    case runs; workers beyond `worker_limit` are not started, and a warning says so.
    """
    check_arguments(workers=workers, out=out, progress=progress, scheduler=scheduler, on_resume=on_resume)
    import pandas  # noqa: F401 - imported before the heap is frozen: its objects are most of it
    with execute.frozen_heap():
        return _run(scene, spec, workers, Path(out) if out is not None else None, progress, scheduler,
                    trajectories, on_resume)


def check_arguments(*, workers: Any = None, out: Any = None, progress: Any = None, scheduler: Any = None,
                    on_resume: Any = None) -> None:
    """Refuse, in one line naming the argument, anything of the wrong kind, before any case
    runs (a bad `progress` had failed only after every case had run, losing the work)."""
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or workers < 1):
        raise SceneError("--workers", f"expected a whole number of worker processes >= 1, got {excerpt(workers)}")
    if scheduler is not None and not isinstance(scheduler, str):
        raise SceneError("--scheduler", f'expected an address "tcp://HOST:PORT" or "local", got {excerpt(scheduler)}')
    if scheduler not in (None, "local") and workers is not None:
        raise SceneError("--workers", "a Dask cluster at an address has its own workers: give --workers "
                                      "only with no --scheduler or --scheduler local")
    if out is not None and not isinstance(out, (str, os.PathLike)):
        raise SceneError("--out", f"expected a folder (a str or Path), got {type(out).__name__} {excerpt(out)}")
    if isinstance(out, str) and not out:
        raise SceneError("--out", 'expected a folder, got "" (use "." for this folder)')
    for name, function in (("progress", progress), ("on_resume", on_resume)):
        if function is not None and not callable(function):
            raise SceneError(name, f"expected a function called with a number of cases, or None; got "
                                   f"{type(function).__name__} {excerpt(function)}")


WORKERS_PER_CORE = 1  # a case is pure CPU work: processes beyond the cores only take turns on them


def usable_cores() -> int:
    """The cores this process may run on (its affinity where the system tells it)."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


def worker_limit(cases: int) -> int:
    """The most worker processes a sweep of `cases` cases starts: one per case and
    WORKERS_PER_CORE per usable core, whichever is fewer (at least 1)."""
    return max(1, min(cases, WORKERS_PER_CORE * usable_cores()))


def capped_workers(asked: int | None, cases: int) -> int:
    """The workers to start for `cases` cases when `asked` were asked for (None: as many as
    help). More than `worker_limit` are not started, and a warning says how many are."""
    limit = worker_limit(cases)
    if asked is None:
        return limit
    if asked > limit:
        cores = usable_cores()
        why = f"{cases} case{'s' if cases != 1 else ''} to run" if limit == cases else \
            f"{cores} usable core{'s' if cores != 1 else ''} x {WORKERS_PER_CORE} worker per core"
        warn(f"--workers {asked}: starting {limit} worker process{'es' if limit != 1 else ''}, the most this "
             f"sweep can use ({why})")
        return limit
    return int(asked)


class CaseList:
    """The cases still to run, in the order they go out, made a chunk at a time when sliced
    (as execute's backends slice it): the driver never holds every case of a large sweep."""

    def __init__(self, spec: SweepSpec, indices: np.ndarray):
        self.spec, self.indices = spec, indices

    def __len__(self) -> int:
        return len(self.indices)

    def __getitem__(self, part: slice) -> execute.Chunk:
        chosen = self.indices[part]
        ascending = np.sort(chosen)  # cases_at takes them in case order
        made = dict(zip(ascending.tolist(), self.spec.cases_at(ascending)))
        return [(i, made[i]) for i in chosen.tolist()]


def _todo(spec: SweepSpec, finished: set[int]) -> CaseList:
    """The cases not finished, with the cases of one model structure together
    (`structure_order`: in case order when no key of the structure varies)."""
    order = structure_order(spec)
    if finished:
        order = order[~np.isin(order, np.fromiter(finished, dtype=np.int64, count=len(finished)))]
    return CaseList(spec, order)


def _warn_validity(frame) -> None:
    """One ValidityWarning for the sweep when some of its cases have validity warnings: how
    many, and the most common kind (a case's first warning, its numbers left out)."""
    warned = [text for text in frame["warnings"] if isinstance(text, str) and text]
    if not warned:
        return
    kinds = collections.Counter(NUMBERS.sub("#", text.split(" | ")[0]) for text in warned)
    kind, count = kinds.most_common(1)[0]
    example = next(text.split(" | ")[0] for text in warned if NUMBERS.sub("#", text.split(" | ")[0]) == kind)
    warn(f"{len(warned)} of {len(frame)} cases have validity warnings (the table's `warnings` column); the most "
         f"common, in {count}: {example}", ValidityWarning)


NUMBERS = re.compile(r"[-+]?\d[\d.]*(?:e[-+]?\d+)?")  # the numbers in a warning's text


def _run(scene: Scene, spec: SweepSpec, workers: int | None, out: Path | None, progress: Progress | None,
         scheduler: str | None, trajectories: int | Iterable[int], on_resume: Callable[[int], None] | None):
    spec.check(scene)
    keep = _kept_cases(trajectories, spec.count())
    if keep and out is None:
        raise SceneError("--trajectories", "kept trajectories are written into the --out folder: give one")
    folder = OutputFolder(out, scene, spec) if out is not None else None
    try:
        frames = folder.done() if folder else []  # one DataFrame per part of an earlier run
        finished = {int(i) for f in frames for i in f["case"]}
        if finished and on_resume:
            on_resume(len(finished))
        if progress and finished:
            progress(len(finished))
        todo = _todo(spec, finished)
        rows = Gathered(len(todo))  # every new row, made a DataFrame once at the end
        for done in _execute(scene, todo, CaseOptions(keep), workers, scheduler):
            chunk = done if isinstance(done, ChunkRows) else lost_rows(done)
            if folder:
                for case, kept in chunk.trajectories.items():
                    folder.write_trajectory(case, kept)
                folder.write_part(chunk)
            rows.add(chunk)
            n_new = len(chunk)
            del chunk, done
            if progress:
                progress(n_new)
        frame = _table(frames, rows.columns() if rows.filled else None, spec)
        del rows, frames
        if folder:
            folder.write_result(frame)
            folder.finish()
        _warn_validity(frame)
        return frame
    finally:
        if folder:
            folder.close()


ROW_END = ("status", "message", "warnings", "wall_s")  # the last columns of the table


class Gathered:
    """A sweep's new rows as its chunks come, each column gathered into one array (or list) of
    the sweep's size, allocated at its first chunk: the driver holds each value once, not once
    per chunk and again joined (a million cases had taken over a gigabyte). A column a chunk
    lacks is NaN there (None for text); counts that meet a NaN or a float become floats."""

    def __init__(self, total: int):
        self.total, self.filled = total, 0
        self._columns: dict[str, np.ndarray | list[Any]] = {}

    def add(self, chunk: ChunkRows) -> None:
        n, at = len(chunk), self.filled
        for name, column in chunk.columns.items():
            target = self._columns.get(name)
            if target is None:
                target = self._columns[name] = self._empty(column, at)
            if isinstance(target, np.ndarray) and not (isinstance(column, np.ndarray) and
                                                       np.can_cast(column.dtype, target.dtype, "same_kind")):
                target = self._columns[name] = self._widened(target, column)
            target[at:at + n] = column
        for name, target in self._columns.items():
            if name not in chunk.columns and isinstance(target, np.ndarray):
                if target.dtype.kind != "f":
                    target = self._columns[name] = target.astype(float)
                target[at:at + n] = np.nan
        self.filled += n

    def _empty(self, column: np.ndarray | list[Any], missing: int) -> np.ndarray | list[Any]:
        """A column of the sweep's size for `column`'s values; its first `missing` rows lack it."""
        if isinstance(column, np.ndarray) and column.dtype.kind in "iuf":
            if column.dtype.kind == "f" or missing:
                return np.full(self.total, np.nan)
            return np.zeros(self.total, column.dtype)
        return [None] * self.total

    def _widened(self, target: np.ndarray, column: np.ndarray | list[Any]) -> np.ndarray | list[Any]:
        """`target` made able to hold `column` too: floats, or a list when it is not numbers."""
        if isinstance(column, np.ndarray) and column.dtype.kind in "iuf":
            return target.astype(float)
        return target[:self.filled].tolist() + [None] * (self.total - self.filled)

    def columns(self) -> dict[str, np.ndarray | list[Any]]:
        """The columns of the rows gathered, in the order they came (handed over: emptied here)."""
        out = {}
        for name in list(self._columns):
            column = self._columns.pop(name)
            out[name] = column[:self.filled] if self.filled < self.total else column
        return out


def _table(frames: list, columns: dict[str, np.ndarray | list[Any]] | None, spec: SweepSpec):
    """The table in case order: case, the varied keys, the summary fields, then status,
    message, warnings and wall time. `frames` are the parts of an earlier run, `columns` this
    run's rows (a case run twice, by a resume, appears once). Without earlier parts the rows
    are put in order by numpy before pandas sees them: a 20000-case table in about half the
    time of pandas' own drop_duplicates, sort and selection."""
    import pandas as pd
    if columns is not None and not frames:
        case = np.asarray(columns["case"])
        order = None if (np.diff(case) > 0).all() else np.argsort(case, kind="stable")
        if order is None or not (np.diff(case[order]) == 0).any():  # each case once
            for name in list(columns) if order is not None else ():  # one column at a time: one more in memory
                columns[name] = _taken(columns[name], order)
            # copy=False: pandas keeps the arrays as they are (one block each), not joined into a copy
            return pd.DataFrame({name: columns[name] for name in _column_order(columns, spec)}, copy=False)
    if columns is not None:
        frames = [*frames, pd.DataFrame(columns)]
    if not frames:
        return pd.DataFrame(columns=["case", *(a.key for a in spec.axes), *ROW_END])
    frame = pd.concat(frames, ignore_index=True)
    frame = frame.drop_duplicates("case", keep="last").sort_values("case", ignore_index=True)
    return frame[_column_order(frame.columns, spec)]


def _column_order(names: Iterable[str], spec: SweepSpec) -> list[str]:
    return column_order(names, [a.key for a in spec.axes])


def column_order(names: Iterable[str], keys: Iterable[str]) -> list[str]:
    """case, the varied keys, the other columns as they come, then ROW_END."""
    names = list(names)
    front = ["case", *keys]
    middle = [c for c in names if c not in front and c not in ROW_END]
    return front + middle + [c for c in ROW_END if c in names]


def _taken(column: np.ndarray | list[Any], order: np.ndarray) -> np.ndarray | list[Any]:
    if isinstance(column, np.ndarray):
        return column[order]
    return [column[i] for i in order.tolist()]


def _kept_cases(trajectories: int | Iterable[int], total: int) -> frozenset[int]:
    """The case numbers whose trajectories are kept: `trajectories` evenly chosen ones, or
    those listed; anything else (a word, a fraction, a case that does not exist) is refused."""
    if isinstance(trajectories, (int, np.integer)) and not isinstance(trajectories, bool):
        if trajectories < 0:
            raise SceneError("--trajectories", f"expected a number of cases >= 0, got {trajectories}")
        return evenly_chosen(int(trajectories), total)
    how = "a number of cases to keep, or a list of case numbers such as [0, 5, 9]"
    if isinstance(trajectories, (str, bytes, Mapping)) or not isinstance(trajectories, Iterable):
        raise SceneError("--trajectories", f"expected {how}; got {type(trajectories).__name__} "
                                           f"{excerpt(trajectories)}")
    chosen = set()
    for case in trajectories:
        if isinstance(case, bool) or not isinstance(case, (int, np.integer)):
            raise SceneError("--trajectories", f"expected {how}; got the item {excerpt(case)}")
        if not 0 <= case < total:
            raise SceneError("--trajectories", f"case {int(case)} does not exist: the cases are 0 to {total - 1}")
        chosen.add(int(case))
    return frozenset(chosen)


def _execute(scene: Scene, todo: execute.Chunk, options: CaseOptions, workers: int | None,
             scheduler: str | None) -> Iterable[ChunkRows | execute.Lost]:
    if not todo:
        return iter(())
    payload = scene.to_dict()
    if scheduler is not None:
        local = capped_workers(workers, len(todo)) if scheduler == "local" else None
        return execute.dask_cluster(run_chunk, payload, options, todo, scheduler, local)
    workers = capped_workers(workers, len(todo))
    if workers == 1:
        return execute.in_process(run_chunk, payload, options, todo)
    _load_model(scene)  # forked workers inherit it loaded: no start-up cost per worker
    return execute.process_pool(run_chunk, payload, options, todo, workers)


def _load_model(scene: Scene) -> None:
    """Load the compiled model every case uses before the workers fork: they inherit it
    loaded, with no start-up cost each."""
    from ..build import compile_model
    from ..engines import model_spec
    compile_model(model_spec(scene))
