"""``toolpath serve`` for real: uvicorn on 127.0.0.1 (port 0), worker processes, a restart."""

from __future__ import annotations

import os
import selectors
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
from _live_server import EventReader
from _service_support import COARSE, JOB_TIMEOUT_S, blade_sections

START_TIMEOUT_S = 30.0
STOP_TIMEOUT_S = 15.0


@contextmanager
def _serve(data_dir: Path) -> Iterator[str]:
    """Run ``toolpath serve --port 0`` and yield its base URL; Ctrl-C it afterwards."""
    process = subprocess.Popen(
        [sys.executable, "-m", "streamline_cam.cli", "serve", "--port", "0", "--data-dir",
         str(data_dir), "--workers", "1", "--log-level", "warning"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        selector = selectors.DefaultSelector()
        selector.register(process.stdout, selectors.EVENT_READ)
        ready = selector.select(timeout=START_TIMEOUT_S)
        selector.close()
        assert ready, "toolpath serve printed nothing"
        banner = process.stdout.readline()
        assert banner.startswith("toolpath serve: http://127.0.0.1:"), (
            banner + process.stderr.read() if process.poll() is not None else banner)
        yield banner.split()[2]
    finally:
        process.send_signal(signal.SIGINT)
        try:
            out, err = process.communicate(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            out, err = process.communicate()
            raise AssertionError(f"toolpath serve did not stop on Ctrl-C:\n{err}") from None
    assert process.returncode == 0, err
    assert "stopped" in out and "Traceback" not in err, err
    assert "timeout graceful shutdown exceeded" not in err, err


def _wait(client: httpx.Client, url: str) -> dict:
    deadline = time.monotonic() + JOB_TIMEOUT_S
    while True:
        status = client.get(url).json()
        if status["state"] in ("done", "failed"):
            return status
        assert time.monotonic() < deadline, status
        time.sleep(0.1)


def test_toolpath_serve_on_loopback_survives_a_restart(tmp_path):
    data = tmp_path / "data"
    with _serve(data) as base, httpx.Client(base_url=base, timeout=10.0) as client:
        health = client.get("/health").json()
        assert (health["executor"], health["workers"]) == ("process", 1)
        assert client.get("/docs").status_code == 200
        answer = client.post("/jobs", json={"sections": blade_sections(), **COARSE})
        assert answer.status_code == 202, answer.text
        job_id = answer.json()["id"]
        status = _wait(client, answer.headers["location"])
        assert status["state"] == "done", status["error"]
        program = client.get(f"/jobs/{job_id}/gcode").text
        assert program.splitlines()[0] == "G21" and program.rstrip().endswith("M30")
        if health["streaming"] == "available":  # streamline_cam.streaming is installed
            answer = client.post(f"/jobs/{job_id}/stream", json={"target": "simulator"})
            assert answer.status_code == 202, answer.text
            stream = _wait(client, answer.headers["location"])
            assert stream["state"] == "done" and stream["result"]["exactly_once"], stream
        else:
            assert client.post(f"/jobs/{job_id}/stream").status_code == 503
    with _serve(data) as base, httpx.Client(base_url=base, timeout=10.0) as client:
        status = client.get(f"/jobs/{job_id}").json()
        assert status["state"] == "done" and status["attempts"] == 1
        assert client.get(f"/jobs/{job_id}/gcode").text == program
        # issue 29: an open event stream ends with the server (Ctrl-C), not after uvicorn's
        # graceful time-out ("Cancel 1 running task(s)" in the log: _serve checks stderr)
        events = EventReader(base)
        _, job = events.wait_for(lambda kind, data: kind == "job", timeout=10.0)
        assert job == status
    assert events.ended.wait(5.0)
    events.close()
