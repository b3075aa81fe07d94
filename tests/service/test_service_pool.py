"""The worker pool: bounded, FIFO, and a dead worker process neither loses nor loops a job."""

from __future__ import annotations

import os
import threading
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from streamline_cam.service import JobState, JobStore, ServiceConfig, WorkerPool


def _wait_states(store: JobStore, ids: list[str], timeout: float = 30.0) -> list:
    deadline = time.monotonic() + timeout
    while True:
        records = [store.get(i) for i in ids]
        if all(r.state in (JobState.DONE, JobState.FAILED) for r in records):
            return records
        assert time.monotonic() < deadline, records
        time.sleep(0.02)


def _pool(tmp_path: Path, job_function, **config) -> tuple[JobStore, WorkerPool]:
    config = ServiceConfig(data_dir=tmp_path, **{"executor": "thread", "workers": 1, **config})
    store = JobStore(config.db_path)
    return store, WorkerPool(store, config, job_function=job_function)


def test_never_more_jobs_at_once_than_workers_and_oldest_first(tmp_path):
    lock = threading.Lock()
    running, peak, order = [0], [0], []

    def job(db_path, job_dir, job_id, attempt):
        with lock:
            running[0] += 1
            peak[0] = max(peak[0], running[0])
            order.append(job_id)
        time.sleep(0.05)
        with lock:
            running[0] -= 1
        JobStore(db_path).finish(job_id, attempt, {})

    store, pool = _pool(tmp_path, job, workers=2)
    ids = [store.add({}, input_name="b.csv").id for _ in range(6)]
    pool.start()
    try:
        assert all(r.state is JobState.DONE for r in _wait_states(store, ids))
    finally:
        pool.shutdown()
    assert peak[0] == 2
    assert sorted(order[:2]) == sorted(ids[:2])  # the two oldest start first
    assert set(order) == set(ids) and len(order) == 6


def test_a_dead_worker_requeues_its_job_then_gives_up(tmp_path):
    deaths = {"once": 1, "always": 99}

    def job(db_path, job_dir, job_id, attempt):
        store = JobStore(db_path)
        name = store.get(job_id).parameters["name"]
        if attempt <= deaths[name]:
            raise BrokenProcessPool("a worker died")
        store.finish(job_id, attempt, {"attempt": attempt})

    store, pool = _pool(tmp_path, job, max_attempts=3)
    once = store.add({"name": "once"}, input_name="b.csv").id
    always = store.add({"name": "always"}, input_name="b.csv").id
    pool.start()
    try:
        first, second = _wait_states(store, [once, always])
    finally:
        pool.shutdown()
    assert (first.state, first.attempts, first.report) == (JobState.DONE, 2, {"attempt": 2})
    assert (second.state, second.attempts) == (JobState.FAILED, 3)
    assert "worker process died during this job (3 times" in second.error


def _exit_now(db_path, job_dir, job_id, attempt):  # module level: runs in a worker process
    store = JobStore(db_path)
    if store.get(job_id).parameters.get("crash") and attempt == 1:
        os._exit(3)  # as if killed for memory
    store.finish(job_id, attempt, {"pid": os.getpid()})


def test_a_worker_process_that_dies_is_replaced(tmp_path):
    store, pool = _pool(tmp_path, _exit_now, executor="process")
    crash = store.add({"crash": True}, input_name="b.csv").id
    pool.start()
    try:
        (record,) = _wait_states(store, [crash], timeout=45.0)
        after = store.add({}, input_name="b.csv").id
        pool.dispatch()
        (later,) = _wait_states(store, [after], timeout=45.0)
    finally:
        pool.shutdown()
    assert (record.state, record.attempts) == (JobState.DONE, 2)
    assert later.state is JobState.DONE and later.report["pid"] != os.getpid()


def test_a_stop_ends_the_process_pools_manager_thread(tmp_path):
    # the workers are stopped and the executor's manager thread has ended when shutdown
    # returns: Python 3.11's exit hook would otherwise write to its closed wakeup pipe
    store, pool = _pool(tmp_path, _exit_now, executor="process")
    job = store.add({}, input_name="b.csv").id
    pool.start()
    try:
        _wait_states(store, [job], timeout=45.0)
        manager = pool._executor._executor_manager_thread
        assert manager is not None and manager.is_alive()
    finally:
        pool.shutdown()
    assert not manager.is_alive()
