"""Refused requests: 4xx naming the problem, nothing stored; failing jobs keep their error."""

from __future__ import annotations

import json

import pytest
from _service_support import COARSE, blade_csv, blade_sections, upload, wait_for_job

import streamline_cam.service.runner as runner


def _loc(answer) -> list:
    return answer.json()["detail"][0]["loc"]


def _msg(answer) -> str:
    return answer.json()["detail"][0]["msg"]


def test_csv_missing_column_names_the_column_file_and_line(service_client):
    bad = blade_csv().replace(b"section,x,y,z", b"sec,x,y,z")
    with service_client(start_workers=False) as client:
        answer = upload(client, bad, filename="hub.csv")
        assert answer.status_code == 422
        assert _loc(answer) == ["body", "file"]
        assert _msg(answer).startswith("hub.csv:1: ")
        assert "lacks column(s) section" in _msg(answer)
        bad_number = blade_csv().replace(b"\n0,", b"\n0,x", 1)
        answer = upload(client, bad_number, filename="hub.csv")
        assert answer.status_code == 422 and _msg(answer).startswith("hub.csv:2: ")
        assert "is not a number" in _msg(answer)
        three = b"\n".join(line for line in blade_csv().splitlines() if line[:1] not in b"34")
        answer = upload(client, three, filename="hub.csv")
        assert answer.status_code == 422 and "at least 4 sections" in _msg(answer)
        assert client.get("/jobs").json()["counts"] == {
            "queued": 0, "running": 0, "done": 0, "failed": 0, "cancelled": 0}


def test_too_large_bodies_get_413_before_they_are_read(service_client, tmp_path):
    csv = blade_csv()
    with service_client(start_workers=False, max_upload_bytes=4096) as client:
        answer = upload(client, csv)  # with Content-Length
        assert answer.status_code == 413
        assert "limit of 4096 bytes" in answer.json()["detail"]

        def chunks():  # no Content-Length: counted as it arrives
            for i in range(0, len(csv), 1000):
                yield csv[i:i + 1000]

        answer = client.post("/jobs", content=chunks(),
                             headers={"content-type": "application/json"})
        assert answer.status_code == 413
        assert upload(client, csv[:3000]).status_code == 422  # small enough, but 3 sections
    assert not any((tmp_path / "data" / "jobs").iterdir())


@pytest.mark.parametrize(("fields", "loc", "words"), [
    ({"scallop_mm": -1}, ["body", "scallop_mm"], "scallop_mm must be a finite length > 0"),
    ({"scallop_mm": "abc"}, ["body", "scallop_mm"], "valid number"),
    ({"scallop_mm": 4}, ["body", "scallop_mm"], "not smaller than the cutter radius"),
    ({"cutter": "ball"}, ["body", "cutter"], "cutter spec 'ball'"),
    ({"machine": "mill-9"}, ["body", "machine"], "unknown machine 'mill-9'"),
    ({"machine": "/etc/machine.toml"}, ["body", "machine"], "unknown machine"),
    ({"dialect": "heidenhain"}, ["body", "dialect"], "heidenhain"),
    ({"spindle_rpm": -100}, ["body", "spindle_rpm"], "spindle_rpm must be finite and >= 0"),
    ({"method": "nurbs"}, ["body", "method"], "'streamline' or 'bspline'"),
    ({"lead_deg": 10, "axis_mode": "3", "planning_options": '{"on_gouge": "retilt"}'},
     ["body", "planning_options", "on_gouge"], "needs axis_mode='lead-tilt'"),
    ({"planning_options": '{"feed": 3}'}, ["body", "planning_options"], "unknown option(s)"),
    ({"planning_options": '{"feed_mm_per_min": -5}'},
     ["body", "planning_options", "feed_mm_per_min"], "feed_mm_per_min"),
    ({"planning_options": '{"progress": 1}'}, ["body", "planning_options"], "set by the service"),
    ({"planning_options": "{not json"}, ["body", "planning_options"], "JSON"),
    ({"scalop_mm": 0.01}, ["body", "scalop_mm"], "Extra inputs are not permitted"),
])
def test_bad_parameters_get_422_naming_the_field(service_client, fields, loc, words):
    with service_client(start_workers=False) as client:
        answer = upload(client, blade_csv(), **fields)
        assert answer.status_code == 422, answer.text
        assert _loc(answer) == loc
        assert words in _msg(answer)


def test_bad_json_sections_name_the_section(service_client):
    sections = blade_sections()
    # sections of different counts are matched (issue 23); one running backwards is refused
    reversed_2 = [*sections[:2], sections[2][::-1], *sections[3:]]
    with service_client(start_workers=False) as client:
        answer = client.post("/jobs", json={"sections": reversed_2, **COARSE})
        assert answer.status_code == 422 and _loc(answer) == ["body", "sections"]
        assert "section 2 runs the other way round" in _msg(answer)
        flat = [[p[:2] for p in s] for s in sections]
        answer = client.post("/jobs", json={"sections": flat, **COARSE})
        assert answer.status_code == 422
        assert _loc(answer)[:3] == ["body", "sections", 0]
        sections[1][3][0] = float("nan")
        text = json.dumps({"sections": sections, **COARSE})  # NaN: Python's JSON extension
        answer = client.post("/jobs", content=text, headers={"content-type": "application/json"})
        assert answer.status_code == 422
        assert _loc(answer) == ["body", "sections", 1, 3, 0]
        assert client.post("/jobs", content=b"{", headers={
            "content-type": "application/json"}).status_code == 422


def test_unknown_job_404_and_unfinished_job_409(service_client):
    with service_client(start_workers=False) as client:
        assert client.get("/jobs/nope").status_code == 404
        assert "no job 'nope'" in client.get("/jobs/nope/gcode").json()["detail"]
        job = upload(client, blade_csv()).json()
        assert job["state"] == "queued"
        answer = client.get(f"/jobs/{job['id']}/report")
        assert answer.status_code == 409 and "is queued" in answer.json()["detail"]
        assert client.get(f"/jobs/{job['id']}/plots/surface").status_code == 409


def test_queue_limit_gives_503(service_client):
    with service_client(start_workers=False, max_queued=1) as client:
        assert upload(client, blade_csv()).status_code == 202
        answer = upload(client, blade_csv())
        assert answer.status_code == 503 and answer.headers["retry-after"] == "60"
        assert "1 jobs are waiting" in answer.json()["detail"]


def test_failing_job_records_the_librarys_message(service_client):
    far = blade_csv(blade_sections(shift_mm=3000.0))  # off the 800 mm table
    with service_client() as client:
        job = upload(client, far, placement="none").json()
        status = wait_for_job(client, job["id"])
        assert status["state"] == "failed"
        assert status["error_type"] == "PlanTravelLimitError"
        assert "axis 'X'" in status["error"] and "above its maximum" in status["error"]
        assert status["progress"]["fit"] == 1.0 and status["progress"]["post"] == 0.0
        answer = client.get(f"/jobs/{job['id']}/gcode")
        assert answer.status_code == 409 and "axis 'X'" in answer.json()["detail"]


def test_a_bug_in_a_job_is_recorded_without_a_traceback(service_client, monkeypatch, tmp_path):
    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(runner, "run_job", broken)
    with service_client() as client:
        job = upload(client, blade_csv()).json()
        status = wait_for_job(client, job["id"])
    assert status["state"] == "failed" and status["error_type"] == "InternalError"
    assert "RuntimeError: boom" in status["error"] and "Traceback" not in status["error"]
    trace = (tmp_path / "data" / "jobs" / job["id"] / "traceback.txt").read_text()
    assert "RuntimeError: boom" in trace
