"""The live feed behind ``GET /events``: job and stream changes pushed to every listener.

:class:`EventHub` fans events out to the open ``/events`` connections (one bounded
:class:`asyncio.Queue` each; publishers are threads). Jobs change in worker processes,
threads or Dask workers that only write the store, so :class:`JobWatcher` looks at the
store while anyone listens: ``PRAGMA data_version`` on one open connection (microseconds)
every :data:`WATCH_INTERVAL_S`, and only when another connection has written, it reads the
active and recently finished jobs and publishes those whose view changed. Streams run in
this process and publish their own changes (:class:`~.streams.StreamRunner`).

Wire format (Server-Sent Events): ``event: job`` or ``event: stream``, ``data:`` one line
of JSON, a blank line; a comment ``: ping`` every :data:`HEARTBEAT_S` keeps proxies from
closing an idle connection.
"""

from __future__ import annotations

import asyncio
import json
import logging
import sqlite3
import threading
import time
from collections.abc import Callable
from contextlib import closing
from pathlib import Path
from typing import Any, Final

from .config import HEARTBEAT_S
from .store import JobRecord, JobStore, StreamRecord

__all__ = [
    "CLOSED",
    "HEARTBEAT_S",
    "WATCH_INTERVAL_S",
    "EventHub",
    "JobWatcher",
    "Subscription",
    "sse",
]

log = logging.getLogger(__name__)

WATCH_INTERVAL_S: Final[float] = 0.1
"""How often the watcher asks SQLite whether the store changed (s), while anyone listens."""
RECENT_S: Final[float] = 10.0
"""Jobs finished this recently are compared on each change (s): their last state is sent."""
QUEUE_EVENTS: Final[int] = 2000
"""Events a slow listener may fall behind by; beyond, its connection ends (the browser
reconnects and gets every job again)."""

Event = tuple[str, dict[str, Any]]


def sse(event: str, data: Any) -> str:
    """One Server-Sent Event: ``event: NAME``, ``data: JSON``, blank line."""
    return f"event: {event}\ndata: {json.dumps(data, separators=(',', ':'), default=str)}\n\n"


#: What :meth:`Subscription.get` answers when the feed has ended (the hub closed, or the
#: listener fell too far behind).
CLOSED: Final = "closed"


class Subscription:
    """One listener's queue, fed from any thread through its event loop."""

    def __init__(self, hub: EventHub, loop: asyncio.AbstractEventLoop) -> None:
        self._hub = hub
        self.loop = loop
        self.queue: asyncio.Queue[Event | None] = asyncio.Queue(QUEUE_EVENTS)
        self._ended = False

    async def get(self, timeout_s: float) -> Event | str | None:
        """The next event, ``None`` after ``timeout_s`` without one, or :data:`CLOSED`."""
        if self._ended:
            return CLOSED
        try:
            item = await asyncio.wait_for(self.queue.get(), timeout_s)
        except TimeoutError:
            return None
        if item is None:
            self._ended = True
            return CLOSED
        return item

    def close(self) -> None:
        """Stop listening."""
        self._hub._drop(self)

    def put(self, item: Event | None) -> None:
        """Queue ``item`` (in the loop's thread); ``None`` ends the feed."""
        try:
            self.queue.put_nowait(item)
        except asyncio.QueueFull:  # too far behind: end it (the client reconnects)
            while not self.queue.empty():
                self.queue.get_nowait()
            self.queue.put_nowait(None)


class EventHub:
    """Publish events from any thread to every listener; :meth:`close` ends all listeners."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._listeners: set[Subscription] = set()
        self._closed = False
        self._changed = threading.Condition(self._lock)

    @property
    def listeners(self) -> int:
        """Open listeners."""
        with self._lock:
            return len(self._listeners)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called (the service stops)."""
        return self._closed

    def publish(self, event: str, data: dict[str, Any]) -> None:
        """Send ``event`` with ``data`` (JSON-able) to every listener (thread-safe)."""
        with self._lock:
            listeners = list(self._listeners)
        for listener in listeners:
            _call_soon(listener, (event, data))

    def wait_for_listeners(self, timeout: float) -> bool:
        """Block until someone listens (or the hub closes); whether anyone listens."""
        with self._lock:
            self._changed.wait_for(lambda: self._listeners or self._closed, timeout)
            return bool(self._listeners) and not self._closed

    def subscribe(self) -> Subscription:
        """A new listener, registered now (nothing published after this call is lost).

        Call from the event loop that will read it; :meth:`Subscription.close` when done.
        """
        subscription = Subscription(self, asyncio.get_running_loop())
        with self._lock:
            if self._closed:
                subscription.put(None)
            else:
                self._listeners.add(subscription)
                self._changed.notify_all()
        return subscription

    def _drop(self, subscription: Subscription) -> None:
        with self._lock:
            self._listeners.discard(subscription)

    def close(self) -> None:
        """End every listener now and refuse new ones (safe from a signal handler)."""
        with self._lock:
            self._closed = True
            listeners = list(self._listeners)
            self._changed.notify_all()
        for listener in listeners:
            _call_soon(listener, None)


def _call_soon(listener: Subscription, item: Event | None) -> None:
    try:
        listener.loop.call_soon_threadsafe(listener.put, item)
    except RuntimeError:  # its loop has closed: the connection is gone
        pass


JobView = Callable[[JobRecord, list[StreamRecord]], dict[str, Any]]


class JobWatcher:
    """Publish a ``job`` event whenever a job's view changes in the store.

    Parameters
    ----------
    store : JobStore
    hub : EventHub
    view : callable
        ``view(record, streams) -> dict``: the JSON of ``GET /jobs/{id}``.
    interval_s : float
        See :data:`WATCH_INTERVAL_S`.
    """

    def __init__(self, store: JobStore, hub: EventHub, view: JobView, *,
                 interval_s: float = WATCH_INTERVAL_S) -> None:
        self._store, self._hub, self._view = store, hub, view
        self._interval_s = interval_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._seen: dict[str, str] = {}

    def start(self) -> None:
        """Start the watcher thread (a daemon: it never holds the process up)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._watch, name="toolpath-events",
                                            daemon=True)
            self._thread.start()

    def stop(self) -> None:
        """Stop the thread (bounded wait)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)

    def _watch(self) -> None:
        version = None
        with closing(_open(self._store.path)) as db:
            while not self._stop.is_set():
                if not self._hub.wait_for_listeners(timeout=0.5):
                    if self._hub.closed:
                        return
                    version = None  # nobody listened: compare afresh when someone does
                    continue
                try:
                    now_version = db.execute("PRAGMA data_version").fetchone()[0]
                    if now_version != version:
                        version = now_version
                        self.scan()
                except sqlite3.Error:
                    log.exception("event watcher: reading the job store failed")
                self._stop.wait(self._interval_s)

    def scan(self) -> int:
        """Publish the jobs whose view changed since the last scan; how many."""
        since = time.time() - RECENT_S
        records = self._store.changing_jobs(finished_after=since)
        streams = self._store.streams_of_jobs([r.id for r in records])
        published = 0
        current: dict[str, str] = {}
        for record in records:
            view = self._view(record, streams.get(record.id, []))
            text = json.dumps(view, sort_keys=True, default=str)
            current[record.id] = text
            if self._seen.get(record.id) != text:
                self._hub.publish("job", view)
                published += 1
        self._seen = current
        return published


def _open(path: Path) -> sqlite3.Connection:
    return sqlite3.connect(path, timeout=10.0, isolation_level=None, check_same_thread=False)
