"""A real uvicorn serving the app on 127.0.0.1 in a thread, and a Server-Sent Events reader."""

from __future__ import annotations

import json
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
import uvicorn

from streamline_cam.service import ServiceConfig, create_app
from streamline_cam.service.app import stop_events

START_TIMEOUT_S = 20.0
STOP_TIMEOUT_S = 10.0


@contextmanager
def live_server(data_dir: Path, **config: Any) -> Iterator[tuple[str, Any]]:
    """Yield ``(base_url, app)`` of the service under uvicorn on a free loopback port."""
    config.setdefault("workers", 1)
    config.setdefault("executor", "thread")
    app = create_app(ServiceConfig(data_dir=data_dir, **config))
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(64)
    port = sock.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", timeout_graceful_shutdown=5))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + START_TIMEOUT_S
    while not server.started:
        assert thread.is_alive() and time.monotonic() < deadline, "uvicorn did not start"
        time.sleep(0.02)
    try:
        yield f"http://127.0.0.1:{port}", app
    finally:
        stop_events(app)
        server.should_exit = True
        thread.join(STOP_TIMEOUT_S)
        sock.close()
        assert not thread.is_alive(), "uvicorn did not stop"


class EventReader:
    """Reads ``GET /events`` in a thread; events land in :attr:`events` as ``(type, data)``."""

    def __init__(self, base_url: str) -> None:
        self.events: list[tuple[str, dict[str, Any]]] = []
        self.comments: list[str] = []
        self.ended = threading.Event()
        self.headers: dict[str, str] = {}
        self._socket: socket.socket | None = None
        self._client = httpx.Client(base_url=base_url, timeout=httpx.Timeout(5.0, read=None))
        self._lock = threading.Condition()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            with self._client.stream("GET", "/events") as response:
                self.headers = dict(response.headers)
                self._socket = response.extensions["network_stream"].get_extra_info("socket")
                event, data = None, []
                for line in response.iter_lines():
                    if line.startswith(":"):
                        self.comments.append(line)
                    elif line.startswith("event: "):
                        event = line[7:]
                    elif line.startswith("data: "):
                        data.append(line[6:])
                    elif line == "" and event is not None:
                        with self._lock:
                            self.events.append((event, json.loads("\n".join(data))))
                            self._lock.notify_all()
                        event, data = None, []
        except (httpx.HTTPError, OSError):
            pass
        finally:
            self.ended.set()
            with self._lock:
                self._lock.notify_all()

    def wait_for(self, predicate, timeout: float = 60.0) -> tuple[str, dict[str, Any]]:
        """The first event (type, data) for which ``predicate(type, data)`` holds."""
        deadline = time.monotonic() + timeout
        seen = 0
        with self._lock:
            while True:
                for item in self.events[seen:]:
                    if predicate(*item):
                        return item
                seen = len(self.events)
                left = deadline - time.monotonic()
                assert left > 0 and not self.ended.is_set(), (
                    f"no such event in {timeout:g} s; last: {self.events[-3:]}")
                self._lock.wait(min(left, 0.5))

    def close(self) -> None:
        """Hang up (the socket shut, as a closed browser tab does)."""
        if self._socket is not None:
            try:
                self._socket.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
        self._client.close()
        self._thread.join(5.0)
