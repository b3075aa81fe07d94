"""The worker pool: the store is the queue; a bounded executor runs what it claims.

The pool never hands the executor more jobs than it has workers: when a slot frees (or a
job is submitted) it claims the oldest queued job from the store and submits it. So the
queue survives a restart (it is the database), and the executor's own unbounded queue
stays empty.

Worker processes end with the service however it ends: a graceful stop terminates them
(their jobs go back to the queue, not counted as failed attempts); a crash or ``kill -9``
of the service is seen by each worker's watchdog thread (:func:`_exit_with_parent`), which
ends the worker within :data:`PARENT_POLL_S` of it (or of the compiled call it is in).
"""

from __future__ import annotations

import functools
import importlib
import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from .config import ServiceConfig
from .runner import run_stored_job
from .store import JobStore

__all__ = ["WorkerPool"]

log = logging.getLogger(__name__)

JobFunction = Callable[[Path, Path, str, int], Any]


class WorkerPool:
    """Run the store's queued jobs, ``config.workers`` at a time.

    Parameters
    ----------
    store : JobStore
    config : ServiceConfig
    job_function : callable, optional
        ``f(db_path, job_dir, job_id, attempt)`` run in the executor (module-level, so it
        pickles); default :func:`~.runner.run_stored_job`.
    """

    def __init__(self, store: JobStore, config: ServiceConfig, *,
                 job_function: JobFunction = run_stored_job) -> None:
        self._store = store
        self._config = config
        self._engine: Any = None
        if config.scheduler is not None and job_function is run_stored_job:
            from ..dask_engine import DaskJobs  # only with --scheduler: dask loads lazily

            self._engine = DaskJobs(config.scheduler)
            job_function = functools.partial(run_stored_job, engine=self._engine)
        self._job_function = job_function
        self._lock = threading.RLock()
        self._executor: Executor | None = None
        self._running: dict[Future[Any], tuple[str, int, Executor]] = {}
        self._closed = False

    def _new_executor(self) -> Executor:
        if self._config.executor == "thread" or self._engine is not None:
            # (with a Dask scheduler, a thread here only waits for its job there)
            return ThreadPoolExecutor(max_workers=self._config.workers,
                                      thread_name_prefix="toolpath-job")
        # spawn: a clean interpreter, no copy of the HTTP loop's threads, locks or sockets
        return ProcessPoolExecutor(max_workers=self._config.workers,
                                   mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_init_worker_process)

    @property
    def running(self) -> int:
        """Jobs in the executor now."""
        with self._lock:
            return len(self._running)

    def start(self) -> None:
        """Create the executor (worker processes start loading now) and take queued jobs."""
        with self._lock:
            if self._executor is None and not self._closed:
                self._executor = self._new_executor()
                if isinstance(self._executor, ProcessPoolExecutor):
                    self._executor.submit(_ready)  # start a worker before the first job
        self.dispatch()

    def dispatch(self) -> None:
        """Claim queued jobs while a worker is free (call after each submission)."""
        with self._lock:
            while (self._executor is not None and not self._closed
                   and len(self._running) < self._config.workers):
                record = self._store.claim_next()
                if record is None:
                    return
                job_dir = self._config.jobs_dir / record.id
                future = self._executor.submit(self._job_function, self._config.db_path,
                                               job_dir, record.id, record.attempts)
                self._running[future] = (record.id, record.attempts, self._executor)
                future.add_done_callback(self._finished)

    def _finished(self, future: Future[Any]) -> None:
        with self._lock:
            job_id, attempt, executor = self._running.pop(future)
            if self._closed or future.cancelled():
                return  # stays "running": re-queued by the next start
            error = future.exception()
            if isinstance(error, BrokenProcessPool):
                # A worker process died (killed, out of memory). Which of the pool's jobs
                # caused it is unknown, so each goes back to the queue; max_attempts stops
                # a job that takes down every worker it gets.
                outcome = self._store.release(
                    job_id, attempt, max_attempts=self._config.max_attempts,
                    reason="a worker process died during this job")
                log.error("job %s: its worker process died (%s); %s", job_id, error, outcome)
                if executor is self._executor:  # once per broken pool
                    self._executor = self._new_executor()
                    executor.shutdown(wait=False, cancel_futures=True)
            elif error is not None:  # run_stored_job records job errors itself: a bug
                log.error("job %s: the worker failed: %r", job_id, error)
                self._store.fail(job_id, attempt, f"the worker running this job failed "
                                 f"({type(error).__name__}: {error})", "WorkerError")
        self.dispatch()

    def shutdown(self, *, wait: bool = False) -> None:
        """Stop taking jobs; the running ones go back to the queue (not as failed attempts).

        Worker processes are stopped (their jobs are redone after the restart); worker
        threads cannot be stopped and finish their job unless ``wait`` is false and the
        process exits (that outcome is dropped: the job was re-queued).
        """
        with self._lock:
            self._closed = True
            executor, self._executor = self._executor, None
            stopped = [(job_id, attempt) for job_id, attempt, _ in self._running.values()]
        if self._engine is not None:
            self._engine.close()
        if executor is None:
            return
        # (shutdown forgets the manager thread: taken first)
        manager = getattr(executor, "_executor_manager_thread", None)
        if isinstance(executor, ProcessPoolExecutor) and not wait:
            _terminate_workers(executor)
        executor.shutdown(wait=wait, cancel_futures=True)
        if manager is not None and manager.is_alive():
            _join_manager(manager)
        # a graceful stop is not a failed attempt: the jobs it cut short go back to the queue
        # (a thread still finishing one is superseded: its outcome is dropped)
        for job_id, attempt in stopped:
            if self._store.requeue_stopped(job_id, attempt):
                log.warning("job %s: stopped with the service; queued again", job_id)


#: How often a worker process checks that the service that started it still runs, s.
PARENT_POLL_S = 0.5
#: Exit status of a worker process that ended because the service had gone.
EXIT_SERVICE_GONE = 75


def _init_worker_process() -> None:
    """Set up a worker process: no Ctrl-C (the service stops it), the watchdog, the pipeline."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _exit_with_parent()
    importlib.import_module("streamline_cam.pipeline")


def _exit_with_parent() -> None:
    """Start a daemon thread that ends this process as soon as its parent has ended.

    ``multiprocessing.parent_process()`` holds the read end of a pipe whose write end only
    the parent holds (spawn; on Windows the parent's process handle): it becomes ready when
    the parent ends, however it ends (``kill -9`` included). Where there is no such
    sentinel, the parent pid is polled: an orphan is re-parented, so ``os.getppid()``
    changes. ``PR_SET_PDEATHSIG`` is not used: Linux sends it when the *thread* that
    started the worker ends, and workers are started from short-lived request threads.
    The worker's job is left ``running`` in the store: the next start re-queues it (as a
    crash, which it was).
    """
    parent = multiprocessing.parent_process()
    parent_pid = os.getppid()

    def watch() -> None:
        while True:
            if parent is not None:
                parent.join(timeout=PARENT_POLL_S)  # returns at once when the parent ends
                gone = not parent.is_alive()
            else:
                time.sleep(PARENT_POLL_S)
                gone = False
            if gone or os.getppid() != parent_pid:
                os._exit(EXIT_SERVICE_GONE)

    threading.Thread(target=watch, name="toolpath-parent-watch", daemon=True).start()


def _ready() -> None:
    """Nothing: submitted once so that a worker process starts loading at start-up."""


#: How long a stop waits for the executor's manager thread once its workers are gone, s.
MANAGER_JOIN_S = 5.0


def _join_manager(thread: threading.Thread) -> None:
    """Let a process pool's manager thread end (its workers stopped) before the process does.

    Python 3.11's exit hook wakes every manager thread through a pipe the thread closes as
    it ends: a thread still ending then makes the hook write to a closed pipe ("Bad file
    descriptor" at exit; CPython 3.12 holds a lock there). The wait is bounded.
    """
    thread.join(timeout=MANAGER_JOIN_S)


def _terminate_workers(executor: ProcessPoolExecutor) -> None:
    """Stop the worker processes now (``terminate_workers`` from Python 3.14 on)."""
    terminate = getattr(executor, "terminate_workers", None)
    if terminate is not None:
        terminate()
        return
    for process in list(getattr(executor, "_processes", {}).values()):
        if process.is_alive():
            process.terminate()
