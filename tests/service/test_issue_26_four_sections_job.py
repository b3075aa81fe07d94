"""Issue 26: a service job of four sections runs; fewer are refused at submission (422)."""

from __future__ import annotations

from _service_support import COARSE, blade_sections, wait_for_job


def test_a_four_section_job_is_done_and_fewer_are_refused_at_once(service_client):
    with service_client() as client:
        answer = client.post("/jobs", json={"sections": blade_sections(m=4), **COARSE})
        assert answer.status_code == 202, answer.text
        status = wait_for_job(client, answer.json()["id"])
        assert status["state"] == "done", status["error"]
        for m in (3, 2):
            answer = client.post("/jobs", json={"sections": blade_sections(m=m), **COARSE})
            assert answer.status_code == 422
            assert f"at least 4 sections, got {m}" in answer.json()["detail"][0]["msg"]
        assert client.get("/jobs").json()["counts"]["failed"] == 0
