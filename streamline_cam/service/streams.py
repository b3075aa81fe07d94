"""Streaming a finished job's program to a configured target (a machine or the simulator).

The streamer comes from :func:`streamline_cam.streaming.make_streamer`, imported when
needed: without it the endpoint answers 503 rather than pretend. Each target has its own
single-thread executor, so two programs never interleave on one controller, and a slow
machine does not hold up the simulator. Stream requests are recorded in the store; one cut
short by a service stop is failed at the next start, never re-sent (see :mod:`.store`).
"""

from __future__ import annotations

import importlib
import logging
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from .config import ServiceConfig
from .runner import USER_ERRORS
from .store import JobRecord, JobStore, StreamRecord

__all__ = [
    "STREAMING_MODULE",
    "MakeStreamer",
    "StreamRunner",
    "StreamingUnavailable",
    "load_make_streamer",
]

log = logging.getLogger(__name__)

STREAMING_MODULE = "streamline_cam.streaming"

MakeStreamer = Callable[[str], Callable[[Path, Any], dict[str, Any]]]


class StreamingUnavailable(RuntimeError):
    """Streaming cannot be offered by this installation (answered as 503)."""


def load_make_streamer() -> MakeStreamer:
    """``make_streamer`` from :mod:`streamline_cam.streaming`.

    Raises
    ------
    StreamingUnavailable
        The module is missing, fails to import, or lacks ``make_streamer``.
    """
    try:
        module = importlib.import_module(STREAMING_MODULE)
    except ImportError as exc:
        raise StreamingUnavailable(
            f"streaming is not available in this installation: {STREAMING_MODULE} cannot "
            f"be imported ({exc})") from None
    make = getattr(module, "make_streamer", None)
    if make is None:
        raise StreamingUnavailable(f"streaming is not available: {STREAMING_MODULE} has no "
                                   "make_streamer")
    return make


class StreamRunner:
    """Runs stream requests, one at a time per target.

    Parameters
    ----------
    store : JobStore
    config : ServiceConfig
    loader : callable, optional
        Returns ``make_streamer``; default :func:`load_make_streamer`.
    """

    def __init__(self, store: JobStore, config: ServiceConfig, *,
                 loader: Callable[[], MakeStreamer] = load_make_streamer) -> None:
        self._store = store
        self._config = config
        self._loader = loader
        self._lock = threading.Lock()
        self._executors: dict[str, ThreadPoolExecutor] = {}

    def availability(self) -> str:
        """``"available"``, or why streaming is not."""
        try:
            self._loader()
        except StreamingUnavailable as exc:
            return str(exc)
        return "available"

    def submit(self, job: JobRecord, target: str) -> StreamRecord | None:
        """Record a stream of ``job``'s program to ``target`` and start it.

        Returns
        -------
        StreamRecord or None
            ``None`` when a stream of this job is still queued or running.

        Raises
        ------
        KeyError
            ``target`` is not configured.
        StreamingUnavailable
            No streamer in this installation.
        """
        address = self._config.stream_targets[target]
        make_streamer = self._loader()
        record = self._store.add_stream(job.id, target)
        if record is None:
            return None
        with self._lock:
            executor = self._executors.get(target)
            if executor is None:
                executor = ThreadPoolExecutor(max_workers=1,
                                              thread_name_prefix=f"toolpath-stream-{target}")
                self._executors[target] = executor
            executor.submit(self._run, record.id, job, address, make_streamer)
        return record

    def _run(self, stream_id: str, job: JobRecord, address: str,
             make_streamer: MakeStreamer) -> None:
        if not self._store.start_stream(stream_id):
            return
        from machines.machine import load_machine

        try:
            machine = load_machine(job.parameters["machine"])
            result = make_streamer(address)(self._config.jobs_dir / job.id / "part.nc", machine)
        except USER_ERRORS as exc:
            self._store.end_stream(stream_id, error=f"{type(exc).__name__}: {exc}")
        except Exception as exc:  # a sender error or a bug: recorded, the service stays up
            log.exception("stream %s failed", stream_id)
            self._store.end_stream(stream_id, error=f"{type(exc).__name__}: {exc}")
        else:
            result = dict(result)
            if "journal" in result:  # a server path: give the resource instead
                result["journal"] = f"/jobs/{job.id}/journal"
            refused = None
            if result.get("ok") is False:
                refused = str(result.get("refused") or result.get("error")
                              or "the streamer reported ok: false")
            self._store.end_stream(stream_id, result=result, error=refused)

    def shutdown(self) -> None:
        """Stop taking streams (a running one ends with the process)."""
        with self._lock:
            executors, self._executors = list(self._executors.values()), {}
        for executor in executors:
            executor.shutdown(wait=False, cancel_futures=True)
