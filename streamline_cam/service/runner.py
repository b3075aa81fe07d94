"""What a worker does with one job: run the pipeline and record the outcome in the store.

:func:`run_stored_job` is a plain module-level function of picklable arguments, so the same
code runs in a worker process or a thread. Progress goes straight to the store (throttled),
so the HTTP side reads it from SQLite whatever the executor.
"""

from __future__ import annotations

import re
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Final, Protocol

from ..job_task import USER_ERRORS, JobInterrupted, JobOutcome, ThrottledProgress
from ..pipeline import JobRequest, run_job
from .store import JobStore

__all__ = [
    "PROGRESS_INTERVAL_S",
    "USER_ERRORS",
    "JobCancelled",
    "JobEngine",
    "as_job_fields",
    "run_stored_job",
]

PROGRESS_INTERVAL_S: Final[float] = 0.25
"""Least time between two progress writes of one stage (s): a poll every second or so
sees movement, and the planner's fine-grained callbacks cost no disk traffic."""


class JobEngine(Protocol):
    """Runs a job elsewhere: :class:`~streamline_cam.dask_engine.DaskJobs`."""

    def run(self, request: JobRequest, job_dir: Path, *,
            progress: Callable[[str, float], None] | None = None,
            verify: bool = False) -> JobOutcome:
        """Run ``request``, its files written into ``job_dir``."""
        ...


#: Command-line flags that library messages name as remedies, and the job's JSON field
#: each sets (``planning_options`` holds the planner's own options).
FLAG_FIELDS: Final[dict[str, str]] = {
    "--on-gouge": "planning_options.on_gouge", "--gouge-tol": "planning_options.gouge_tol_mm",
    "--on-limit": "planning_options.on_limit", "--clearance": "planning_options.clearance_mm",
    "--approach": "planning_options.approach_mm",
    "--lead-radius": "planning_options.lead_radius_mm", "--lead": "lead_deg",
    "--tilt": "tilt_deg", "--fit-tol": "fit_tol_mm", "--cutter": "cutter",
    "--scallop": "scallop_mm", "--chord-tol": "chord_tol_mm", "--machine": "machine",
}
_FLAG = re.compile(r"(--[a-z][a-z-]*)(?: (raise|lift|retilt|report)\b)?")


def as_job_fields(message: str) -> str:
    """A library message for a job's client: command-line flags named as JSON fields.

    ``use --on-gouge lift`` reads ``use planning_options.on_gouge="lift"``; flags with no
    field stay as they are.
    """
    def field(match: re.Match[str]) -> str:
        flag, choice = match.group(1), match.group(2)
        if flag not in FLAG_FIELDS:
            return match.group(0)
        return FLAG_FIELDS[flag] + (f'="{choice}"' if choice else "")

    return _FLAG.sub(field, message)


class JobCancelled(Exception):
    """The run no longer owns its job (cancelled on request, or superseded): stop it."""


class _Progress(ThrottledProgress):
    """``progress(stage, fraction)`` writing to the store at most every interval.

    A write the store refuses means the job was cancelled (or a newer run owns it): with
    ``stop_when_cancelled`` the call raises :class:`JobCancelled`, so the pipeline stops at
    its next progress report (every stage reports its start and end, the long ones more
    often than every :data:`PROGRESS_INTERVAL_S`).
    """

    def __init__(self, store: JobStore, job_id: str, attempt: int, *,
                 stop_when_cancelled: bool = True) -> None:
        super().__init__(PROGRESS_INTERVAL_S)
        self._store, self._job_id, self._attempt = store, job_id, attempt
        self._stop = stop_when_cancelled

    def emit(self, stage: str, fraction: float) -> None:
        owned = self._store.set_progress(self._job_id, self._attempt, stage,
                                         min(max(float(fraction), 0.0), 1.0))
        if not owned and self._stop:
            raise JobCancelled(self._job_id)


def run_stored_job(db_path: Path, job_dir: Path, job_id: str, attempt: int, *,
                   engine: JobEngine | None = None) -> str:
    """Run the stored job ``job_id`` (run number ``attempt``) with its files in ``job_dir``.

    Never raises for a failing job: the outcome (report, or message and error class) is
    written to the store. An unexpected exception is recorded as an internal error with its
    traceback in ``job_dir/traceback.txt`` (not in the HTTP answer). With ``engine`` (the
    service's ``--scheduler``: :class:`~streamline_cam.dask_engine.DaskJobs`), the job runs
    where the engine sends it and its files come back into ``job_dir``; without, here.

    Returns
    -------
    str
        The job's final state, ``"done"``, ``"failed"`` or ``"superseded"`` (a newer run owns
        the job: this one's outcome was dropped), ``"cancelled"`` (stopped on request: the
        job was cancelled while it ran; with ``engine`` the run ends and its outcome is
        dropped as ``"superseded"``), or ``"interrupted"`` (the engine stopped
        before the job ended: it stays running in the store, re-queued at the next start).
    """
    store = JobStore(db_path)
    record = store.get(job_id)
    if record is None:
        return "superseded"
    try:
        request = JobRequest(sections_path=job_dir / record.input_name, **record.parameters)
        # (an engine's progress comes from its own event thread: nothing to stop there)
        progress = _Progress(store, job_id, attempt, stop_when_cancelled=engine is None)
        if engine is None:
            report = run_job(request, job_dir, progress=progress, verify=True).report
        else:
            outcome = engine.run(request, job_dir, progress=progress, verify=True)
            if outcome.traceback is not None:
                (job_dir / "traceback.txt").write_text(outcome.traceback, encoding="utf-8")
                kept = store.fail(job_id, attempt, f"{outcome.error}; the traceback is in "
                                  "the job's folder", "InternalError")
                return "failed" if kept else "superseded"
            if not outcome.ok:
                kept = store.fail(job_id, attempt, as_job_fields(outcome.error or ""),
                                  outcome.error_type or "JobError")
                return "failed" if kept else "superseded"
            report = outcome.report or {}
    except JobCancelled:
        current = store.get(job_id)
        return "cancelled" if current is not None and current.state == "cancelled" else (
            "superseded")
    except JobInterrupted:  # the service stops: the job stays running, re-queued at start
        return "interrupted"
    except USER_ERRORS as exc:
        kept = store.fail(job_id, attempt, as_job_fields(str(exc)), type(exc).__name__)
    except Exception as exc:  # a bug: keep the service up, the traceback on disk
        (job_dir / "traceback.txt").write_text(traceback.format_exc(), encoding="utf-8")
        kept = store.fail(job_id, attempt, f"internal error ({type(exc).__name__}: {exc}); "
                          "the traceback is in the job's folder", "InternalError")
    else:
        return "done" if store.finish(job_id, attempt, report) else "superseded"
    return "failed" if kept else "superseded"
