"""The job store: jobs and stream requests in SQLite (stdlib :mod:`sqlite3`).

One file, ``jobs.sqlite3`` in the data folder, is the queue and the record: a job is
``queued`` -> ``running`` -> ``done`` | ``failed``, or ``cancelled`` on request from either of
the first two (:meth:`JobStore.cancel`; a running job's worker sees it at its next progress
write). The worker pool claims the oldest queued
job in one ``UPDATE ... RETURNING`` statement, and every later write of that run names the
attempt it belongs to, so a worker left over from a stopped service (or a thread still
finishing) cannot overwrite a newer run. The database is opened per call in WAL mode with a
busy time-out, so the HTTP threads and worker processes share it safely.

A graceful stop (:meth:`JobStore.requeue_stopped`, by the worker pool as the service
stops) puts its running jobs back in the queue at once and counts the run in ``stops``, not
as a failed attempt. Restart (:meth:`JobStore.recover`): jobs still ``running`` were cut
short by a crash or a ``kill -9``; they go back to ``queued`` (their files are rewritten by
the next run), unless such crashes ended :data:`~.config.MAX_ATTEMPTS` of their runs
(``attempts - stops``). Streams that were queued or running are failed, never re-sent: a
controller may hold part of the program, and a machine must not start by itself when a
service comes back.
"""

from __future__ import annotations

import json
import sqlite3
import time
import uuid
from collections.abc import Iterator
from contextlib import closing, contextmanager
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any, Final

__all__ = ["FINAL_STATES", "JobRecord", "JobState", "JobStore", "StreamRecord", "StreamState"]

SCHEMA_VERSION: Final[int] = 3
BUSY_TIMEOUT_S: Final[float] = 10.0
"""Wait for a lock this long (s): writes are single-row and take microseconds, so only a
stalled disk comes near it."""

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    state TEXT NOT NULL CHECK (state IN ('queued', 'running', 'done', 'failed',
                                         'cancelled')),
    parameters TEXT NOT NULL,
    input_name TEXT NOT NULL,
    created REAL NOT NULL,
    started REAL,
    finished REAL,
    attempts INTEGER NOT NULL DEFAULT 0,
    stops INTEGER NOT NULL DEFAULT 0,
    stage TEXT,
    progress TEXT NOT NULL DEFAULT '{}',
    error TEXT,
    error_type TEXT,
    report TEXT
);
CREATE INDEX IF NOT EXISTS jobs_state ON jobs (state, seq);
CREATE TABLE IF NOT EXISTS streams (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    job_id TEXT NOT NULL REFERENCES jobs (id),
    target TEXT NOT NULL,
    state TEXT NOT NULL CHECK (state IN ('queued', 'running', 'done', 'failed',
                                         'cancelled')),
    created REAL NOT NULL,
    started REAL,
    finished REAL,
    result TEXT,
    error TEXT
);
CREATE INDEX IF NOT EXISTS streams_job ON streams (job_id, seq);
"""


class JobState(StrEnum):
    """Where a job is."""

    QUEUED = "queued"  #: waiting for a worker
    RUNNING = "running"  #: in a worker
    DONE = "done"  #: files and report written
    FAILED = "failed"  #: ``error`` says why
    CANCELLED = "cancelled"  #: stopped on request (``POST /jobs/{id}/cancel``)


class StreamState(StrEnum):
    """Where a stream request is (same words as :class:`JobState`)."""

    QUEUED = "queued"
    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"
    CANCELLED = "cancelled"


#: Finished states: nothing changes a job or stream in one of these any more.
FINAL_STATES: Final[frozenset[str]] = frozenset({"done", "failed", "cancelled"})


@dataclass(frozen=True)
class JobRecord:
    """One job as stored.

    Attributes
    ----------
    id : str
        32 hex digits (random: not guessable from other jobs' ids).
    state : JobState
    parameters : dict
        The :class:`~streamline_cam.pipeline.JobRequest` fields but ``sections_path``.
    input_name : str
        File name of the sections inside the job's folder.
    created, started, finished : float or None
        Unix times, s.
    attempts : int
        Runs started (more than one after a service restart).
    stage : str or None
        Stage of the last progress report.
    progress : dict of str to float
        Fraction done (0 to 1) by stage.
    error, error_type : str or None
        Message and exception class of a failed job.
    report : dict or None
        The pipeline's report of a finished job.
    stops : int
        Runs ended by a graceful stop of the service (re-queued; not failed attempts).
    """

    id: str
    state: JobState
    parameters: dict[str, Any]
    input_name: str
    created: float
    started: float | None
    finished: float | None
    attempts: int
    stage: str | None
    progress: dict[str, float]
    error: str | None
    error_type: str | None
    report: dict[str, Any] | None
    stops: int = 0


@dataclass(frozen=True)
class StreamRecord:
    """One request to stream a job's program to a target."""

    id: str
    job_id: str
    target: str
    state: StreamState
    created: float
    started: float | None
    finished: float | None
    result: dict[str, Any] | None
    error: str | None


def _job(row: sqlite3.Row) -> JobRecord:
    return JobRecord(
        id=row["id"], state=JobState(row["state"]), parameters=json.loads(row["parameters"]),
        input_name=row["input_name"], created=row["created"], started=row["started"],
        finished=row["finished"], attempts=row["attempts"], stage=row["stage"],
        progress=json.loads(row["progress"]), error=row["error"], error_type=row["error_type"],
        report=None if row["report"] is None else json.loads(row["report"]),
        stops=row["stops"])


def _stream(row: sqlite3.Row) -> StreamRecord:
    return StreamRecord(
        id=row["id"], job_id=row["job_id"], target=row["target"],
        state=StreamState(row["state"]), created=row["created"], started=row["started"],
        finished=row["finished"],
        result=None if row["result"] is None else json.loads(row["result"]), error=row["error"])


class JobStore:
    """Jobs and streams in one SQLite file (created on first use).

    Parameters
    ----------
    path : Path
        The database file; its folder is created if missing.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> store = JobStore(pathlib.Path(tempfile.mkdtemp()) / "jobs.sqlite3")
    >>> job = store.add({"scallop_mm": 0.05}, input_name="blade.csv")
    >>> store.claim_next().id == job.id
    True
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._connect() as db:
            db.execute("PRAGMA journal_mode = WAL")
            version = db.execute("PRAGMA user_version").fetchone()[0]
            if version > SCHEMA_VERSION:
                raise RuntimeError(f"{self.path}: job store schema {version} is newer than "
                                   f"this service's {SCHEMA_VERSION}")
            if 0 < version < 3:
                _allow_cancelled(db)
            db.executescript(_SCHEMA)
            columns = {r["name"] for r in db.execute("PRAGMA table_info(jobs)")}
            if "stops" not in columns:  # a version 1 store: graceful stops not counted
                db.execute("ALTER TABLE jobs ADD COLUMN stops INTEGER NOT NULL DEFAULT 0")
            db.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")

    @contextmanager
    def _connect(self) -> Iterator[sqlite3.Connection]:
        """A connection in autocommit mode (each statement is its own transaction)."""
        with closing(sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S,
                                     isolation_level=None)) as db:
            db.row_factory = sqlite3.Row
            db.execute("PRAGMA foreign_keys = ON")
            yield db

    # jobs -----------------------------------------------------------------------------

    def add(self, parameters: dict[str, Any], *, input_name: str,
            job_id: str | None = None) -> JobRecord:
        """Insert a queued job and return it."""
        job_id = job_id or uuid.uuid4().hex
        with self._connect() as db:
            row = db.execute(
                "INSERT INTO jobs (id, state, parameters, input_name, created) "
                "VALUES (?, 'queued', ?, ?, ?) RETURNING *",
                (job_id, json.dumps(parameters), input_name, time.time())).fetchone()
        return _job(row)

    def get(self, job_id: str) -> JobRecord | None:
        """The job, or ``None`` if there is no such id."""
        with self._connect() as db:
            row = db.execute("SELECT * FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return None if row is None else _job(row)

    def jobs(self, *, state: JobState | None = None, limit: int = 100,
             offset: int = 0) -> list[JobRecord]:
        """Jobs newest first, optionally of one state."""
        where, args = ("WHERE state = ?", [str(state)]) if state else ("", [])
        with self._connect() as db:
            rows = db.execute(f"SELECT * FROM jobs {where} ORDER BY seq DESC LIMIT ? OFFSET ?",
                              (*args, limit, offset)).fetchall()
        return [_job(r) for r in rows]

    def changing_jobs(self, *, finished_after: float) -> list[JobRecord]:
        """Queued and running jobs, and those finished after ``finished_after`` (Unix s)."""
        with self._connect() as db:
            rows = db.execute(
                "SELECT * FROM jobs WHERE state IN ('queued', 'running') OR finished >= ? "
                "OR id IN (SELECT job_id FROM streams WHERE state IN ('queued', 'running') "
                "OR finished >= ?) ORDER BY seq DESC", (finished_after, finished_after)
            ).fetchall()
        return [_job(r) for r in rows]

    def streams_of_jobs(self, job_ids: list[str]) -> dict[str, list[StreamRecord]]:
        """The stream requests of each of ``job_ids`` (oldest first); jobs without, absent."""
        out: dict[str, list[StreamRecord]] = {}
        with self._connect() as db:
            for start in range(0, len(job_ids), 500):  # (SQLite's variable limit)
                chunk = job_ids[start:start + 500]
                rows = db.execute(
                    f"SELECT * FROM streams WHERE job_id IN ({', '.join('?' * len(chunk))}) "
                    "ORDER BY seq", chunk).fetchall()
                for row in rows:
                    out.setdefault(row["job_id"], []).append(_stream(row))
        return out

    def counts(self) -> dict[str, int]:
        """Number of jobs by state (every state present)."""
        with self._connect() as db:
            rows = db.execute("SELECT state, COUNT(*) FROM jobs GROUP BY state").fetchall()
        return {str(s): 0 for s in JobState} | {r[0]: r[1] for r in rows}

    def claim_next(self) -> JobRecord | None:
        """Move the oldest queued job to ``running`` (one attempt more) and return it."""
        with self._connect() as db:
            row = db.execute(
                "UPDATE jobs SET state = 'running', started = ?, attempts = attempts + 1, "
                "stage = NULL, progress = '{}' WHERE id = (SELECT id FROM jobs WHERE "
                "state = 'queued' ORDER BY seq LIMIT 1) RETURNING *", (time.time(),)).fetchone()
        return None if row is None else _job(row)

    def set_progress(self, job_id: str, attempt: int, stage: str, fraction: float) -> bool:
        """Record ``fraction`` (0 to 1) of ``stage`` for the run ``attempt``.

        Returns whether the run still owns the job (``False``: cancelled, or superseded).
        """
        with self._connect() as db:
            cursor = db.execute(
                "UPDATE jobs SET stage = ?, progress = json_set(progress, '$.' || ?, ?) "
                "WHERE id = ? AND state = 'running' AND attempts = ?",
                (stage, stage, float(fraction), job_id, attempt))
        return cursor.rowcount == 1

    def cancel(self, job_id: str) -> JobRecord | None:
        """Cancel a queued or running job; ``None`` if it is not (any more) one of those.

        A queued job is never claimed; a running one's worker stops at its next progress
        write (:meth:`set_progress` answers ``False``) and its outcome is dropped.
        """
        with self._connect() as db:
            row = db.execute(
                "UPDATE jobs SET state = 'cancelled', finished = ?, error = 'cancelled on "
                "request', error_type = 'Cancelled' WHERE id = ? AND state IN ('queued', "
                "'running') RETURNING *", (time.time(), job_id)).fetchone()
        return None if row is None else _job(row)

    def finish(self, job_id: str, attempt: int, report: dict[str, Any]) -> bool:
        """Mark the run ``attempt`` done with its report; ``False`` if it was superseded."""
        with self._connect() as db:
            cursor = db.execute(
                "UPDATE jobs SET state = 'done', finished = ?, report = ?, error = NULL, "
                "error_type = NULL WHERE id = ? AND state = 'running' AND attempts = ?",
                (time.time(), json.dumps(report), job_id, attempt))
        return cursor.rowcount == 1

    def fail(self, job_id: str, attempt: int | None, error: str, error_type: str) -> bool:
        """Mark a job failed (the run ``attempt``, or a queued job with ``None``)."""
        with self._connect() as db:
            if attempt is None:
                cursor = db.execute(
                    "UPDATE jobs SET state = 'failed', finished = ?, error = ?, error_type = ? "
                    "WHERE id = ? AND state IN ('queued', 'running')",
                    (time.time(), error, error_type, job_id))
            else:
                cursor = db.execute(
                    "UPDATE jobs SET state = 'failed', finished = ?, error = ?, error_type = ? "
                    "WHERE id = ? AND state = 'running' AND attempts = ?",
                    (time.time(), error, error_type, job_id, attempt))
        return cursor.rowcount == 1

    def release(self, job_id: str, attempt: int, *, max_attempts: int, reason: str) -> str:
        """Put the run ``attempt`` back in the queue (its worker died), or fail it for good.

        Returns
        -------
        str
            ``"queued"``, ``"failed"`` (``max_attempts`` runs used up), or ``"superseded"``.
        """
        if self.fail_if_worn(job_id, attempt, max_attempts=max_attempts, reason=reason):
            return "failed"
        with self._connect() as db:
            cursor = db.execute(
                "UPDATE jobs SET state = 'queued', stage = NULL, progress = '{}' "
                "WHERE id = ? AND state = 'running' AND attempts = ?", (job_id, attempt))
        return "queued" if cursor.rowcount == 1 else "superseded"

    def fail_if_worn(self, job_id: str, attempt: int, *, max_attempts: int,
                     reason: str) -> bool:
        """Fail the run ``attempt`` if it is the ``max_attempts``-th cut short; whether it was.

        Runs ended by a graceful stop (``stops``) do not count.
        """
        with self._connect() as db:
            cursor = db.execute(
                "UPDATE jobs SET state = 'failed', finished = ?, error_type = 'Interrupted', "
                "error = ? || ' (' || (attempts - stops) || ' times; not retried again)' "
                "WHERE id = ? AND state = 'running' AND attempts = ? "
                "AND attempts - stops >= ?",
                (time.time(), reason, job_id, attempt, max_attempts))
        return cursor.rowcount == 1

    def requeue_stopped(self, job_id: str, attempt: int) -> bool:
        """The run ``attempt`` was stopped with the service: queue it again, not as a failure.

        Returns whether the job was still in that run (``False``: it finished meanwhile, or
        a newer run owns it).
        """
        with self._connect() as db:
            cursor = db.execute(
                "UPDATE jobs SET state = 'queued', stops = stops + 1, stage = NULL, "
                "progress = '{}' WHERE id = ? AND state = 'running' AND attempts = ?",
                (job_id, attempt))
        return cursor.rowcount == 1

    def recover(self, *, max_attempts: int) -> tuple[list[str], list[str]]:
        """After a restart: re-queue the jobs that were running, fail the worn-out ones.

        A job still ``running`` here was cut short by a crash (a graceful stop re-queued
        its jobs): it fails when crashes ended ``max_attempts`` of its runs.

        Returns
        -------
        requeued, failed : list of str
            Job ids.
        """
        now = time.time()
        with self._connect() as db:
            failed = db.execute(
                "UPDATE jobs SET state = 'failed', finished = ?, error_type = 'Interrupted', "
                "error = 'the service stopped during this job (' || (attempts - stops) || "
                "' times; not retried again)' WHERE state = 'running' "
                "AND attempts - stops >= ? RETURNING id",
                (now, max_attempts)).fetchall()
            requeued = db.execute(
                "UPDATE jobs SET state = 'queued', stage = NULL, progress = '{}' "
                "WHERE state = 'running' RETURNING id").fetchall()
            db.execute(
                "UPDATE streams SET state = 'failed', finished = ?, error = 'interrupted by a "
                "service restart and not re-sent: the machine may hold part of the program; "
                "check it, then ask again' WHERE state IN ('queued', 'running')", (now,))
        return [r[0] for r in requeued], [r[0] for r in failed]

    # streams --------------------------------------------------------------------------

    def add_stream(self, job_id: str, target: str) -> StreamRecord | None:
        """Insert a queued stream request; ``None`` if one of the job's is still active.

        One program goes out once at a time: the streamer journals next to the program,
        and two runs of one job on two machines at once is nobody's intent.
        """
        with self._connect() as db:
            row = db.execute(
                "INSERT INTO streams (id, job_id, target, state, created) "
                "SELECT ?, ?, ?, 'queued', ? WHERE NOT EXISTS (SELECT 1 FROM streams WHERE "
                "job_id = ? AND state IN ('queued', 'running')) RETURNING *",
                (uuid.uuid4().hex, job_id, target, time.time(), job_id)).fetchone()
        return None if row is None else _stream(row)

    def get_stream(self, stream_id: str) -> StreamRecord | None:
        """The stream request, or ``None``."""
        with self._connect() as db:
            row = db.execute("SELECT * FROM streams WHERE id = ?", (stream_id,)).fetchone()
        return None if row is None else _stream(row)

    def streams_of(self, job_id: str) -> list[StreamRecord]:
        """A job's stream requests, oldest first."""
        with self._connect() as db:
            rows = db.execute("SELECT * FROM streams WHERE job_id = ? ORDER BY seq",
                              (job_id,)).fetchall()
        return [_stream(r) for r in rows]

    def start_stream(self, stream_id: str) -> bool:
        """``queued`` -> ``running``; ``False`` if it was not queued any more."""
        with self._connect() as db:
            cursor = db.execute("UPDATE streams SET state = 'running', started = ? "
                                "WHERE id = ? AND state = 'queued'", (time.time(), stream_id))
        return cursor.rowcount == 1

    def cancel_queued_stream(self, stream_id: str) -> bool:
        """``queued`` -> ``cancelled`` (it never starts); ``False`` if it was not queued."""
        with self._connect() as db:
            cursor = db.execute(
                "UPDATE streams SET state = 'cancelled', finished = ?, error = 'cancelled "
                "before it started' WHERE id = ? AND state = 'queued'", (time.time(), stream_id))
        return cursor.rowcount == 1

    def end_stream(self, stream_id: str, *, result: dict[str, Any] | None = None,
                   error: str | None = None, cancelled: bool = False) -> None:
        """Record the outcome: cancelled if asked, failed if there is an ``error``, else done.

        ``result`` is kept.
        """
        state = StreamState.FAILED if error is not None else StreamState.DONE
        if cancelled:
            state = StreamState.CANCELLED
        with self._connect() as db:
            db.execute(
                "UPDATE streams SET state = ?, finished = ?, result = ?, error = ? "
                "WHERE id = ? AND state IN ('queued', 'running')",
                (str(state), time.time(),
                 None if result is None else json.dumps(result, default=str),
                 error, stream_id))


def _allow_cancelled(db: sqlite3.Connection) -> None:
    """Rebuild a version 1 or 2 store's tables so their ``state`` accepts ``cancelled``.

    SQLite cannot alter a CHECK constraint: each table is copied into one of the new
    schema, in one transaction (the rows, ids and ``seq`` order are kept).
    """
    db.execute("PRAGMA foreign_keys = OFF")
    db.execute("BEGIN IMMEDIATE")
    try:
        renamed = []
        for table, index in (("jobs", "jobs_state"), ("streams", "streams_job")):
            sql = db.execute("SELECT sql FROM sqlite_master WHERE type = 'table' AND name = ?",
                             (table,)).fetchone()
            if sql is None or "'cancelled'" in sql[0]:
                continue
            db.execute(f"ALTER TABLE {table} RENAME TO {table}_old")
            db.execute(f"DROP INDEX IF EXISTS {index}")
            renamed.append(table)
        for statement in _SCHEMA.split(";"):  # (executescript would commit first)
            if statement.strip():
                db.execute(statement)
        for table in renamed:
            columns = ", ".join(r["name"] for r in db.execute(f"PRAGMA table_info({table}_old)"))
            db.execute(f"INSERT INTO {table} ({columns}) SELECT {columns} FROM {table}_old")
            db.execute(f"DROP TABLE {table}_old")
        db.execute("COMMIT")
    except BaseException:
        db.execute("ROLLBACK")
        raise
    finally:
        db.execute("PRAGMA foreign_keys = ON")
