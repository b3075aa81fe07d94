"""Dask tasks for the batch tests: the real task, counted, and one that kills its worker.

Module-level (so workers import them by name); each appends a line per event to a log file
the test reads back: ``start NAME``, ``done NAME``.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

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
