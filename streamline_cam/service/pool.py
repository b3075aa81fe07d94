"""The worker pool: the store is the queue; a bounded executor runs what it claims.

The pool never hands the executor more jobs than it has workers: when a slot frees (or a
job is submitted) it claims the oldest queued job from the store and submits it. So the
queue survives a restart (it is the database), and the executor's own unbounded queue
stays empty.
"""

from __future__ import annotations

import functools
import importlib
import logging
import multiprocessing
import signal
import threading
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
        """Stop taking jobs; running ones stay ``running`` in the store (re-queued on start).

        Worker processes are stopped (their jobs are redone after the restart); worker
        threads cannot be stopped and finish their job unless ``wait`` is false and the
        process exits.
        """
        with self._lock:
            self._closed = True
            executor, self._executor = self._executor, None
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


def _init_worker_process() -> None:
    """A worker process ignores Ctrl-C (the service stops it) and loads the pipeline."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    importlib.import_module("streamline_cam.pipeline")


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
