"""Shared helpers of the service tests: a small synthetic blade, coarse parameters, polling."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

#: Coarse settings: the small blade's job takes about a second.
COARSE = {"scallop_mm": 0.05, "chord_tol_mm": 0.05}
#: Bounded waits (s) on this busy 2-core machine.
JOB_TIMEOUT_S = 60.0


def blade_sections(m: int = 5, n: int = 40, *, shift_mm: float = 0.0) -> list[list[list[float]]]:
    """``m`` sections of ``n`` points of a twisted, cambered airfoil-ish strip (mm)."""
    u = np.linspace(0.0, 1.0, n)
    sections = []
    for j in range(m):
        twist = np.radians(4.0 * j)
        x = 40.0 * u - 20.0
        y = 3.0 * np.sin(np.pi * u) * (1.0 - 0.05 * j) + 0.5 * j
        c, s = np.cos(twist), np.sin(twist)
        pts = np.column_stack((c * x - s * y + shift_mm, s * x + c * y, np.full(n, 10.0 * j)))
        sections.append(np.round(pts, 6).tolist())
    return sections


def blade_csv(sections: list[list[list[float]]] | None = None) -> bytes:
    """The sections as ``section,x,y,z`` CSV."""
    lines = ["section,x,y,z"]
    for j, section in enumerate(sections or blade_sections()):
        lines += [f"{j},{x!r},{y!r},{z!r}" for x, y, z in section]
    return ("\n".join(lines) + "\n").encode()


def wait_for_job(client: Any, job_id: str, *, timeout: float = JOB_TIMEOUT_S) -> dict:
    """Poll ``GET /jobs/{id}`` until done or failed; the last status."""
    deadline = time.monotonic() + timeout
    while True:
        answer = client.get(f"/jobs/{job_id}")
        assert answer.status_code == 200, answer.text
        status = answer.json()
        if status["state"] in ("done", "failed"):
            return status
        assert time.monotonic() < deadline, f"job {job_id} still {status['state']}: {status}"
        time.sleep(0.05)


def upload(client: Any, csv: bytes, *, filename: str = "blade.csv", **fields: Any) -> Any:
    """``POST /jobs/upload`` with the CSV and form fields."""
    data = {k: str(v) for k, v in ({**COARSE, **fields}).items()}
    return client.post("/jobs/upload", files={"file": (filename, csv, "text/csv")}, data=data)
