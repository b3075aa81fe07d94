"""Jobs as Dask tasks: a local cluster or any scheduler's address, the same task either way.

The only module that imports ``dask``/``distributed`` (imported lazily by the commands, so
``toolpath --help`` does not load them). A task is :func:`run_packed_task`: one
:class:`~streamline_cam.job_task.PackedJob` in (the sections file's bytes and the request),
one :class:`~streamline_cam.job_task.JobOutcome` out (the report and the job's files as
bytes), so workers need no disk shared with the client. Workers are set up once each by
:class:`WorkerSetup`: the compiled kernels' threads limited so jobs side by side do not fight
for cores, and the kernels loaded before the first job (:func:`~.warmup.load_kernels`).

Nothing lost, nothing twice: a worker that dies (killed, out of memory) takes its task with
it and the scheduler runs the task again on another worker, up to
``distributed.scheduler.allowed-failures`` deaths (3) before the task is given up as
:class:`distributed.KilledWorker`; the task itself writes nothing where the client keeps
results, and the client takes each task's result once.
"""

from __future__ import annotations

import asyncio
import importlib.util
import logging
import os
import threading
import uuid
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Final

import distributed
from distributed import Client, Future, LocalCluster, WorkerPlugin

from .job_task import (
    JobInterrupted,
    JobOutcome,
    PackedJob,
    ThrottledProgress,
    pack_job,
    run_packed_job,
    write_files,
)
from .pipeline import JobRequest
from .warmup import load_kernels

__all__ = [
    "CONNECT_TIMEOUT_S",
    "THREAD_LIMITS",
    "WARM_UP_TOPIC",
    "DaskJobs",
    "SchedulerError",
    "WorkerSetup",
    "as_outcomes",
    "dashboard_link",
    "job_client",
    "run_packed_task",
    "submit_job",
]

log = logging.getLogger(__name__)

#: Threads of the compiled kernels and of the BLAS/OpenMP libraries, per worker process:
#: one job per worker, one core per job (a 2-core machine with 2 workers runs 2 threads, not
#: 2 x 2 numba threads that take turns).
THREAD_LIMITS: Final[dict[str, str]] = {
    "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
}

#: How long a client tries to reach a scheduler before it gives up (s).
CONNECT_TIMEOUT_S: Final[float] = 30.0

#: The topic of the workers' warm-up events (``Client.get_events``): one per process.
WARM_UP_TOPIC: Final[str] = "toolpath-warm-up"

#: Least time between two progress events of one job's stage (s).
PROGRESS_INTERVAL_S: Final[float] = 0.5

Task = Callable[[PackedJob, str | None], JobOutcome]


class SchedulerError(ConnectionError):
    """The Dask scheduler named by ``--scheduler`` cannot be reached."""


class WorkerSetup(WorkerPlugin):
    """Run once in each worker process as it joins: thread limits, then the warm-up.

    Parameters
    ----------
    threads : int
        Threads a job's compiled kernels may use (``numba.set_num_threads`` in each task's
        thread, numba's limit being per thread; workers started by :func:`job_client` also
        get :data:`THREAD_LIMITS` in their environment before they start).
    warm : bool
        Load the compiled kernels now (:func:`~.warmup.load_kernels`), not in the first job.
    """

    name = "streamline-cam-setup"

    def __init__(self, threads: int = 1, *, warm: bool = True) -> None:
        self.threads = threads
        self.warm = warm

    async def setup(self, worker: distributed.Worker) -> None:
        """Limit the threads, then warm up (in a thread: the worker keeps answering).

        Once per worker process: a plugin registered again (each batch's client registers
        it) finds the process warm and returns.
        """
        global _JOB_THREADS
        for name in THREAD_LIMITS:
            os.environ.setdefault(name, str(self.threads))
        _JOB_THREADS = self.threads
        _limit_threads()
        if self.warm and not _WARM.is_set():
            seconds = await asyncio.get_running_loop().run_in_executor(None, _warm_once)
            if seconds is not None:
                worker.log_event(WARM_UP_TOPIC, {"worker": worker.address, "pid": os.getpid(),
                                                 "seconds": round(seconds, 3)})


_WARM = threading.Event()
_WARM_LOCK = threading.Lock()
#: Threads a job's compiled kernels may use in this worker process (set by WorkerSetup).
_JOB_THREADS = 1


def _limit_threads() -> None:
    """Numba's thread count for the calling thread (numba keeps one per thread)."""
    import numba

    numba.set_num_threads(max(1, min(_JOB_THREADS, numba.config.NUMBA_NUM_THREADS)))


def _warm_once() -> float | None:
    """:func:`~.warmup.load_kernels` unless this process is warm; its seconds, or None."""
    with _WARM_LOCK:
        if _WARM.is_set():
            return None
        _limit_threads()
        seconds = load_kernels()
        _WARM.set()
        return seconds


@contextmanager
def job_client(scheduler: str | None = None, *, workers: int | None = None,
               dashboard: bool = True, warm: bool = True) -> Iterator[Client]:
    """A client for jobs: of the scheduler at ``scheduler``, or of a new local cluster.

    The local cluster listens on 127.0.0.1 only, with ``workers`` worker processes
    (default: one per core) of one thread each and :data:`THREAD_LIMITS` in their
    environment; its dashboard (when ``bokeh`` is installed and ``dashboard``) on a free
    local port (the scheduler's HTTP routes, health and metrics, are there either way). Every
    worker, local or remote, is set up by :class:`WorkerSetup` before the first job.
    """
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
            host="127.0.0.1", dashboard_address="127.0.0.1:0",
            scheduler_kwargs={"dashboard": dashboard}, env=dict(THREAD_LIMITS),
            silence_logs=logging.ERROR)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
        except OSError as exc:  # refused, timed out, unknown host
            raise SchedulerError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") \
                from None
    try:
        client.register_plugin(WorkerSetup(warm=warm))
        crowded = [w for w, info in client.scheduler_info().get("workers", {}).items()
                   if info.get("nthreads", 1) > 1]
        if crowded:
            log.warning("%d worker(s) have more than one thread: their jobs share one "
                        "process (start them with `dask worker --nthreads 1`)", len(crowded))
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _has_bokeh() -> bool:
    return importlib.util.find_spec("bokeh") is not None


def dashboard_link(client: Client) -> str | None:
    """The scheduler's dashboard address, when it serves one (``bokeh`` installed there)."""
    services = client.scheduler_info().get("services", {})
    if "dashboard" not in services or not client.run_on_scheduler(_has_bokeh):
        return None
    return client.dashboard_link


class _ProgressEvents(ThrottledProgress):
    """``progress(stage, fraction)`` on a worker: throttled events under the job's topic."""

    def __init__(self, topic: str) -> None:
        super().__init__(PROGRESS_INTERVAL_S)
        self._topic = topic
        self._worker = distributed.get_worker()

    def emit(self, stage: str, fraction: float) -> None:
        self._worker.log_event(self._topic, {"stage": stage, "fraction": float(fraction)})


def run_packed_task(job: PackedJob, progress_topic: str | None = None) -> JobOutcome:
    """The Dask task: :func:`~.job_task.run_packed_job` in the worker's local folder.

    With ``progress_topic``, the job's ``progress(stage, fraction)`` goes to the client as
    events of that topic (:meth:`distributed.Client.subscribe_topic`).
    """
    worker = distributed.get_worker()
    _limit_threads()  # in this task's thread: numba's limit is per thread
    progress = _ProgressEvents(progress_topic) if progress_topic else None
    return run_packed_job(job, scratch_dir=worker.local_directory, progress=progress)


def submit_job(client: Client, job: PackedJob, key: str, *,
               progress_topic: str | None = None, task: Task = run_packed_task) -> Future:
    """Submit ``job`` as one task under ``key`` (``task`` is replaceable for tests)."""
    return client.submit(task, job, progress_topic, key=key, pure=False)


def _outcome_of(future: Future) -> JobOutcome:
    """The future's outcome; a task that could not run becomes a failed outcome."""
    try:
        return future.result()
    except distributed.KilledWorker as exc:
        return JobOutcome(None, error=f"the workers running this job died ({exc}); it was "
                          "tried on a new worker each time and given up", error_type="KilledWorker")
    except Exception as exc:  # the task raised (it should not) or the scheduler was lost
        return JobOutcome(None, error=f"the task failed ({type(exc).__name__}: {exc})",
                          error_type=type(exc).__name__)


def as_outcomes(futures: Iterable[Future], *,
                timeout_s: float | None = None) -> Iterator[tuple[Future, JobOutcome]]:
    """Each future with its outcome, in the order they finish.

    ``TimeoutError`` when they have not all finished after ``timeout_s`` seconds.
    """
    futures = list(futures)
    if not futures:  # (as_completed looks for a default client even for none)
        return
    for future in distributed.as_completed(futures, timeout=timeout_s):
        yield future, _outcome_of(future)


class DaskJobs:
    """The service's jobs on a Dask scheduler (``toolpath serve --scheduler``).

    :meth:`run` has the shape of a local run: the request's sections file is read here,
    the job runs on a worker, its files are written into ``job_dir`` here, and progress
    arrives as the worker reports it.
    """

    def __init__(self, scheduler: str) -> None:
        self.scheduler = scheduler
        self._lock = threading.Lock()
        self._client: Client | None = None
        self._closed = False

    def _connected(self) -> Client:
        with self._lock:
            if self._closed:
                raise JobInterrupted("the service is stopping")
            if self._client is None:
                self._client = Client(self.scheduler, timeout=f"{CONNECT_TIMEOUT_S}s",
                                      set_as_default=False)
                self._client.register_plugin(WorkerSetup())
            return self._client

    def run(self, request: JobRequest, job_dir: Path, *,
            progress: Callable[[str, float], None] | None = None,
            verify: bool = False) -> JobOutcome:
        """Run ``request`` on the cluster, its files written into ``job_dir``.

        Raises :class:`~.job_task.JobInterrupted` when :meth:`close` cut the wait short
        (the job is not failed: the service runs it again at its next start).
        """
        client = self._connected()
        key = f"toolpath-job-{job_dir.name}-{uuid.uuid4().hex[:8]}"
        topic = f"{key}-progress" if progress else None
        packed = pack_job(request, verify=verify)
        try:
            if topic is not None:
                client.subscribe_topic(topic, lambda event: progress(**event[1]))
            try:
                outcome = _outcome_of(submit_job(client, packed, key, progress_topic=topic))
            finally:
                if topic is not None and not self._closed:
                    client.unsubscribe_topic(topic)
        except Exception:
            # close() may shut the client at any point of the above, from another thread:
            # whatever the closed client then raises means the service stops, not a failure
            if self._closed:
                raise JobInterrupted("the service stopped while the job ran on the cluster") \
                    from None
            raise
        if self._closed:
            raise JobInterrupted("the service stopped while the job ran on the cluster")
        if outcome.ok:
            write_files(outcome.files, job_dir)
        return outcome

    def close(self) -> None:
        """Disconnect from the scheduler (its workers keep running)."""
        with self._lock:
            self._closed = True
            if self._client is not None:
                self._client.close()
                self._client = None
