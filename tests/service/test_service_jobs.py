"""Submit -> poll -> fetch every result, by CSV upload and by JSON, against the pipeline."""

from __future__ import annotations

import io
import json

import numpy as np
from _service_support import COARSE

from streamline_cam.pipeline import JobRequest, run_job
from toolpath import Toolpath, surface_from_dict


def test_upload_poll_and_fetch_every_result(service_client, finished_job, tmp_path):
    data_dir, job_id = finished_job
    with service_client(data_dir) as client:  # a new service on the finished job's data
        status = client.get(f"/jobs/{job_id}").json()
        assert status["state"] == "done"
        assert status["name"] == "small_blade"
        assert status["progress"] == {"fit": 1.0, "plan": 1.0, "post": 1.0, "check": 1.0,
                                  "verify": 1.0}
        assert status["parameters"]["scallop_mm"] == COARSE["scallop_mm"]
        assert {"report", "gcode", "toolpath", "surface", "plot:surface", "stream"} <= set(
            status["links"])

        report = client.get(f"/jobs/{job_id}/report").json()
        assert report["check"]["errors"] == 0
        assert report["plan"]["n_passes"] > 0
        assert report["fit"]["max_error_mm"] < 0.01

        gcode = client.get(status["links"]["gcode"])
        assert gcode.headers["content-type"].startswith("text/plain")
        assert 'filename="small_blade.nc"' in gcode.headers["content-disposition"]
        assert gcode.content == (data_dir / "jobs" / job_id / "part.nc").read_bytes()
        assert len(gcode.text.splitlines()) == report["program"]["lines"]

        npz = client.get(status["links"]["toolpath"])
        assert 'filename="small_blade.npz"' in npz.headers["content-disposition"]
        (tmp_path / "got.npz").write_bytes(npz.content)
        path = Toolpath.load(tmp_path / "got.npz")
        assert path.positions_mm.shape[1] == 3 and len(path.positions_mm) > 10
        with np.load(io.BytesIO(npz.content)) as arrays:
            assert np.array_equal(arrays["positions_mm"], path.positions_mm)

        surface = surface_from_dict(client.get(status["links"]["surface"]).json())
        assert np.isfinite(surface(np.array([0.5]), np.array([0.5]))).all()

        png = client.get(status["links"]["plot:surface"])
        assert png.status_code == 200
        assert png.headers["content-type"] == "image/png"
        assert png.content.startswith(b"\x89PNG\r\n\x1a\n")
        again = client.get(f"/jobs/{job_id}/plots/surface.png")  # drawn once, then served
        assert again.content == png.content

        if "plot:toolpath" in status["links"]:  # toolpath.plotting_paths is installed
            png = client.get(status["links"]["plot:toolpath"])
            assert png.status_code == 200 and png.content.startswith(b"\x89PNG")
        assert client.get(f"/jobs/{job_id}/plots/nope").status_code == 404
        listed = client.get("/jobs").json()
        assert [j["id"] for j in listed["jobs"]] == [job_id]
        assert listed["counts"]["done"] == 1


def test_the_served_program_is_the_pipelines_own(finished_job, tmp_path):
    """The service adds nothing and loses nothing: the same files as ``run_job`` directly."""
    data_dir, job_id = finished_job
    job_dir = data_dir / "jobs" / job_id
    (tmp_path / "small_blade.csv").write_bytes((job_dir / "small_blade.csv").read_bytes())
    direct = run_job(JobRequest(sections_path=tmp_path / "small_blade.csv", **COARSE), tmp_path)
    assert (job_dir / "part.nc").read_bytes() == direct.files["gcode"].read_bytes()
    served = json.loads((job_dir / "report.json").read_text())
    for part in ("fit", "plan", "program", "check"):  # all but the timings
        served_part = {k: v for k, v in served[part].items() if k != "seconds"}
        assert served_part == {k: v for k, v in direct.report[part].items() if k != "seconds"}


def test_openapi_schema_and_docs(service_client):
    with service_client(start_workers=False) as client:
        schema = client.get("/openapi.json").json()
        assert {"/jobs", "/jobs/upload", "/jobs/{job_id}", "/jobs/{job_id}/report",
                "/jobs/{job_id}/gcode", "/jobs/{job_id}/toolpath",
                "/jobs/{job_id}/plots/{name}", "/jobs/{job_id}/stream"} <= set(schema["paths"])
        assert "scallop_mm" in json.dumps(schema["components"]["schemas"]["JobSubmission"])
        upload = schema["paths"]["/jobs/upload"]["post"]["requestBody"]["content"]
        assert list(upload) == ["multipart/form-data"]  # a file picker in /docs
        docs = client.get("/docs")
        assert docs.status_code == 200 and "swagger" in docs.text.lower()
        health = client.get("/health").json()
        assert health["status"] == "ok" and health["stream_targets"] == ["simulator"]
        assert "grbl-router" in client.get("/machines").json()["machines"]
