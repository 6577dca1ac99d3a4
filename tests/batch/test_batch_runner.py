"""run_tasks: same results on every backend, failures captured, a dead worker retried or reported."""

import functools
import os
from pathlib import Path

import numpy as np
import pytest

from seamodem.batch import map_tasks, run_tasks
from seamodem.errors import ConfigError, SeamodemError

distributed = pytest.importorskip("distributed")


def seeded_point(task):
    """A small Monte Carlo estimate whose noise comes from the task's own seed."""
    seed, index, n = task
    rng = np.random.default_rng([seed, index])
    x = rng.standard_normal((n, 3))
    return np.mean(np.linalg.norm(x, axis=1)), x[-1].copy()


def fails_on_odd(task):
    if task % 2:
        raise ValueError(f"task {task} is odd")
    return task * 10


def dies_once(task):
    """Kill the worker process the first time task 3 runs (a marker file remembers it)."""
    folder, index = task
    marker = Path(folder) / f"died-{index}"
    if index == 3 and not marker.exists():
        marker.write_text("x")
        os._exit(1)
    return index


def makes_a_progress_bar(task):
    """Create and close a (disabled) progress bar, as each decoding task's reader does."""
    from seamodem._progress import progress_bar

    with progress_bar(total=1, desc="task", enabled=False) as bar:
        bar.update()
    return task


def _take_and_die(lock):
    lock.acquire()
    os._exit(0)


def test_a_process_that_died_holding_the_progress_bars_lock_does_not_stall_the_workers(monkeypatch):
    """tqdm's default lock holds a semaphore every forked process shares, and every bar takes it to be created.
    A worker terminated while it held it (a broken pool terminates the others) left the batch's replacement
    worker waiting in its reader's bar for good: the suite hung in
    test_worker_killed_while_decoding_a_file_then_the_file_is_retried. Workers take a lock of their own."""
    import multiprocessing
    import threading

    from tqdm import tqdm
    from tqdm.auto import tqdm as auto_tqdm
    from tqdm.std import TqdmDefaultWriteLock

    from seamodem.batch.runner import _run_processes

    ctx = multiprocessing.get_context("fork")
    shared = ctx.Lock()  # tqdm's is a shared RLock; a plain one, so that the test can free it if it fails
    monkeypatch.setattr(TqdmDefaultWriteLock, "mp_lock", shared, raising=False)
    for cls in {tqdm, auto_tqdm}:
        monkeypatch.setattr(cls, "_lock", TqdmDefaultWriteLock(), raising=False)
    dead = ctx.Process(target=_take_and_die, args=(shared,))
    dead.start()
    dead.join()
    results = []
    runner = threading.Thread(target=_run_processes, args=(makes_a_progress_bar, [0, 1, 2], 2, 0, results.append),
                              daemon=True)
    runner.start()
    runner.join(timeout=60)
    stalled = runner.is_alive()
    if stalled:
        shared.release()  # the workers go on, and the pool shuts down
        runner.join()
    assert not stalled, "the workers waited for the progress bars' lock a dead process held"
    assert sorted(r.value for r in results) == [0, 1, 2]


def always_dies(task):
    if task == 2:
        os._exit(1)
    return task


def test_seeded_sweep_is_identical_serial_processes_dask(dask_client):
    tasks = [(11, i, 200) for i in range(7)]
    serial = run_tasks(seeded_point, tasks, backend="serial")
    procs = run_tasks(seeded_point, tasks, backend="processes", workers=2)
    dask = run_tasks(seeded_point, tasks, backend="dask", scheduler=dask_client)
    for a, b, c in zip(serial, procs, dask):
        assert a.ok and b.ok and c.ok
        # bit for bit: the same seed gives the same draws whatever process runs the task
        assert a.value[0] == b.value[0] == c.value[0]
        assert np.array_equal(a.value[1], b.value[1]) and np.array_equal(a.value[1], c.value[1])
    assert [r.index for r in procs] == list(range(7))
    # and the points differ from each other: the seeds are per task
    assert len({r.value[0] for r in serial}) == 7


@pytest.mark.parametrize("backend", ["serial", "processes", "dask"])
def test_a_failing_task_is_reported_and_the_rest_complete(backend, dask_client):
    scheduler = dask_client if backend == "dask" else None
    results = run_tasks(fails_on_odd, range(6), backend=backend, workers=2, scheduler=scheduler)
    assert [r.ok for r in results] == [True, False] * 3
    assert [r.value for r in results if r.ok] == [0, 20, 40]
    assert results[1].error == "ValueError: task 1 is odd"


def test_progress_and_on_result_see_every_task():
    seen, calls = [], []
    run_tasks(fails_on_odd, range(5), backend="processes", workers=2, on_result=seen.append,
              progress=lambda done, total: calls.append((done, total)))
    assert sorted(r.index for r in seen) == list(range(5))
    assert calls[-1] == (5, 5) and len(calls) == 5


def test_worker_killed_mid_job_is_retried_and_the_job_completes(tmp_path):
    tasks = [(str(tmp_path), i) for i in range(8)]
    results = run_tasks(dies_once, tasks, backend="processes", workers=2)
    assert (tmp_path / "died-3").exists()  # the worker did die
    assert all(r.ok for r in results)
    assert [r.value for r in results] == list(range(8))
    assert results[3].attempts == 2


def test_worker_that_always_dies_is_reported_after_one_retry():
    results = run_tasks(always_dies, range(6), backend="processes", workers=2)
    assert [r.ok for r in results] == [True, True, False, True, True, True]
    assert results[2].error == "worker process died (2 attempts)" and results[2].attempts == 2
    assert run_tasks(always_dies, range(3), backend="processes", workers=2, retries=0)[2].attempts == 1


def test_map_tasks_raises_when_a_point_fails_and_is_a_mapper():
    mapper = functools.partial(map_tasks, backend="processes", workers=2)
    assert mapper(fails_on_odd, [0, 2, 4]) == [0, 20, 40]
    with pytest.raises(SeamodemError, match="1 of 3 tasks failed; task 1: ValueError: task 1 is odd"):
        mapper(fails_on_odd, [0, 1, 2])


@pytest.mark.parametrize(
    "options, message",
    [
        ({"backend": "threads"}, "backend: must be one of serial, processes, dask, got 'threads'"),
        ({"backend": "processes", "workers": 0}, "workers: must be an integer >= 1, got 0"),
        ({"backend": "processes", "scheduler": "tcp://x:1"}, "scheduler: needs backend 'dask'"),
    ],
)
def test_bad_options_are_one_line_errors(options, message):
    with pytest.raises(ConfigError, match=message):
        run_tasks(fails_on_odd, range(2), **options)


def test_unreachable_scheduler_is_a_one_line_error():
    import dask

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}), pytest.raises(ConfigError, match="scheduler: cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'"):
        run_tasks(fails_on_odd, range(2), backend="dask", scheduler="tcp://127.0.0.1:9")


@pytest.fixture(scope="module")
def dask_process_client():
    """A local Dask cluster of 2 worker processes (a task can kill its worker without killing the test)."""
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def test_dask_worker_killed_mid_job_the_task_runs_elsewhere(tmp_path, dask_process_client):
    results = run_tasks(dies_once, [(str(tmp_path), i) for i in range(8)], backend="dask",
                        scheduler=dask_process_client)
    assert (tmp_path / "died-3").exists()
    assert all(r.ok for r in results) and [r.value for r in results] == list(range(8))


@pytest.mark.slow
def test_dask_task_that_always_kills_its_worker_is_reported_alone():
    """The scheduler blames the tasks running beside it too; the lone resubmission clears them (about 10 s)."""
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):  # fail fast: 1 death, not 4
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=":0")
    with cluster, distributed.Client(cluster) as client:
        results = run_tasks(always_dies, range(5), backend="dask", scheduler=client)
    assert [r.ok for r in results] == [True, True, False, True, True]
    assert results[2].error.startswith("worker process died: KilledWorker") and results[2].attempts == 2
