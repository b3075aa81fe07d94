"""The verifier's verdict on a job's program, through the HTTP API (issue 24).

``toolpath run --verify`` exits 1 when the verified gouge or scallop exceeds the request;
the service runs the same verification and gives the same verdict: the report's
``verify.verdict`` and the job's ``verdict`` and ``summary``.
"""

from __future__ import annotations

from _service_support import blade_csv, upload, wait_for_job

import streamline_cam.pipeline as pipeline
from streamline_cam.verdict import verify_excess


def test_a_job_within_the_request_passes(service_client):
    with service_client() as client:
        status = wait_for_job(client, upload(client, blade_csv()).json()["id"])
        report = client.get(f"/jobs/{status['id']}/report").json()
    assert status["state"] == "done", status
    verdict = report["verify"]["verdict"]
    assert verdict["ok"] and not verdict["exceeds"]
    assert verdict["gouge_mm"] == report["verify"]["max_gouge_mm"]
    assert verdict["chord_tol_mm"] == report["plan"]["chord_tol_mm"]
    assert status["verdict"] == "pass"
    assert status["summary"].startswith("verified: deepest gouge")
    assert verify_excess(report) is None


def test_a_program_beyond_the_request_is_reported_as_exceeding(service_client, monkeypatch):
    # a crafted verification: the verifier's report with a gouge deeper than asked
    measured = pipeline._verify

    def deeper(*args, **kwargs):
        out = measured(*args, **kwargs)
        out["max_gouge_mm"] = 0.25
        out["max_gouge"] = dict(out.get("max_gouge") or {}, line=1234)
        return out

    monkeypatch.setattr(pipeline, "_verify", deeper)
    with service_client() as client:
        status = wait_for_job(client, upload(client, blade_csv(), chord_tol_mm=0.05)
                              .json()["id"])
        report = client.get(f"/jobs/{status['id']}/report").json()
        listed = client.get(f"/jobs/{status['id']}").json()
    assert status["state"] == "done"  # the files are there, for inspection
    assert status["verdict"] == listed["verdict"] == "exceeds"
    assert report["verify"]["verdict"]["ok"] is False
    # the same words as the command line's, flags named as the job's fields
    assert verify_excess(report) == ("deepest gouge 0.2500 mm exceeds the chord tolerance "
                                     "0.05 mm (--chord-tol) at line 1234")
    assert status["summary"] == ("the program exceeds the request: deepest gouge 0.2500 mm "
                                 "exceeds the chord tolerance 0.05 mm (chord_tol_mm) at "
                                 "line 1234")
