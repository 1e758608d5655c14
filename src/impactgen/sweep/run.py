"""Run a sweep: its cases in chunks (chunk.py), one row per case, where execute.py puts them.

A case that fails (a solver failure, or a combination the scene checks refuse) is a row with
its status and message; the sweep goes on. With an output folder every finished chunk is
written at once as its own Parquet part, so an interrupted sweep keeps its rows, and the same
command resumes, computing only the missing cases. Two sweeps into one folder are refused.
"""
from __future__ import annotations

import collections
import contextlib
import fcntl
import json
import os
import re
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from ..errors import SceneError, ValidityWarning, excerpt, warn
from ..export import write_parquet, write_table
from ..scene import Scene
from . import execute
from .chunk import CaseOptions, ChunkRows, lost_rows, run_chunk
from .spec import SweepSpec

RESULT_FILE = "sweep.parquet"
# Everything else in the folder starts with "_" (or "."), which Parquet readers skip
# (pandas.read_parquet, pyarrow.dataset, dask.dataframe): the folder reads as one dataset,
# each case once.
PARTS, STAMP, TRAJECTORIES, FIGURES = "_parts", "_sweep.json", "_trajectories", "_figures"
LOCK = ".lock"  # held while a sweep writes into the folder, removed when it finishes
OLD_NAMES = {"parts": PARTS, "sweep.json": STAMP, "trajectories": TRAJECTORIES, "figures": FIGURES}  # before 0.2

Progress = Callable[[int], None]  # called with the number of cases just finished


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


def warn_validity(frame) -> None:
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
        warn_validity(frame)
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
