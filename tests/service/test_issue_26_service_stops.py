"""Issue 26: pool workers end with the service however it ends; a graceful stop is no failure.

After a ``kill -9`` of ``toolpath serve`` its worker processes stayed alive (orphans of
init, holding memory and the job store open). A graceful stop counted as a failed attempt,
so a job stopped three times by restarts failed. Now each worker watches its parent and
ends with it, and a graceful stop re-queues its jobs counting them in ``stops``.
"""

from __future__ import annotations

import os
import selectors
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from _service_support import COARSE, blade_sections, wait_for_job

from streamline_cam.service import JobState, JobStore, ServiceConfig, WorkerPool

START_TIMEOUT_S = 60.0
#: Workers must be gone this long after the service was killed (the watchdog polls every
#: 0.5 s; an idle worker ends at once): generous for a busy 2-core machine.
GONE_TIMEOUT_S = 15.0


def _children(pid: int) -> set[int]:
    """Live (not zombie) processes whose parent is ``pid`` (Linux ``/proc``)."""
    found = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[1]) == pid and fields[0] != "Z":
            found.add(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2:].split()[0] != "Z"  # a zombie has ended


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_worker_processes_end_when_the_service_is_killed(tmp_path):
    process = subprocess.Popen(
        [sys.executable, "-m", "streamline_cam.cli", "serve", "--port", "0", "--data-dir",
         str(tmp_path / "data"), "--workers", "2", "--executor", "process",
         "--log-level", "warning"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        selector = selectors.DefaultSelector()
        selector.register(process.stdout, selectors.EVENT_READ)
        assert selector.select(timeout=START_TIMEOUT_S), "toolpath serve printed nothing"
        selector.close()
        assert process.stdout.readline().startswith("toolpath serve: http://127.0.0.1:")
        deadline = time.monotonic() + START_TIMEOUT_S
        while not (workers := _children(process.pid)):  # the pool starts one at once
            assert time.monotonic() < deadline, "no worker process started"
            time.sleep(0.1)
        time.sleep(1.0)  # let it reach its idle wait (it imports the pipeline first)
        workers = _children(process.pid)
    finally:
        process.send_signal(signal.SIGKILL)
        process.communicate(timeout=30)
    deadline = time.monotonic() + GONE_TIMEOUT_S
    while alive := {pid for pid in workers if _alive(pid)}:
        if time.monotonic() > deadline:
            for pid in alive:  # do not leave them behind either way
                os.kill(pid, signal.SIGKILL)
            pytest.fail(f"worker processes {sorted(alive)} outlived the killed service")
        time.sleep(0.1)


def test_graceful_stops_requeue_without_counting_as_attempts(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.add({}, input_name="blade.csv")
    for run in (1, 2, 3, 4):  # stopped four times by restarts, more than max_attempts
        claimed = store.claim_next()
        assert (claimed.id, claimed.attempts) == (job.id, run)
        assert store.requeue_stopped(job.id, run)
        assert store.recover(max_attempts=3) == ([], [])  # nothing left running
        record = store.get(job.id)
        assert (record.state, record.stops) == (JobState.QUEUED, run)
    last = store.claim_next()
    assert store.finish(job.id, last.attempts, {"ok": True})
    assert not store.requeue_stopped(job.id, last.attempts)  # finished: stays done
    assert store.get(job.id).state is JobState.DONE


def test_crashes_still_count_between_graceful_stops(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.add({}, input_name="blade.csv")
    store.requeue_stopped(job.id, store.claim_next().attempts)  # a graceful stop
    for crash in (1, 2, 3):  # then killed mid-job three times
        store.claim_next()
        requeued, failed = store.recover(max_attempts=3)
        assert (requeued, failed) == (([job.id], []) if crash < 3 else ([], [job.id]))
    record = store.get(job.id)
    assert (record.state, record.attempts, record.stops) == (JobState.FAILED, 4, 1)
    assert "stopped during this job (3 times" in record.error


def test_a_version_1_store_gains_the_stops_column(tmp_path):
    path = tmp_path / "jobs.sqlite3"
    with sqlite3.connect(path) as db:  # the jobs table as version 1 made it
        db.execute("CREATE TABLE jobs (seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL "
                   "UNIQUE, state TEXT NOT NULL, parameters TEXT NOT NULL, input_name TEXT NOT "
                   "NULL, created REAL NOT NULL, started REAL, finished REAL, attempts INTEGER "
                   "NOT NULL DEFAULT 0, stage TEXT, progress TEXT NOT NULL DEFAULT '{}', error "
                   "TEXT, error_type TEXT, report TEXT)")
        db.execute("INSERT INTO jobs (id, state, parameters, input_name, created, attempts) "
                   "VALUES ('old', 'running', '{}', 'b.csv', 0, 2)")
        db.execute("PRAGMA user_version = 1")
    store = JobStore(path)
    assert store.get("old").stops == 0
    assert store.requeue_stopped("old", 2) and store.get("old").stops == 1


def test_a_pool_stopped_three_times_mid_job_still_runs_it(tmp_path):
    release = threading.Event()
    started = threading.Semaphore(0)

    def job(db_path, job_dir, job_id, attempt):  # blocks until released, like a long plan
        started.release()
        release.wait(30.0)
        JobStore(db_path).finish(job_id, attempt, {"attempt": attempt})

    config = ServiceConfig(data_dir=tmp_path, executor="thread", workers=1, max_attempts=3)
    store = JobStore(config.db_path)
    job_id = store.add({}, input_name="b.csv").id
    try:
        for stop in (1, 2, 3):
            store.recover(max_attempts=config.max_attempts)  # what a start does
            pool = WorkerPool(store, config, job_function=job)
            pool.start()
            assert started.acquire(timeout=30.0)
            pool.shutdown()  # graceful stop mid-job
            record = store.get(job_id)
            assert (record.state, record.attempts, record.stops) == (JobState.QUEUED, stop, stop)
        release.set()  # the stopped threads finish: superseded, their outcome dropped
        assert store.recover(max_attempts=config.max_attempts) == ([], [])
        pool = WorkerPool(store, config, job_function=job)
        pool.start()
        deadline = time.monotonic() + 30.0
        while (record := store.get(job_id)).state is not JobState.DONE:
            assert record.state is not JobState.FAILED and time.monotonic() < deadline, record
            time.sleep(0.02)
        pool.shutdown()
    finally:
        release.set()
    assert (record.attempts, record.stops, record.report) == (4, 3, {"attempt": 4})


def test_the_job_status_shows_graceful_stops(service_client, tmp_path):
    data = tmp_path / "data"
    with service_client(data, start_workers=False) as client:
        job_id = client.post("/jobs", json={"sections": blade_sections(), **COARSE}).json()["id"]
    store = JobStore(data / "jobs.sqlite3")
    store.requeue_stopped(job_id, store.claim_next().attempts)
    with service_client(data) as client:
        status = wait_for_job(client, job_id)
    assert (status["state"], status["attempts"], status["stops"]) == ("done", 2, 1)
