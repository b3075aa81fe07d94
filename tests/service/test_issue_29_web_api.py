"""Issue 29: the endpoints behind the web page.

Live events (``GET /events``), cancelling jobs, holding, resuming and cancelling a stream to
the built-in simulator, the 3-D preview, and the offline ``/docs``.
"""

from __future__ import annotations

import re
import shutil
import sqlite3
import time
from contextlib import closing
from itertools import pairwise
from pathlib import Path

import httpx
import numpy as np
import pytest
from _live_server import EventReader, live_server
from _service_support import COARSE, blade_csv, blade_sections, upload

from streamline_cam.service import JobStore
from streamline_cam.service import store as store_module
from streamline_cam.service.preview import chord_deviation, decimate_polyline, toolpath_runs

#: A job that plans for many seconds (fine scallop): it is still running when cancelled.
SLOW = {"scallop_mm": 0.0015, "chord_tol_mm": 0.002}
#: The simulator at 40 times real speed: the small blade's program takes two seconds.
SIM_TARGETS = {"simulator": "simulate:x40"}
END_STATES = ("done", "failed", "cancelled")


def _wait(client, url: str, predicate, timeout: float = 60.0) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        view = client.get(url).json()
        if predicate(view):
            return view
        assert time.monotonic() < deadline, view
        time.sleep(0.05)


# live events -----------------------------------------------------------------------------


def test_events_bring_every_job_then_a_coarse_job_to_done(tmp_path, finished_job):
    data_dir, first = _own_copy(finished_job, tmp_path)
    with live_server(data_dir) as (url, app), httpx.Client(base_url=url) as client:
        reader = EventReader(url)
        try:
            _, seen = reader.wait_for(lambda t, d: t == "job", timeout=10)
            assert seen == client.get(f"/jobs/{first}").json()  # the job there was
            assert "text/event-stream" in reader.headers["content-type"]
            job = client.post("/jobs", json={"sections": blade_sections(shift_mm=1.0),
                                             **COARSE}).json()
            reader.wait_for(lambda t, d: t == "job" and d["id"] == job["id"], timeout=10)
            _, done = reader.wait_for(lambda t, d: t == "job" and d["id"] == job["id"]
                                      and d["state"] == "done")
            assert done == client.get(f"/jobs/{job['id']}").json()
            ours = [d for t, d in reader.events if t == "job" and d["id"] == job["id"]]
            states = [d["state"] for d in ours]
            assert states[-1] == "done" and "running" in states
            # pushed as they change, not polled: each event differs from the one before
            assert all(a != b for a, b in pairwise(ours))
            plan = [d["progress"]["plan"] for d in ours]
            assert plan == sorted(plan)
            later = EventReader(url)  # a new listener gets every job, newest first
            later.wait_for(lambda t, d: t == "job" and d["id"] == first, timeout=10)
            assert [d["id"] for _, d in later.events[:2]] == [job["id"], first]
            later.close()
        finally:
            reader.close()
        # the connection's end is seen by the server: no listener is left behind
        hub = app.state.service.events
        deadline = time.monotonic() + 5.0
        while hub.listeners and time.monotonic() < deadline:
            time.sleep(0.05)
        assert hub.listeners == 0


def test_an_idle_event_stream_pings_and_does_not_hold_the_server_up(tmp_path):
    started = None
    with live_server(tmp_path / "data", heartbeat_s=0.6) as (url, _app):  # (15 s default)
        reader = EventReader(url)
        deadline = time.monotonic() + 10
        while len(reader.comments) < 2 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert reader.comments[:2] == [": connected", ": ping"] and not reader.events
        started = time.monotonic()
    assert time.monotonic() - started < 3.0  # not the 5 s graceful time-out
    assert reader.ended.wait(2.0)  # the stream ended with the server
    reader.close()


# cancelling jobs -------------------------------------------------------------------------


def test_cancel_a_running_job_frees_its_worker(service_client):
    with service_client() as client:
        slow = client.post("/jobs", json={"sections": blade_sections(), **SLOW}).json()
        _wait(client, f"/jobs/{slow['id']}", lambda v: v["progress"]["plan"] > 0.0)
        answer = client.post(f"/jobs/{slow['id']}/cancel")
        assert answer.status_code == 200, answer.text
        assert answer.json()["state"] == "cancelled"
        assert "cancel" not in answer.json()["links"]
        # the worker stops at its next progress report, long before the plan would end
        _wait(client, "/health", lambda v: v["running"] == 0, timeout=10)
        view = client.get(f"/jobs/{slow['id']}").json()
        assert view["state"] == "cancelled" and view["error"] == "cancelled on request"
        again = client.post(f"/jobs/{slow['id']}/cancel")
        assert again.status_code == 409 and "is cancelled" in again.json()["detail"]
        assert client.get(f"/jobs/{slow['id']}/gcode").status_code == 409
        assert client.get("/jobs").json()["counts"]["cancelled"] == 1


def test_cancel_a_queued_job_and_refuse_finished_or_unknown_ones(service_client, finished_job):
    with service_client(start_workers=False) as client:
        job = upload(client, blade_csv()).json()
        assert job["links"]["cancel"] == f"/jobs/{job['id']}/cancel"
        answer = client.post(job["links"]["cancel"])
        assert answer.status_code == 200 and answer.json()["state"] == "cancelled"
        assert client.post("/jobs/nope/cancel").status_code == 404
    data_dir, job_id = finished_job
    with service_client(data_dir) as client:
        done = client.post(f"/jobs/{job_id}/cancel")
        assert done.status_code == 409
        assert done.json()["detail"] == (f"job {job_id} is done; only a queued or running "
                                         "job can be cancelled")


def test_a_version_2_store_takes_cancelled_jobs(tmp_path):
    path = tmp_path / "jobs.sqlite3"
    old_schema = re.sub(r"'failed',\s*'cancelled'\)", "'failed')", store_module._SCHEMA)
    assert "cancelled" not in old_schema
    with closing(sqlite3.connect(path)) as db, db:
        db.executescript(old_schema)
        db.execute("INSERT INTO jobs (id, state, parameters, input_name, created) "
                   "VALUES ('j1', 'queued', '{}', 'a.csv', 1.0)")
        db.execute("INSERT INTO streams (id, job_id, target, state, created) "
                   "VALUES ('s1', 'j1', 'simulator', 'queued', 2.0)")
        db.execute("PRAGMA user_version = 2")
        with pytest.raises(sqlite3.IntegrityError):
            db.execute("UPDATE jobs SET state = 'cancelled'")
    store = JobStore(path)  # migrates
    assert store.cancel("j1").state == "cancelled"
    assert store.cancel_queued_stream("s1")
    assert store.get_stream("s1").state == "cancelled"
    assert [j.id for j in store.jobs()] == ["j1"]
    job = store.add({}, input_name="b.csv")
    assert store.claim_next().id == job.id


# streaming: hold, resume, cancel ---------------------------------------------------------


def _last_point(program: str) -> dict[str, float]:
    """The program's last X Y Z (modal words)."""
    position: dict[str, float] = {}
    for line in program.splitlines():
        for axis, value in re.findall(r"([XYZ])(-?\d+\.?\d*)", line.split(";")[0]):
            position[axis.lower()] = float(value)
    return position


def _own_copy(finished_job, tmp_path: Path) -> tuple[Path, str]:
    """The shared finished job in a data folder of the test's own (streams change it)."""
    data_dir, job_id = finished_job
    shutil.copytree(data_dir, tmp_path / "data")
    return tmp_path / "data", job_id


def _start_stream(client, job_id: str) -> tuple[str, str]:
    answer = client.post(f"/jobs/{job_id}/stream", json={"target": "simulator"})
    assert answer.status_code == 202, answer.text
    stream_id = answer.json()["id"]
    return stream_id, f"/jobs/{job_id}/streams/{stream_id}"


def test_hold_resume_and_run_to_the_programs_last_point(service_client, finished_job,
                                                        tmp_path):
    data_dir, job_id = _own_copy(finished_job, tmp_path)
    program = (data_dir / "jobs" / job_id / "part.nc").read_text()
    with service_client(data_dir, stream_targets=SIM_TARGETS) as client:
        _, url = _start_stream(client, job_id)
        early = client.post(f"{url}/resume")
        assert early.status_code == 409 and "only a held stream" in early.json()["detail"]
        _wait(client, url, lambda v: (v["line"] or 0) >= 20)
        asked = client.post(f"{url}/hold")
        assert asked.status_code == 202
        held = _wait(client, url, lambda v: v["state"] == "held", timeout=20)
        assert held["controller_state"] == "Hold" and held["percent"] < 100
        # the answer to hold may still say running; its revision tells it is the older view
        if asked.json()["state"] == "running":
            assert asked.json()["revision"] < held["revision"]
        twice = client.post(f"{url}/hold")
        assert twice.status_code == 409 and "is held" in twice.json()["detail"]
        time.sleep(0.5)
        still = client.get(url).json()
        assert still["state"] == "held" and still["position_mm"] == held["position_mm"]
        assert still["line"] == held["line"]
        assert client.post(f"{url}/resume").status_code == 202
        moving = _wait(client, url, lambda v: v["state"] != "held")
        assert moving["state"] in ("running", "done")
        assert moving["revision"] > still["revision"] == held["revision"]
        done = _wait(client, url, lambda v: v["state"] in END_STATES)
        assert done["state"] == "done", done["error"]
        assert done["result"]["exactly_once"] and done["alarm"] is None
        assert done["line"] == done["total_lines"] and done["percent"] == 100
        assert done["position_mm"] == pytest.approx(_last_point(program), abs=1e-3)
        late = client.post(f"{url}/cancel")
        assert late.status_code == 409 and "is done" in late.json()["detail"]
        assert client.post(f"/jobs/{job_id}/streams/nope/hold").status_code == 404


def test_cancel_a_running_stream_and_see_it_in_the_events(tmp_path, finished_job):
    data_dir, job_id = _own_copy(finished_job, tmp_path)
    with live_server(data_dir, stream_targets=SIM_TARGETS) as (base, _app), \
            httpx.Client(base_url=base, timeout=30) as client:
        reader = EventReader(base)
        try:
            stream_id, url = _start_stream(client, job_id)
            _, moving = reader.wait_for(lambda t, d: t == "stream" and d["id"] == stream_id
                                        and (d["line"] or 0) >= 10)
            assert moving["job_id"] == job_id and moving["state"] == "running"
            assert set(moving["position_mm"]) == {"x", "y", "z"}
            assert moving["total_lines"] > moving["line"] and moving["eta_s"] is not None
            answer = client.post(f"{url}/cancel")
            assert answer.status_code == 202, answer.text
            _, end = reader.wait_for(lambda t, d: t == "stream" and d["id"] == stream_id
                                     and d["state"] in END_STATES, timeout=30)
            assert end["state"] == "cancelled", end
            assert "cancelled" in end["error"] and end["line"] < end["total_lines"]
            reader.wait_for(lambda t, d: t == "job" and d["id"] == job_id
                            and d["streams"] and d["streams"][-1]["state"] == "cancelled",
                            timeout=10)
            again = client.post(f"{url}/cancel")
            assert again.status_code == 409 and "is cancelled" in again.json()["detail"]
            # held, then cancelled: the sender resets the held controller
            stream_id, url = _start_stream(client, job_id)
            reader.wait_for(lambda t, d: t == "stream" and d["id"] == stream_id
                            and (d["line"] or 0) >= 10)
            assert client.post(f"{url}/hold").status_code == 202
            _, held = reader.wait_for(lambda t, d: t == "stream" and d["id"] == stream_id
                                      and d["state"] == "held", timeout=20)
            assert client.post(f"{url}/cancel").status_code == 202
            _, end = reader.wait_for(lambda t, d: t == "stream" and d["id"] == stream_id
                                     and d["state"] in END_STATES, timeout=30)
            assert end["state"] == "cancelled" and end["line"] == held["line"], end
        finally:
            reader.close()


class _Sender:
    """Records the feed holds a StreamControl asks for."""

    status = None

    def __init__(self) -> None:
        self.holds = 0

    def request_hold(self) -> None:
        self.holds += 1


def test_a_cancel_before_the_sender_starts_stops_it_at_its_first_line():
    from gcode.senders.progress import Progress
    from streamline_cam.streaming import StreamControl

    control = StreamControl()
    assert not control.hold() and not control.resume()  # queued: nothing to hold yet
    # cancelled as the runner starts it (the store says running, the control queued)
    assert control.cancel() and not control.cancel()
    control.start()
    sender = _Sender()
    control.attach(sender)
    assert sender.holds == 1  # the sender holds at once, then asks what to do
    assert control.decide(Progress(0, 10, 0.1)) == "cancel"
    control.ended()
    assert not control.hold() and not control.cancel()


def test_serve_refuses_a_simulator_target_of_unknown_speed(capsys):
    from streamline_cam.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["serve", "--target", "sim=simulate:fast"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.splitlines()[-1]
    assert err.startswith("toolpath serve: error: argument --target: 'sim=simulate:fast': "
                          "unknown speed 'fast'")


# preview ---------------------------------------------------------------------------------


def _points(segment: dict) -> np.ndarray:
    return np.asarray(segment["points"]).reshape(-1, 3)


def test_preview_shapes_and_run_ends(service_client, finished_job):
    from toolpath import Toolpath

    data_dir, job_id = finished_job
    path = Toolpath.load(data_dir / "jobs" / job_id / "toolpath.npz")
    with service_client(data_dir) as client:
        full = client.get(f"/jobs/{job_id}/preview").json()
        small = client.get(f"/jobs/{job_id}/preview", params={"max_points": 200}).json()
        bad = client.get(f"/jobs/{job_id}/preview", params={"max_points": 5})
        assert bad.status_code == 422 and bad.json()["detail"][0]["loc"] == [
            "query", "max_points"]
        assert client.get("/jobs/nope/preview").status_code == 404
    surface = full["surface"]
    assert 40 <= surface["rows"] <= 80 and 40 <= surface["cols"] <= 80
    assert len(surface["points"]) == 3 * surface["rows"] * surface["cols"]
    n = len(path.positions_mm)
    assert full["source_points"] == n and full["max_deviation_mm"] == 0.0
    assert full["points"] == sum(len(s["points"]) // 3 for s in full["segments"])
    assert not full["five_axis"] and all("tool_axis" not in s for s in full["segments"])
    # the full path, run by run: consecutive runs share their end point
    joined = np.concatenate([_points(s)[1 if i else 0:] for i, s in enumerate(full["segments"])])
    np.testing.assert_allclose(joined, path.positions_mm, atol=1e-4)
    kinds = {s["kind"] for s in full["segments"]}
    assert kinds == {"cut", "link", "rapid"}
    cuts = [s for s in full["segments"] if s["kind"] == "cut"]
    assert sorted({s["pass"] for s in cuts}) == sorted(set(path.pass_index[path.pass_index >= 0]))
    assert all(s["pass"] is None for s in full["segments"] if s["kind"] != "cut")
    lo, hi = np.asarray(full["bounds_mm"]["min"]), np.asarray(full["bounds_mm"]["max"])
    assert (path.positions_mm >= lo - 1e-3).all() and (path.positions_mm <= hi + 1e-3).all()
    # decimated: within the budget, the same runs with the same ends
    assert small["points"] <= 200 < n
    assert [(s["kind"], s["pass"]) for s in small["segments"]] == [
        (s["kind"], s["pass"]) for s in full["segments"]]
    for a, b in zip(small["segments"], full["segments"], strict=True):
        np.testing.assert_array_equal(_points(a)[[0, -1]], _points(b)[[0, -1]])
    diagonal = float(np.linalg.norm(hi - lo))
    assert 0.0 < small["max_deviation_mm"] < 0.05 * diagonal


def _synthetic_toolpath(n_passes: int, per_pass: int):
    """Zig-zag passes over a wavy sheet, a link move between passes: (points, kinds, pass)."""
    u = np.linspace(0.0, 1.0, per_pass)
    points, kinds, passes = [], [], []
    for j in range(n_passes):
        x = 100.0 * (u if j % 2 == 0 else 1.0 - u)
        y = np.full(per_pass, 0.2 * j)
        points.append(np.column_stack((x, y, 5.0 * np.sin(x / 10.0) + np.cos(y / 7.0))))
        kinds += [5] + [3] * (per_pass - 1)
        passes += [-1] + [j] * (per_pass - 1)
    return np.concatenate(points), np.asarray(kinds, dtype=np.uint8), np.asarray(passes)


def _brute_deviation(points: np.ndarray, keep: np.ndarray) -> float:
    """Largest distance of a dropped point from its kept chord, one point at a time."""
    kept = np.flatnonzero(keep)
    worst = 0.0
    for a, b in pairwise(kept):
        pa, pb = points[a], points[b]
        for p in points[a + 1:b]:
            t = np.clip(np.dot(p - pa, pb - pa) / np.dot(pb - pa, pb - pa), 0.0, 1.0)
            worst = max(worst, float(np.linalg.norm(p - (pa + t * (pb - pa)))))
    return worst


def test_decimation_keeps_run_ends_and_stays_close():
    points, kinds, passes = _synthetic_toolpath(40, 300)
    runs = toolpath_runs(kinds, passes)
    assert len(runs) == 79 and runs[0] == ("cut", 0, 1, 299)
    fixed = np.zeros(len(points), dtype=bool)
    for _, _, first, last in runs:
        fixed[first - 1] = fixed[last] = True
    kept = decimate_polyline(points, 2000, fixed)
    assert kept.keep.sum() == 2000 and kept.keep[fixed].all()
    assert kept.max_deviation_mm == pytest.approx(_brute_deviation(points, kept.keep))
    # 50 points per 100 mm pass: 2 mm chords on radii down to 20 mm (5 sin(x / 10)) sag
    # 2^2 / (8 * 20) = 0.025 mm; RDP puts its points where the curve bends, so no worse
    assert kept.max_deviation_mm < 0.026
    coarser = decimate_polyline(points, 500, fixed)
    assert coarser.max_deviation_mm > kept.max_deviation_mm
    assert chord_deviation(points, np.ones(len(points), dtype=bool)) == 0.0


def test_a_250k_point_toolpath_previews_within_its_budget():
    from streamline_cam.service.preview import preview
    from toolpath.path import Toolpath

    points, kinds, passes = _synthetic_toolpath(500, 500)
    assert len(points) == 250_000
    path = Toolpath(points, np.array([0.0, 0.0, 1.0]), kinds, np.full(len(points), 1000.0),
                    passes)

    class Sheet:
        closed_t = False

        def __call__(self, t, s, *, grid=False):
            t, s = np.meshgrid(t, s, indexing="ij")
            return np.stack((100.0 * t, 100.0 * s, np.zeros_like(t)), axis=-1)

    answer = preview(Sheet(), path, max_points=50_000)
    assert answer["source_points"] == 250_000 and answer["points"] <= 50_000
    assert len(answer["segments"]) == 999
    assert answer["max_deviation_mm"] < 0.05


# offline docs ----------------------------------------------------------------------------


def test_docs_load_only_files_of_the_service(service_client):
    with service_client(start_workers=False) as client:
        page = client.get("/docs")
        assert page.status_code == 200
        urls = re.findall(r"""(?:src|href)=["']([^"']+)""", page.text)
        urls += re.findall(r"""url:\s*['"]([^'"]+)""", page.text)
        assert len(urls) >= 4
        for url in urls:
            assert url.startswith("/") and not url.startswith("//"), url
            assert client.get(url).status_code == 200, url
        assert "http://" not in page.text and "https://" not in page.text
        assert client.get("/redoc").status_code == 404
        bundle = client.get("/static/swagger/swagger-ui-bundle.js")
        assert "javascript" in bundle.headers["content-type"] and len(bundle.content) > 500_000
    shipped = Path(__file__).parents[2] / "streamline_cam" / "service" / "static" / "swagger"
    assert {"LICENSE", "swagger-ui-bundle.js", "swagger-ui.css"} <= {
        p.name for p in shipped.iterdir()}
