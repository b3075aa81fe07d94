"""``toolpath serve --scheduler``: the service's jobs on a Dask cluster's workers."""

from __future__ import annotations

import time
import warnings

import pytest
from _batch_support import strip_csv

with warnings.catch_warnings():  # starlette asks for httpx2; httpx is what we have
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient`")
    from fastapi.testclient import TestClient

from streamline_cam.dask_engine import DaskJobs
from streamline_cam.job_task import JobInterrupted
from streamline_cam.pipeline import JobRequest
from streamline_cam.service import ServiceConfig, create_app

TIMEOUT_S = 120.0


def _wait(http, job_id: str) -> dict:
    deadline = time.monotonic() + TIMEOUT_S
    while True:
        status = http.get(f"/jobs/{job_id}").json()
        if status["state"] in ("done", "failed"):
            return status
        assert time.monotonic() < deadline, status
        time.sleep(0.1)


def test_the_service_runs_its_jobs_on_the_scheduler(client, tmp_path):
    config = ServiceConfig(data_dir=tmp_path / "service", workers=2,
                           scheduler=client.scheduler.address)
    fields = {"scallop_mm": "0.5", "chord_tol_mm": "0.2", "fit_tol_mm": "0.05"}
    good = strip_csv()
    with TestClient(create_app(config)) as http:
        answer = http.post("/jobs/upload", files={"file": ("strip.csv", good, "text/csv")},
                           data=fields)
        assert answer.status_code == 202, answer.text
        ids = [answer.json()["id"]]
        deadline = time.monotonic() + TIMEOUT_S
        while http.get(f"/jobs/{ids[0]}").json()["state"] == "queued":
            assert time.monotonic() < deadline
            time.sleep(0.02)
    # the service stopped while its job ran on the cluster: the job is not failed, and the
    # next start runs it again
    with TestClient(create_app(config)) as http:
        done = _wait(http, ids[0])
        assert done["attempts"] == 2, done
        assert done["state"] == "done", done
        assert done["progress"]["plan"] == 1.0  # progress came back from the worker
        report = http.get(f"/jobs/{ids[0]}/report").json()
        assert report["check"]["errors"] == 0 and "verify" in report  # the service verifies
        gcode = http.get(f"/jobs/{ids[0]}/gcode").text
        assert gcode.count("\n") == report["program"]["lines"]
    # the worker's files came back into the service's job folder
    assert {"part.nc", "report.json", "surface.json", "toolpath.npz"} <= {
        p.name for p in (tmp_path / "service" / "jobs" / ids[0]).iterdir()}


class _StopsOnceConnected(DaskJobs):
    """The service stops (from another thread) right after the job took its client."""

    def _connected(self):
        connected = super()._connected()
        self.close()
        return connected


def test_a_stop_between_connecting_and_submitting_interrupts_the_job(client, tmp_path):
    sections = tmp_path / "strip.csv"
    sections.write_bytes(strip_csv())
    jobs = _StopsOnceConnected(client.scheduler.address)
    with pytest.raises(JobInterrupted):
        jobs.run(JobRequest(sections, scallop_mm=0.5), tmp_path / "job",
                 progress=lambda stage, fraction: None)
