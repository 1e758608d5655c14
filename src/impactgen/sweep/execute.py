"""Where the chunks of a sweep run: this process, a local process pool, or a Dask cluster.

Every backend yields what the chunk function returns for each chunk as it finishes, so the
caller writes it at once. A chunk whose worker dies is run again: the process pool is restarted,
and the chunks it had been sent run first, one at a time (a chunk at most MAX_CHUNK_TRIES times);
Dask reschedules the tasks of a lost worker itself (its `distributed.scheduler.allowed-failures`).
A chunk that keeps killing its workers is yielded as a `Lost` record, which the caller makes
rows with status "failed", so no case is ever missing from the table.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import gc
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections import deque
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import Any, Callable, Collection, Iterator, NamedTuple

from ..errors import SceneError, excerpt

GUIDED_SHARE = 2  # a chunk holds at most 1/(GUIDED_SHARE x workers) of the cases not yet sent
MAX_CHUNK = 2000  # cases: a lost or interrupted chunk costs at most this much work again (0.2 s of
# the paper's impacts); each chunk costs its worker a pause of about 0.8 ms
SMALLEST_CHUNK = 16  # cases: below this a chunk's own cost (about 0.8 ms of the pool's) shows
IN_PROCESS_SHARES = 4  # in this process, chunks as a pool of four has them: the first an eighth
# of the cases, so that the progress bar moves and an interrupt loses little
MAX_TASK_CHUNK = 1000  # cases per Dask task: a task costs the cluster about 5 ms (500 tasks of 200
# cases doing nothing took 2.6 s on a LocalCluster of two workers), a pool's chunk about 0.8 ms
TASKS_AHEAD = 4  # Dask tasks in flight per worker: the next always queued on the worker, and the
# driver holds only their cases (a million cases made at once had taken a gigabyte)
MAX_CHUNK_TRIES = 3  # a chunk whose workers die this often is recorded as failed
AHEAD_PER_WORKER = 2  # chunks sent to a pool per worker at a time: the next is always waiting,
# and a dead worker leaves only these as suspects (the pool itself holds workers + 1)
ABANDON_JOIN_S = 5.0  # s to wait for each killed worker of a broken pool
PARENT_WATCH_S = 1.0  # s between a worker's looks at its parent, where no parent-death signal exists
PR_SET_PDEATHSIG = 1  # prctl option (linux/prctl.h): a signal for this process when its parent dies
NOT_FOR_WORKERS: set[int] = set()  # descriptors a forked worker closes (a sweep folder's lock)

Chunk = list[tuple[int, dict[str, Any]]]  # (case index, overrides)
RunChunk = Callable[[dict[str, Any], Chunk, Any], Any]  # the rows of a chunk, in the caller's form


@contextmanager
def frozen_heap() -> Iterator[None]:
    """Leave the objects that exist before a sweep out of the garbage collector's passes
    while it runs (gc.freeze, as the gc docs advise before fork). The caller's heap (pandas',
    pyarrow's, the model's objects) is then not scanned again by a full collection that the
    sweep's own allocations set off: in a warm process the first 20000-case sweep spent
    about 0.1 s in one before its workers started. Forked workers inherit the frozen heap,
    so their collections leave its pages shared. A caller that froze objects itself, or
    turned the collector off, keeps its settings."""
    if not gc.isenabled() or gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def chunk_bounds(count: int, workers: int, largest: int = MAX_CHUNK) -> list[tuple[int, int]]:
    """(start, stop) of chunks of `count` cases that shrink towards the end (guided
    scheduling): large chunks while much is left, since each costs the driver and its worker
    a pause, and small ones last, so that the workers finish together instead of one waiting
    on the other's last large chunk."""
    bounds, start = [], 0
    while start < count:
        left = count - start
        size = max(SMALLEST_CHUNK, min(largest, -(-left // (GUIDED_SHARE * workers))))
        bounds.append((start, min(start + size, count)))
        start += size
    return bounds


def chunked(cases: Chunk, workers: int, largest: int = MAX_CHUNK) -> list[Chunk]:
    """The cases in the chunks of `chunk_bounds`."""
    return [cases[start:stop] for start, stop in chunk_bounds(len(cases), workers, largest)]


class Lost(NamedTuple):
    """A chunk that could not be run, and why: the caller makes its rows (status "failed"),
    so that no case is silently missing."""

    chunk: Chunk
    reason: str


def in_process(run_chunk: RunChunk, payload: dict[str, Any], options: Any, todo: Chunk) -> Iterator[Any]:
    """`todo` (a list of cases, or anything sliced into lists of them, as run.CaseList) here."""
    for start, stop in chunk_bounds(len(todo), IN_PROCESS_SHARES):
        yield run_chunk(payload, todo[start:stop], options)


def process_pool(run_chunk: RunChunk, payload: dict[str, Any], options: Any, todo: Chunk,
                 workers: int) -> Iterator[Any]:
    """A local pool of `workers` processes, sent AHEAD_PER_WORKER chunks per worker ahead.
    A dead worker breaks the pool, and the chunks sent to it then are suspects: they run
    again on a new pool one at a time, so that a chunk that kills its worker is told apart
    from the chunks sent with it, and it alone is tried up to MAX_CHUNK_TRIES times."""
    # (chunk, the pools it broke with): a chunk is a (start, stop) of `todo` until sent, its
    # cases made then, so that the driver holds the cases of the chunks in flight only
    queue: deque[tuple[Chunk | tuple[int, int], int]] = deque((bounds, 0)
                                                              for bounds in chunk_bounds(len(todo), workers))
    while queue:
        context = _start_method()
        inherited = tuple(NOT_FOR_WORKERS) if context.get_start_method() == "fork" else ()
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_worker_signals,
                                   initargs=(inherited,))
        pending: dict[Future, tuple[Chunk, int]] = {}
        broken = finished_normally = False
        try:
            while (queue or pending) and not broken:
                while queue and _may_send(queue[0][1], pending.values(), AHEAD_PER_WORKER * workers):
                    chunk, tries = queue.popleft()
                    if isinstance(chunk, tuple):
                        chunk = todo[chunk[0]:chunk[1]]
                    pending[pool.submit(run_chunk, payload, chunk, options)] = (chunk, tries)
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    try:
                        rows = future.result()
                    except BrokenProcessPool:
                        broken = True
                        continue
                    pending.pop(future)
                    yield rows
            finished_normally = True
        except BrokenProcessPool:  # from submit: a worker had died already
            broken = finished_normally = True
        finally:
            for future in list(pending):
                future.cancel()
            if broken:  # never wait on it (its queue feeder can block on a dead worker's pipe)
                _abandon(pool)
            else:  # interrupted (Ctrl-C, SIGTERM): return at once, the workers end after their chunk
                pool.shutdown(wait=finished_normally, cancel_futures=True)
        if not broken:
            break
        suspects = [(chunk, tries + 1) for chunk, tries in pending.values()]
        print(f"impactgen: a worker process died; running the {len(suspects)} chunks the pool had "
              "been sent again on a new pool, one at a time", file=sys.stderr)
        for chunk, tries in suspects:
            if tries >= MAX_CHUNK_TRIES:
                yield Lost(chunk, f"its worker process died {tries} times (out of memory, or killed)")
        queue.extendleft(reversed([(chunk, tries) for chunk, tries in suspects if tries < MAX_CHUNK_TRIES]))


def _may_send(tries: int, pending: Collection[tuple[Chunk, int]], ahead: int) -> bool:
    """Whether the next chunk (in `tries` broken pools so far) may go to the pool now: a
    suspect goes alone, and nothing goes beside one; others up to `ahead` at a time."""
    if any(t for _, t in pending):
        return False
    return not pending if tries else len(pending) < ahead


def _worker_signals(inherited: tuple[int, ...] = ()) -> None:
    """A worker ends on SIGTERM, and when its driver dies; it closes the descriptors of
    `inherited` (forked from the driver: the lock of the sweep's folder).

    A forked worker inherits the command line's SIGTERM handler, which turns the signal into
    KeyboardInterrupt; the pool would then report that as a result and the worker would live
    on, so that a broken pool's terminate() never ended it and the pool's shutdown spun
    waiting for it (the sweep hung at 100 % CPU). A driver killed with SIGKILL had left its
    workers running, reparented, and holding the folder's lock, so that the same command
    could not resume."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    for fd in inherited:
        try:
            os.close(fd)
        except OSError:
            pass
    _end_with_parent()


def _end_with_parent() -> None:
    """SIGTERM for this process when its parent (the driver, or the forkserver that ends
    with it) dies: Linux's parent-death signal, elsewhere a thread that watches the parent."""
    parent = os.getppid()
    libc = ctypes.util.find_library("c") if sys.platform.startswith("linux") else None
    if libc and ctypes.CDLL(libc, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0) == 0:
        if os.getppid() != parent:  # it died before the signal was asked for
            os.kill(os.getpid(), signal.SIGTERM)
        return

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_WATCH_S)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, name="impactgen-parent-watch", daemon=True).start()


def _abandon(pool: ProcessPoolExecutor) -> None:
    """Shut a broken pool down without waiting for it, and end the workers it still has: a
    worker's death can leave the pool's feeder thread blocked on a pipe nobody reads, and
    waiting for that thread would hang the sweep."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.kill()
    for process in processes:
        process.join(timeout=ABANDON_JOIN_S)


def _start_method() -> multiprocessing.context.BaseContext:
    """Fork while this process has a single thread: the workers inherit the loaded model and
    start at once. With other threads (a broken pool's, a progress bar's, a caller's) a fork
    can copy a held lock into a child that then never runs, so start clean workers instead."""
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and threading.active_count() == 1:
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


def dask_cluster(run_chunk: RunChunk, payload: dict[str, Any], options: Any, todo: Chunk,
                 scheduler: str, workers: int | None) -> Iterator[Any]:
    """The chunks as tasks on a Dask distributed cluster: `scheduler` is its address
    (tcp://HOST:PORT), or "local" for a LocalCluster of `workers` processes started here."""
    try:
        from distributed import Client, LocalCluster, as_completed
        from distributed.scheduler import KilledWorker
    except ImportError:
        raise SceneError("--scheduler", "Dask needs the distributed package: pip install 'impactgen[sweep]'") from None
    cluster = None
    try:
        if scheduler == "local":
            cluster = LocalCluster(n_workers=workers or None, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(scheduler, timeout="20s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise SceneError("--scheduler", f"cannot reach the Dask scheduler at {excerpt(scheduler)}: {exc}") from None
    try:
        n_workers = max(len(client.scheduler_info().get("workers", {})), 1)
        bounds = iter(chunk_bounds(len(todo), n_workers, MAX_TASK_CHUNK))
        futures: dict[Any, Chunk] = {}

        def submit() -> Any:  # the next chunk as a task, its cases made now (None: none left)
            start_stop = next(bounds, None)
            if start_stop is None:
                return None
            chunk = todo[start_stop[0]:start_stop[1]]
            future = client.submit(run_chunk, payload, chunk, options, pure=False)
            futures[future] = chunk
            return future

        # TASKS_AHEAD tasks per worker at a time: the driver holds the cases of those only
        first = [f for f in (submit() for _ in range(TASKS_AHEAD * n_workers)) if f is not None]
        finished = as_completed(first)
        try:
            for future in finished:
                chunk = futures.pop(future)
                following = submit()
                if following is not None:
                    finished.add(following)
                try:
                    yield future.result()
                except KilledWorker:
                    yield Lost(chunk, "the Dask workers running it died repeatedly")
        finally:
            client.cancel(list(futures))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
