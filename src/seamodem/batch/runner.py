"""One way to run many independent tasks: serially, on local processes, or on a Dask cluster.

:func:`run_tasks` calls ``fn(task)`` for every task and returns one
:class:`TaskResult` per task, in task order, whatever the backend. A task that
raises is reported, not raised, so the rest of the job completes. A task whose
worker process dies is retried: local processes resubmit it once, alone in a
fresh pool (so the culprit is known exactly), then report it; Dask reschedules
it on another worker (its ``distributed.scheduler.allowed-failures`` setting),
then it is submitted once more by itself, then reported.

Results are identical across backends as long as ``fn`` is deterministic in
its task: draw random numbers from a seed carried by the task (e.g.
``numpy.random.default_rng([seed, index])``), never from the worker's
identity, the process id or the order of completion.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

from .._progress import progress_bar
from ..errors import ConfigError, SeamodemError

__all__ = ["BACKENDS", "TaskResult", "run_tasks", "map_tasks", "default_workers"]

#: Execution backends of :func:`run_tasks`.
BACKENDS = ("serial", "processes", "dask")


@dataclass(frozen=True)
class TaskResult:
    """The outcome of one task.

    Attributes
    ----------
    index : int
        Position of the task in the list given to :func:`run_tasks`.
    ok : bool
        True when ``fn`` returned.
    value : Any
        What ``fn`` returned (None on failure).
    error : str
        One line: the exception type and message, or why the worker died ("" when ok).
    attempts : int
        How many times the task was started (more than 1 after a worker died).
    """

    index: int
    ok: bool
    value: Any = None
    error: str = ""
    attempts: int = 1


def default_workers() -> int:
    """Local worker processes by default: the CPUs this process may use.

    Returns
    -------
    int
        Number of CPUs in this process's affinity mask (elsewhere than
        Linux: ``os.cpu_count()``), at least 1.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _guarded(fn: Callable, task) -> tuple[bool, Any]:
    """Run ``fn(task)`` in the worker; an exception becomes (False, one line) so it always pickles."""
    try:
        return True, fn(task)
    except Exception as exc:  # noqa: BLE001 - every failure of a task is reported, not raised
        return False, _one_line(exc)


class _Box:
    """An opaque holder, so that a task reaches ``fn`` exactly as given."""

    __slots__ = ("task",)

    def __init__(self, task):
        self.task = task

    def __reduce__(self):
        return _Box, (self.task,)


def _unbox(fn: Callable, box: _Box) -> tuple[bool, Any]:
    return _guarded(fn, box.task)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or traceback.format_exception_only(type(exc), exc)[-1].strip()
    return f"{type(exc).__name__}: {text}"


def run_tasks(
    fn: Callable[[Any], Any],
    tasks: Sequence | Iterable,
    *,
    backend: str = "serial",
    workers: int | None = None,
    scheduler=None,
    progress: bool | None | Callable[[int, int], None] = False,
    on_result: Callable[[TaskResult], None] | None = None,
    retries: int = 1,
    desc: str = "tasks",
) -> list[TaskResult]:
    """Run ``fn(task)`` for every task; results in task order, failures captured.

    Parameters
    ----------
    fn : callable
        A module-level function (it is pickled by reference for processes and Dask).
    tasks : sequence
        Picklable task descriptions.
    backend : {"serial", "processes", "dask"}
        Where to run: this process; a local process pool (no Dask needed); a
        Dask cluster (``scheduler``) or, without one, a local Dask cluster of
        ``workers`` processes.
    workers : int, optional
        Local processes (default: the usable CPUs). Ignored with a scheduler address.
    scheduler : str or distributed.Client, optional
        Dask scheduler address (``tcp://host:8786``) or an existing client.
    progress : bool, callable or None
        A progress bar over the tasks (None: on a terminal), or a callable
        ``(done, total)`` called after each task.
    on_result : callable, optional
        Called in this process with each :class:`TaskResult` as it arrives
        (e.g. to save it), in completion order.
    retries : int
        Extra attempts of a task whose worker died, each alone (processes: in
        a fresh pool; Dask: submitted by itself, after the scheduler's own
        ``allowed-failures`` reschedulings), so that a task that kills its
        worker cannot take others with it.
    desc : str
        Label of the progress bar.

    Returns
    -------
    list of TaskResult
        One per task, in task order.

    Raises
    ------
    ConfigError
        Unknown backend, bad worker count, a scheduler with another backend.
    """
    tasks = list(tasks)
    if backend not in BACKENDS:
        raise ConfigError("backend", f"must be one of {', '.join(BACKENDS)}, got {backend!r}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ConfigError("workers", f"must be an integer >= 1, got {workers!r}")
    if scheduler is not None and backend != "dask":
        raise ConfigError("scheduler", f"needs backend 'dask', got backend {backend!r}")
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise ConfigError("retries", f"must be an integer >= 0, got {retries!r}")
    results: list[TaskResult | None] = [None] * len(tasks)
    with progress_bar(
        total=len(tasks), desc=desc, unit="task", enabled=None if progress is None else progress is True
    ) as bar:

        def done(result: TaskResult) -> None:
            results[result.index] = result
            bar.update(1)
            if callable(progress):
                progress(sum(r is not None for r in results), len(tasks))
            if on_result is not None:
                on_result(result)

        if backend == "serial" or not tasks:
            for i, task in enumerate(tasks):
                ok, value = _guarded(fn, task)
                done(TaskResult(i, ok, value if ok else None, "" if ok else value))
        elif backend == "processes":
            _run_processes(fn, tasks, workers or default_workers(), retries, done)
        else:
            _run_dask(fn, tasks, workers, scheduler, retries, done)
    return results  # type: ignore[return-value]


def map_tasks(fn: Callable[[Any], Any], tasks: Iterable, **options) -> list:
    """``[fn(t) for t in tasks]`` on any backend; for sweeps, where one failed point fails the sweep.

    Takes the options of :func:`run_tasks`; ``functools.partial(map_tasks,
    backend="dask", scheduler=...)`` is a ``mapper(fn, iterable)`` as
    :func:`seamodem.studies.ber.ber_sweep` takes.

    Parameters
    ----------
    fn : callable
        A module-level function of one task.
    tasks : iterable
        Picklable task descriptions.
    **options
        ``backend``, ``workers``, ``scheduler``, ``progress``, ``on_result``,
        ``retries``, ``desc`` of :func:`run_tasks`.

    Returns
    -------
    list
        ``fn(t)`` for each task, in task order.

    Raises
    ------
    SeamodemError
        After every task has run, when any failed: how many, and the first error.
    """
    results = run_tasks(fn, tasks, **options)
    failed = [r for r in results if not r.ok]
    if failed:
        raise SeamodemError(
            f"{len(failed)} of {len(results)} tasks failed; task {failed[0].index}: {failed[0].error}"
        )
    return [r.value for r in results]


def _context():
    """Fork on Linux: workers start in milliseconds with numpy, scipy and the compiled kernels loaded.

    ``spawn``/``forkserver`` re-import seamodem in every worker (about 2 s each,
    and again for each pool rebuilt after a worker died). Fork is safe here:
    a worker only unpickles and runs its task, and needs no lock that a thread
    of the parent (a pool's manager, a progress bar) may hold. Elsewhere the platform's default.
    """
    if sys.platform.startswith("linux"):
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context()


def _one_thread_per_worker() -> None:
    """Each worker process uses one BLAS/OpenMP thread: the pool is the parallelism.

    Forked workers inherit numpy's threaded BLAS; two workers with two BLAS threads
    each on 2 cores ran 0.84× as fast as one worker (bench_batch, quiet machine),
    and 1.88× with one thread each.
    """
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def _own_progress_lock() -> None:
    """Each worker process's progress bars take a lock of its own, not the one its parent shares.

    tqdm's default lock holds a multiprocessing semaphore that every forked process shares, and every bar
    takes it to be created, a disabled one too (the reader's in each decoding task). A worker that dies or
    is terminated while it holds it (a broken pool terminates the others) leaves it taken for good: every
    other process then waits at its next bar. A batch hung so, its replacement worker waiting in its
    reader's bar (``tests/batch/test_batch_runner.py``). A worker's bars write nowhere a parent's do.
    """
    import threading

    from tqdm import tqdm
    from tqdm.auto import tqdm as auto_tqdm

    for cls in {tqdm, auto_tqdm}:
        cls.set_lock(threading.RLock())


def _worker_init() -> None:
    """A worker process's set-up: :func:`_one_thread_per_worker`, :func:`_own_progress_lock`."""
    _one_thread_per_worker()
    _own_progress_lock()


def _run_processes(fn, tasks, workers: int, retries: int, done) -> None:
    """A pool of ``workers`` processes; tasks lost with a dead worker are rerun alone, then reported."""
    attempts = [0] * len(tasks)
    queue = deque(range(len(tasks)))
    lost: list[int] = []
    ctx = _context()
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
    running: dict = {}
    try:
        while queue or running:
            # at most one task per worker in flight: a dead worker then costs only the tasks started
            while queue and len(running) < workers:
                i = queue.popleft()
                attempts[i] += 1
                running[pool.submit(_guarded, fn, tasks[i])] = i
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            broken = False
            for fut in finished:
                i = running.pop(fut)
                try:
                    ok, value = fut.result()
                except BrokenProcessPool:
                    lost.append(i)
                    broken = True
                    continue
                done(TaskResult(i, ok, value if ok else None, "" if ok else value, attempts[i]))
            if broken:
                # every task still in flight died with the pool
                lost.extend(running.values())
                running.clear()
                pool.shutdown(wait=False, cancel_futures=True)
                pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    _rerun_alone(fn, tasks, sorted(lost), attempts, workers, retries, ctx, done)


def _rerun_alone(fn, tasks, lost: list[int], attempts: list[int], workers: int, retries: int, ctx, done) -> None:
    """Each task in a pool of its own (up to ``workers`` at once), so a death is blamed on the right task."""
    queue = deque(lost)
    running: dict = {}
    try:
        while queue or running:
            while queue and len(running) < workers:
                i = queue.popleft()
                if attempts[i] > retries:
                    done(TaskResult(i, False, None, f"worker process died ({attempts[i]} attempts)", attempts[i]))
                    continue
                attempts[i] += 1
                pool = ProcessPoolExecutor(max_workers=1, mp_context=ctx, initializer=_worker_init)
                running[pool.submit(_guarded, fn, tasks[i])] = (i, pool)
            if not running:
                break
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in finished:
                i, pool = running.pop(fut)
                pool.shutdown(wait=False)
                try:
                    ok, value = fut.result()
                except BrokenProcessPool:
                    queue.append(i)
                    continue
                done(TaskResult(i, ok, value if ok else None, "" if ok else value, attempts[i]))
    finally:
        for _, pool in running.values():
            pool.shutdown(wait=False, cancel_futures=True)


def _run_dask(fn, tasks, workers: int | None, scheduler, retries: int, done) -> None:
    """Map over a Dask cluster; tasks killed with their workers are resubmitted one at a time."""
    try:
        from distributed import Client, LocalCluster, as_completed
        from distributed.scheduler import KilledWorker
    except ImportError:
        raise ConfigError("backend", "'dask' needs dask.distributed: pip install 'seamodem[dask]'") from None
    cluster = own = None
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=workers or default_workers(), threads_per_worker=1, processes=True, dashboard_address=":0"
        )
        client = own = Client(cluster)
    elif isinstance(scheduler, str):
        try:
            client = own = Client(scheduler)  # waits distributed.comm.timeouts.connect
        except (OSError, TimeoutError) as exc:
            raise ConfigError("scheduler", f"cannot reach the Dask scheduler at {scheduler!r}: {exc}") from None
    else:
        client = scheduler
    try:
        # boxed: Dask would read a tuple that starts with a callable as a task of its graph
        futures = client.map(_unbox, [fn] * len(tasks), [_Box(t) for t in tasks], pure=False)
        index = {fut.key: i for i, fut in enumerate(futures)}
        lost = []
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                ok, value = fut.result()
            except KilledWorker as exc:
                # the scheduler blames every task running on a worker that died: give each a turn alone
                if retries:
                    lost.append(i)
                else:
                    done(TaskResult(i, False, None, f"worker process died: {_one_line(exc)}", 1))
                continue
            except Exception as exc:  # noqa: BLE001 - a lost scheduler, a cancelled task...: reported per task
                done(TaskResult(i, False, None, f"worker or scheduler lost: {_one_line(exc)}", 1))
                continue
            done(TaskResult(i, ok, value if ok else None, "" if ok else value))
        for i in sorted(lost):
            try:
                ok, value = client.submit(_unbox, fn, _Box(tasks[i]), pure=False).result()
            except Exception as exc:  # noqa: BLE001 - killed again, or lost: reported
                done(TaskResult(i, False, None, f"worker process died: {_one_line(exc)}", 2))
                continue
            done(TaskResult(i, ok, value if ok else None, "" if ok else value, 2))
    finally:
        if own is not None:
            own.close()
        if cluster is not None:
            cluster.close()
