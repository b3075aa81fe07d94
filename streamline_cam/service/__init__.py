"""``toolpath serve``: the pipeline as an HTTP service (FastAPI; jobs in SQLite).

Public index
------------
create_app
    The FastAPI application for a :class:`ServiceConfig` (``app.py``; endpoints in
    ``routes.py``, bodies in ``schemas.py``).
ServiceConfig
    Data folder, workers, executor, upload limit, queue limit, stream targets (``config.py``).
JobStore, JobRecord, JobState
    Jobs and stream requests in ``<data>/jobs.sqlite3``; the queue survives restarts
    (``store.py``).
WorkerPool
    Claims queued jobs and runs them in a bounded process (or thread) pool (``pool.py``);
    each run is :func:`~.runner.run_stored_job` (``runner.py``).
StreamRunner
    Streams finished programs to configured targets via ``streamline_cam.streaming``
    (``streams.py``).

Submissions are checked by the library itself before they are queued (``validation.py``);
plots are drawn on first request (``artefacts.py``).
"""

from __future__ import annotations

import importlib
from typing import Any

# Exported names -> defining module. Loaded on first use, so ``toolpath`` sub-commands
# and worker processes that import a part (the runner, the config) do not import FastAPI.
_EXPORTS = {
    "create_app": ".app",
    "ServiceConfig": ".config",
    "WorkerPool": ".pool",
    "JobRecord": ".store",
    "JobState": ".store",
    "JobStore": ".store",
    "StreamRecord": ".store",
    "StreamState": ".store",
    "StreamRunner": ".streams",
}

__all__ = [
    "JobRecord",
    "JobState",
    "JobStore",
    "ServiceConfig",
    "StreamRecord",
    "StreamRunner",
    "StreamState",
    "WorkerPool",
    "create_app",
]


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name], __name__), name)


def __dir__() -> list[str]:
    return sorted(__all__)
