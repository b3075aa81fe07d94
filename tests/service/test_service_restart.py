"""A restart loses nothing: finished jobs stay, interrupted ones run again, streams do not."""

from __future__ import annotations

import shutil

import pytest
from _service_support import COARSE, blade_csv, blade_sections, upload, wait_for_job

from streamline_cam.service import JobState, JobStore
from streamline_cam.service.store import StreamState


def test_new_service_keeps_finished_jobs_and_requeues_unfinished(
        service_client, finished_job, tmp_path):
    data = tmp_path / "data"
    shutil.copytree(finished_job[0], data)  # a service stopped after one finished job
    done = finished_job[1]
    program = (data / "jobs" / done / "part.nc").read_bytes()
    with service_client(data, start_workers=False) as client:  # takes jobs, runs none
        assert client.get(f"/jobs/{done}").json()["state"] == "done"
        interrupted = client.post("/jobs", json={"name": "second", "sections": blade_sections(),
                                                 **COARSE}).json()
        queued = upload(client, blade_csv(), filename="third.csv").json()
    # the service stopped while running the second job, half-way through planning
    store = JobStore(data / "jobs.sqlite3")
    claimed = store.claim_next()
    assert claimed is not None and claimed.id == interrupted["id"]
    store.set_progress(claimed.id, claimed.attempts, "plan", 0.5)
    stream = store.add_stream(done, "simulator")  # and had a stream waiting

    with service_client(data) as client:
        first = client.get(f"/jobs/{done}").json()
        assert first["state"] == "done" and first["attempts"] == 1
        assert client.get(f"/jobs/{done}/gcode").content == program
        second = wait_for_job(client, interrupted["id"])
        third = wait_for_job(client, queued["id"])
        assert (second["state"], second["attempts"]) == ("done", 2)
        assert (third["state"], third["attempts"]) == ("done", 1)
        # JSON and CSV submissions of one blade make one program (but for its name)
        assert client.get(f"/jobs/{interrupted['id']}/gcode").content == program.replace(
            b"(small_blade)", b"(second)")
        streamed = client.get(f"/jobs/{done}/streams/{stream.id}").json()
        assert streamed["state"] == "failed" and "not re-sent" in streamed["error"]
        assert client.get("/jobs").json()["counts"]["done"] == 3


def test_a_job_interrupted_too_often_is_failed_not_retried(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.add({}, input_name="blade.csv")
    for attempt in (1, 2, 3):
        assert store.claim_next().attempts == attempt
        requeued, failed = store.recover(max_attempts=3)
    assert (requeued, failed) == ([], [job.id])
    record = store.get(job.id)
    assert record.state is JobState.FAILED and record.error_type == "Interrupted"
    assert "stopped during this job (3 times" in record.error


def test_a_superseded_run_cannot_overwrite_the_new_one(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.add({}, input_name="blade.csv")
    old = store.claim_next()
    store.recover(max_attempts=3)  # restart: the old worker may still be finishing
    new = store.claim_next()
    assert (old.attempts, new.attempts) == (1, 2)
    store.set_progress(job.id, old.attempts, "plan", 0.9)
    assert store.get(job.id).progress == {}
    assert not store.finish(job.id, old.attempts, {"old": True})
    assert not store.fail(job.id, old.attempts, "late", "X")
    assert store.finish(job.id, new.attempts, {"new": True})
    assert store.get(job.id).report == {"new": True}


def test_jobs_are_claimed_oldest_first_and_once(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    ids = [store.add({"k": i}, input_name="b.csv").id for i in range(3)]
    assert [store.claim_next().id for _ in range(3)] == ids
    assert store.claim_next() is None
    assert store.counts() == {"queued": 0, "running": 3, "done": 0, "failed": 0,
                              "cancelled": 0}
    assert JobStore(tmp_path / "jobs.sqlite3").counts()["running"] == 3  # on disk


@pytest.mark.parametrize("state", [StreamState.QUEUED, StreamState.RUNNING])
def test_streams_cut_short_are_failed_on_restart(tmp_path, state):
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.add({}, input_name="b.csv")
    stream = store.add_stream(job.id, "mill")
    if state is StreamState.RUNNING:
        assert store.start_stream(stream.id)
    store.recover(max_attempts=3)
    record = store.get_stream(stream.id)
    assert record.state is StreamState.FAILED and "check it, then ask again" in record.error
