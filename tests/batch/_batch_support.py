"""Dask tasks for the batch tests: the real task, counted, and one that kills its worker.

Module-level (so workers import them by name); each appends a line per event to a log file
the test reads back: ``start NAME``, ``done NAME``.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np

from streamline_cam.dask_engine import run_packed_task
from streamline_cam.job_task import JobOutcome, PackedJob, run_packed_job

LOG_ENV = "TOOLPATH_BATCH_TEST_LOG"


def _log(log: Path, line: str) -> None:
    with log.open("a", encoding="utf-8") as stream:
        stream.write(line + "\n")


def counted_task(log: str):
    """The real task, each start and finish logged."""

    def task(job: PackedJob, topic: str | None = None) -> JobOutcome:
        _log(Path(log), f"start {job.input_name}")
        outcome = run_packed_task(job, topic)
        _log(Path(log), f"done {job.input_name}")
        return outcome

    return task


def killing_task(log: str, victim: str, marker: str):
    """The real task, but the first run of ``victim`` kills its own worker during planning.

    The kill comes from the job's progress callback when planning starts (after the fit
    has written ``surface.json``), so the job dies with partial output on the worker.
    """

    def task(job: PackedJob, topic: str | None = None) -> JobOutcome:
        _log(Path(log), f"start {job.input_name}")

        def progress(stage: str, fraction: float) -> None:
            if job.input_name == victim and stage == "plan" and not Path(marker).exists():
                Path(marker).write_text(str(os.getpid()), encoding="utf-8")
                os.kill(os.getpid(), signal.SIGKILL)

        import distributed

        worker = distributed.get_worker()
        outcome = run_packed_job(job, scratch_dir=worker.local_directory, progress=progress)
        _log(Path(log), f"done {job.input_name}")
        return outcome

    return task


def numba_threads() -> int:
    """The compiled kernels' thread pool size in this process."""
    import numba

    return numba.config.NUMBA_NUM_THREADS


def strip_csv(m: int = 5, n: int = 40, *, twist_deg: float = 4.0) -> bytes:
    """``m`` sections of ``n`` points of a twisted, cambered strip: a job of a second or two."""
    u = np.linspace(0.0, 1.0, n)
    lines = ["section,x,y,z"]
    for j in range(m):
        twist = np.radians(twist_deg * j)
        x, y = 40.0 * u - 20.0, 3.0 * np.sin(np.pi * u) * (1.0 - 0.05 * j) + 0.5 * j
        xr, yr = np.cos(twist) * x - np.sin(twist) * y, np.sin(twist) * x + np.cos(twist) * y
        lines += [f"{j},{a:.6f},{b:.6f},{10.0 * j:.6f}" for a, b in zip(xr, yr, strict=True)]
    return ("\n".join(lines) + "\n").encode()
