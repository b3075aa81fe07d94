"""The service's settings: one frozen record, every default with its reason."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Final

__all__ = [
    "DEFAULT_MAX_QUEUED",
    "DEFAULT_MAX_UPLOAD_BYTES",
    "DEFAULT_STREAM_TARGETS",
    "EXECUTORS",
    "HEARTBEAT_S",
    "MAX_ATTEMPTS",
    "ServiceConfig",
    "default_workers",
]

DEFAULT_MAX_UPLOAD_BYTES: Final[int] = 8 * 1024 * 1024
"""8 MiB per request body: the bundled 15 x 142 blade is 80 kB of CSV; a dense scan of 200
sections x 1000 points is about 8 MB. Larger bodies get 413 before they are read."""

DEFAULT_MAX_QUEUED: Final[int] = 100
"""Jobs waiting for a worker before submissions get 503: a full blade at 0.005 mm scallop
takes minutes, so a hundred is hours of work; more is a client in a loop."""

DEFAULT_STREAM_TARGETS: Final[Mapping[str, str]] = MappingProxyType({"simulator": "simulate"})
"""Where ``POST /jobs/{id}/stream`` may send a program, by name. Only the built-in
simulator by default; real machines are added by the operator (``--target NAME=PORT``),
never by the HTTP client, so a request cannot open an arbitrary port."""

EXECUTORS: Final[tuple[str, ...]] = ("process", "thread")

HEARTBEAT_S: Final[float] = 15.0
"""A comment line after this long without an event (s): idle connections stay open."""

MAX_ATTEMPTS: Final[int] = 3
"""A job cut short this many times by a crash (its worker process or the service killed
mid-job) is failed instead of re-queued: a job that takes the service down (out of memory)
must not do it forever. A graceful stop of the service re-queues its jobs without counting."""


def default_workers() -> int:
    """One worker per core but one (left for the HTTP loop), between 1 and 4."""
    return max(1, min(4, (os.cpu_count() or 2) - 1))


@dataclass(frozen=True)
class ServiceConfig:
    """Settings of one service instance.

    Attributes
    ----------
    data_dir : Path
        Holds ``jobs.sqlite3`` (the job store) and ``jobs/<id>/`` (inputs and results).
    workers : int
        Jobs run at the same time (size of the worker pool, >= 1).
    executor : {"process", "thread"}
        ``process`` (default): each job in a worker process, so a CPU-bound fit or plan
        never holds the HTTP loop's GIL and a crash cannot take the service down.
        ``thread``: in the service process (fast start; tests).
    max_upload_bytes : int
        Largest request body, bytes (413 above).
    max_queued : int
        Largest number of queued jobs (503 above).
    stream_targets : Mapping[str, str]
        Target name -> ``make_streamer`` target (``"simulate"`` or a port such as
        ``"socket://127.0.0.1:PORT"``).
    start_workers : bool
        Start taking jobs at start-up (``False`` leaves them queued; tests).
    max_attempts : int
        See :data:`MAX_ATTEMPTS`.
    scheduler : str or None
        A Dask scheduler's address (``tcp://HOST:8786``): jobs run on its workers
        (:class:`~streamline_cam.dask_engine.DaskJobs`), ``workers`` of them at once, each
        waited for by a thread here. None (default): the local pool of ``executor``.
    heartbeat_s : float
        Seconds between ``: ping`` comments on an idle ``/events`` stream (> 0; see
        :data:`HEARTBEAT_S`): shorter behind a proxy that
        drops connections idle for less.
    """

    data_dir: Path
    workers: int = field(default_factory=default_workers)
    executor: str = "process"
    max_upload_bytes: int = DEFAULT_MAX_UPLOAD_BYTES
    max_queued: int = DEFAULT_MAX_QUEUED
    stream_targets: Mapping[str, str] = field(default_factory=lambda: DEFAULT_STREAM_TARGETS)
    start_workers: bool = True
    max_attempts: int = MAX_ATTEMPTS
    scheduler: str | None = None
    heartbeat_s: float = HEARTBEAT_S

    def __post_init__(self) -> None:
        object.__setattr__(self, "data_dir", Path(self.data_dir))
        object.__setattr__(self, "stream_targets", MappingProxyType(dict(self.stream_targets)))
        if not isinstance(self.workers, int) or self.workers < 1:
            raise ValueError(f"workers must be an integer >= 1, got {self.workers!r}")
        if self.executor not in EXECUTORS:
            raise ValueError(f"executor must be one of {EXECUTORS}, got {self.executor!r}")
        for name in ("max_upload_bytes", "max_queued", "max_attempts"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if not self.heartbeat_s > 0.0:
            raise ValueError(f"heartbeat_s must be > 0 s, got {self.heartbeat_s!r}")

    @property
    def db_path(self) -> Path:
        """The SQLite file of the job store."""
        return self.data_dir / "jobs.sqlite3"

    @property
    def jobs_dir(self) -> Path:
        """The folder of the jobs' files (one sub-folder per job)."""
        return self.data_dir / "jobs"
