"""``POST /jobs/{id}/stream``: 503 without a streamer, the plumbing with an injected one."""

from __future__ import annotations

import importlib.util
import json
import sys
import threading
import time
from pathlib import Path

import pytest
from _service_support import blade_csv, upload

from streamline_cam.service.streams import STREAMING_MODULE


def _wait_stream(client, job_id: str, stream_id: str, timeout: float = 60.0) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        view = client.get(f"/jobs/{job_id}/streams/{stream_id}").json()
        if view["state"] in ("done", "failed"):
            return view
        assert time.monotonic() < deadline, view
        time.sleep(0.05)


def test_stream_answers_503_when_the_installation_has_no_streamer(
        service_client, finished_job, monkeypatch):
    monkeypatch.setitem(sys.modules, STREAMING_MODULE, None)  # import fails, as if absent
    data_dir, job_id = finished_job
    with service_client(data_dir) as client:
        answer = client.post(f"/jobs/{job_id}/stream", json={"target": "simulator"})
        assert answer.status_code == 503
        assert "streaming is not available" in answer.json()["detail"]
        assert "streaming is not available" in client.get("/health").json()["streaming"]
        assert client.get(f"/jobs/{job_id}").json()["streams"] == []  # nothing recorded


class _Recorder:
    """An injected ``make_streamer`` recording its calls (tests the service's plumbing only)."""

    def __init__(self, fail: bool = False, refuse: bool = False,
                 gate: threading.Event | None = None) -> None:
        self.calls: list[tuple[str, Path, str]] = []
        self.fail, self.refuse, self.gate = fail, refuse, gate

    def __call__(self, target: str):
        def stream(gcode_path: Path, machine, *, control=None) -> dict:
            self.calls.append((target, Path(gcode_path), machine.name))
            if self.gate is not None:
                assert self.gate.wait(30.0)
            if self.fail:
                raise ConnectionRefusedError("no controller at " + target)
            if self.refuse:
                return {"ok": False, "refused": "pre-flight: line 7: X beyond travel"}
            return {"ok": True, "lines_sent": len(Path(gcode_path).read_text().splitlines())}

        return stream


def test_stream_runs_the_programme_on_the_configured_target(service_client, finished_job):
    data_dir, job_id = finished_job
    recorder = _Recorder()
    targets = {"simulator": "simulate", "mill": "socket://127.0.0.1:5999"}
    with service_client(data_dir, stream_loader=lambda: recorder,
                        stream_targets=targets) as client:
        answer = client.post(f"/jobs/{job_id}/stream", json={"target": "mill"})
        assert answer.status_code == 202, answer.text
        assert answer.headers["location"].startswith(f"/jobs/{job_id}/streams/")
        view = _wait_stream(client, job_id, answer.json()["id"])
        assert view["state"] == "done" and view["target"] == "mill"
        program = data_dir / "jobs" / job_id / "part.nc"
        assert recorder.calls == [("socket://127.0.0.1:5999", program, "grbl-router")]
        assert view["result"] == {"ok": True,
                                  "lines_sent": len(program.read_text().splitlines())}
        default = client.post(f"/jobs/{job_id}/stream")  # no body: the simulator
        assert _wait_stream(client, job_id, default.json()["id"])["target"] == "simulator"
        assert [s["target"] for s in client.get(f"/jobs/{job_id}").json()["streams"]] == [
            "mill", "simulator"]

        unknown = client.post(f"/jobs/{job_id}/stream", json={"target": "/dev/ttyUSB0"})
        assert unknown.status_code == 422
        assert unknown.json()["detail"][0]["loc"] == ["body", "target"]
        assert "streams to simulator, mill" in unknown.json()["detail"][0]["msg"]


def test_a_failing_stream_records_its_error(service_client, finished_job):
    data_dir, job_id = finished_job
    with service_client(data_dir, stream_loader=lambda: _Recorder(fail=True)) as client:
        answer = client.post(f"/jobs/{job_id}/stream", json={"target": "simulator"})
        view = _wait_stream(client, job_id, answer.json()["id"])
        assert view["state"] == "failed"
        assert view["error"] == "ConnectionRefusedError: no controller at simulate"


def test_a_refused_stream_is_failed_with_the_streamers_reason(service_client, finished_job):
    data_dir, job_id = finished_job
    with service_client(data_dir, stream_loader=lambda: _Recorder(refuse=True)) as client:
        answer = client.post(f"/jobs/{job_id}/stream", json={"target": "simulator"})
        view = _wait_stream(client, job_id, answer.json()["id"])
        assert view["state"] == "failed" and view["error"].startswith("pre-flight: line 7")
        assert view["result"]["ok"] is False


def test_one_stream_of_a_job_at_a_time(service_client, finished_job):
    data_dir, job_id = finished_job
    gate = threading.Event()
    targets = {"simulator": "simulate", "mill": "socket://127.0.0.1:5999"}
    with service_client(data_dir, stream_loader=lambda: _Recorder(gate=gate),
                        stream_targets=targets) as client:
        first = client.post(f"/jobs/{job_id}/stream", json={"target": "simulator"})
        assert first.status_code == 202
        second = client.post(f"/jobs/{job_id}/stream", json={"target": "mill"})
        assert second.status_code == 409 and "already being streamed" in second.text
        gate.set()
        assert _wait_stream(client, job_id, first.json()["id"])["state"] == "done"
        again = client.post(f"/jobs/{job_id}/stream", json={"target": "mill"})
        assert again.status_code == 202
        assert _wait_stream(client, job_id, again.json()["id"])["state"] == "done"


def test_only_finished_jobs_are_streamed(service_client):
    with service_client(start_workers=False, stream_loader=lambda: _Recorder()) as client:
        job = upload(client, blade_csv()).json()
        answer = client.post(f"/jobs/{job['id']}/stream", json={"target": "simulator"})
        assert answer.status_code == 409 and "is queued" in answer.json()["detail"]
        assert client.post("/jobs/nope/stream").status_code == 404


@pytest.mark.skipif(importlib.util.find_spec(STREAMING_MODULE) is None,
                    reason=f"{STREAMING_MODULE} is not written yet (the endpoint answers 503)")
def test_stream_to_the_built_in_simulator(service_client, finished_job):
    data_dir, job_id = finished_job
    with service_client(data_dir) as client:
        assert client.get("/health").json()["streaming"] == "available"
        answer = client.post(f"/jobs/{job_id}/stream", json={"target": "simulator"})
        assert answer.status_code == 202, answer.text
        view = _wait_stream(client, job_id, answer.json()["id"])
        assert view["state"] == "done", view["error"]
        result = view["result"]
        assert result["ok"] and result["exactly_once"] and not result["alarm"]
        assert result["blocks_done"] > 100 and result["journal"] == f"/jobs/{job_id}/journal"
        last = json.loads(client.get(result["journal"]).text.splitlines()[-1])
        assert (last["e"], last["outcome"]) == ("end", "done")
