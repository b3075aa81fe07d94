"""A batch of blades: one ``toolpath run`` job per sections file, as Dask tasks.

Each input becomes a :class:`BatchJob` (its folder name, and a fingerprint of its bytes and
the job's options), each job one task (:mod:`streamline_cam.dask_engine`) running
:func:`streamline_cam.pipeline.run_job` on whichever worker takes it. The client writes each
result as ``toolpath run`` would (``OUT_DIR/<name>/`` with ``part.nc``, ``report.json``, ...)
atomically: the files go into ``OUT_DIR/.partial/<name>-<random>/`` and the finished folder is
renamed into place, so ``OUT_DIR/<name>/`` exists only complete. ``batch_job.json`` in it
records the fingerprint: a rerun into the same ``OUT_DIR`` skips every job whose folder holds
the same fingerprint (same bytes, same options), and redoes the failed and the changed ones.
At the end, ``summary.csv`` and ``summary.json``: one row per input.
"""

from __future__ import annotations

import csv
import dataclasses
import glob
import hashlib
import json
import shutil
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from toolpath.errors import DataFileError, InvalidParameterError

from .job_task import JobOutcome, PackedJob, pack_job, write_files
from .pipeline import JobRequest
from .verdict import plan_excess, verify_excess

__all__ = [
    "JOB_RECORD",
    "SUMMARY_FIELDS",
    "BatchJob",
    "BatchSummary",
    "find_inputs",
    "needs_run",
    "plan_batch",
    "run_batch",
    "summary_row",
]

#: The file in each finished job's folder that says what it was made from.
JOB_RECORD: Final[str] = "batch_job.json"
#: Where unfinished folders are written before they are renamed into place.
PARTIAL_DIR: Final[str] = ".partial"
#: The summary's columns, in order. ``scallop_above_mm``: where the plan's largest scallop
#: stands above the measure's horizon (its ``max_scallop_mm`` then empty, as in the report's
#: JSON), that horizon: the scallop is more than this, not unmeasured.
SUMMARY_FIELDS: Final[tuple[str, ...]] = (
    "file", "name", "status", "exit", "passes", "points", "max_scallop_mm",
    "scallop_above_mm", "max_chord_error_mm", "verified_scallop_mm", "verified_gouge_mm",
    "check_errors", "seconds", "worker", "error")


@dataclass(frozen=True)
class BatchJob:
    """One input of a batch: its folder name under ``OUT_DIR``, fingerprint and packed job.

    An input that cannot be read has no packed job but its ``error``: it fails alone.
    """

    name: str
    path: Path
    fingerprint: str
    packed: PackedJob | None
    error: str | None = None


@dataclass(frozen=True)
class BatchSummary:
    """The batch's rows (one per input, in input order) and where the summary went."""

    rows: list[dict[str, Any]]
    csv_path: Path
    json_path: Path

    @property
    def all_held(self) -> bool:
        """Every job made a program that checked clean, its figures within the request."""
        return all(row["exit"] == 0 for row in self.rows)


def find_inputs(patterns: Sequence[str]) -> list[Path]:
    """The sections files named by ``patterns``: files, folders (their ``*.csv``), globs.

    In the order given (a folder's and a glob's files sorted by name), each once.
    """
    found: list[Path] = []
    for pattern in patterns:
        path = Path(pattern)
        if path.is_dir():
            matches = sorted(p for p in path.glob("*.csv") if p.is_file())
            if not matches:
                raise InvalidParameterError(f"no sections files (*.csv) in the folder {pattern}")
        elif glob.has_magic(pattern):
            matches = sorted(Path(p) for p in glob.glob(pattern) if Path(p).is_file())
            if not matches:
                raise InvalidParameterError(f"no file matches {pattern}")
        elif path.is_file():
            matches = [path]
        else:
            raise InvalidParameterError(f"no such file or folder: {pattern}")
        found += matches
    unique: dict[Path, Path] = {}
    for path in found:
        unique.setdefault(path.resolve(), path)
    return list(unique.values())


def _names(paths: Sequence[Path]) -> list[str]:
    """Folder names: the file's stem, its parent folder's name before it where stems repeat."""
    stems = [p.stem for p in paths]
    names = [f"{p.parent.name}-{p.stem}" if stems.count(p.stem) > 1 else p.stem
             for p in paths]
    seen: dict[str, int] = {}
    unique = []
    for name in names:
        name = name.lstrip(".") or "job"
        seen[name] = seen.get(name, 0) + 1
        unique.append(name if seen[name] == 1 else f"{name}-{seen[name]}")
    return unique


def _fingerprint(packed: PackedJob) -> str:
    """What makes two jobs' results the same: the input's bytes and every option."""
    digest = hashlib.sha256(packed.input_bytes)
    options = dataclasses.asdict(packed) | {"input_bytes": None, "shown_path": None}
    digest.update(json.dumps(options, sort_keys=True, default=str).encode())
    return digest.hexdigest()


def plan_batch(paths: Sequence[Path], template: JobRequest, *, verify: bool = False,
               plots: bool = False) -> list[BatchJob]:
    """One :class:`BatchJob` per input, the options of ``template`` for each."""
    template.validated()  # a bad option is named once, before any work
    jobs = []
    for name, path in zip(_names(paths), paths, strict=True):
        try:
            packed = pack_job(dataclasses.replace(template, sections_path=path),
                              verify=verify, plots=plots)
        except DataFileError as exc:  # unreadable (permissions): this job fails, not all
            jobs.append(BatchJob(name, path, "", None, error=str(exc)))
            continue
        jobs.append(BatchJob(name, path, _fingerprint(packed), packed))
    return jobs


def summary_row(job: BatchJob, outcome: JobOutcome | None, *, status: str,
                record: dict[str, Any] | None = None) -> dict[str, Any]:
    """The summary's row for ``job``: from its outcome, or a skipped job's saved record."""
    row: dict[str, Any] = dict.fromkeys(SUMMARY_FIELDS)
    here = {"file": str(job.path), "name": job.name, "status": status}
    if record is not None or outcome is None:  # skipped: the figures of the run that made it
        return row | {k: (record or {}).get(k) for k in SUMMARY_FIELDS} | here
    row |= here | {"seconds": round(outcome.seconds, 3), "worker": outcome.worker}
    if not outcome.ok:
        return row | {"exit": 2, "error": outcome.error}
    report = outcome.report or {}
    plan, check = report.get("plan", {}), report.get("check", {})
    verify = report.get("verify", {})
    # as `toolpath run` exits: 1 on check errors, or figures beyond the request (the
    # verifier's when verified, else the plan's own)
    excess = verify_excess(report) if verify else plan_excess(report)
    return row | {
        "exit": 1 if check.get("errors") or excess else 0, "passes": plan.get("n_passes"),
        "points": plan.get("n_points"), "max_scallop_mm": plan.get("max_scallop_mm"),
        "scallop_above_mm": (plan.get("scallop_horizon_mm") if plan.get("scallop_above_horizon")
                             else None),
        "max_chord_error_mm": plan.get("max_chord_error_mm"),
        "verified_scallop_mm": verify.get("max_scallop_mm"),
        "verified_gouge_mm": verify.get("max_gouge_mm"), "check_errors": check.get("errors"),
        "error": ((check.get("issues") or [None])[0] if check.get("errors") else excess)}


def _finished_record(folder: Path, fingerprint: str) -> dict[str, Any] | None:
    """The saved record of a finished job of this fingerprint in ``folder``, if any."""
    try:
        record = json.loads((folder / JOB_RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if record.get("fingerprint") == fingerprint else None


def needs_run(job: BatchJob, out_dir: Path) -> bool:
    """``job`` has to run: readable, and no finished folder of its fingerprint in ``out_dir``."""
    return job.packed is not None and _finished_record(out_dir / job.name,
                                                       job.fingerprint) is None


def _commit(out_dir: Path, job: BatchJob, outcome: JobOutcome, row: dict[str, Any]) -> None:
    """Write the job's folder whole, then rename it into place (replacing an older one)."""
    partial = out_dir / PARTIAL_DIR
    folder = partial / f"{job.name}-{uuid.uuid4().hex[:8]}"
    write_files(outcome.files, folder)
    (folder / JOB_RECORD).write_text(json.dumps(
        row | {"fingerprint": job.fingerprint}, indent=2), encoding="utf-8")
    final = out_dir / job.name
    old = None
    if final.exists():
        old = partial / f"{job.name}-old-{uuid.uuid4().hex[:8]}"
        final.rename(old)
    folder.rename(final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _write_summary(out_dir: Path, rows: list[dict[str, Any]]) -> tuple[Path, Path]:
    csv_path, json_path = out_dir / "summary.csv", out_dir / "summary.json"
    part = out_dir / ".summary.csv.part"
    with part.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.DictWriter(stream, fieldnames=SUMMARY_FIELDS)
        writer.writeheader()
        writer.writerows({k: ("" if row[k] is None else row[k]) for k in SUMMARY_FIELDS}
                         for row in rows)
    part.replace(csv_path)
    part = out_dir / ".summary.json.part"
    part.write_text(json.dumps({"all_held": all(r["exit"] == 0 for r in rows),
                                "jobs": rows}, indent=2), encoding="utf-8")
    part.replace(json_path)
    return csv_path, json_path


def run_batch(jobs: Sequence[BatchJob], out_dir: Path, client: Any, *,
              on_done: Callable[[dict[str, Any]], None] | None = None,
              task: Callable[..., JobOutcome] | None = None,
              timeout_s: float | None = None) -> BatchSummary:
    """Run ``jobs`` on ``client``'s cluster into ``out_dir``; jobs finished before are skipped.

    Parameters
    ----------
    jobs : sequence of BatchJob
    out_dir : Path
    client : distributed.Client or None
        Needed only when a job has to run (:func:`needs_run`).
    on_done : callable, optional
        Called with each job's row as it finishes (skipped jobs first).
    task : callable, optional
        The Dask task (default :func:`~.dask_engine.run_packed_task`; tests wrap it).
    timeout_s : float, optional
        Give up waiting after this long in all (``TimeoutError``); default: wait.
    """
    from . import dask_engine

    out_dir.mkdir(parents=True, exist_ok=True)
    rows: dict[str, dict[str, Any]] = {}
    futures, by_key = [], {}
    for job in jobs:
        if job.packed is None:
            rows[job.name] = summary_row(job, JobOutcome(None, error=job.error),
                                         status="failed")
        elif not needs_run(job, out_dir):
            rows[job.name] = summary_row(job, None, status="skipped",
                                         record=_finished_record(out_dir / job.name,
                                                                 job.fingerprint))
        if job.name in rows:
            if on_done is not None:
                on_done(rows[job.name])
            continue
        key = f"toolpath-batch-{job.name}-{job.fingerprint[:12]}-{uuid.uuid4().hex[:6]}"
        future = dask_engine.submit_job(client, job.packed, key,
                                        **({} if task is None else {"task": task}))
        futures.append(future)
        by_key[future.key] = job
    for future, outcome in dask_engine.as_outcomes(futures, timeout_s=timeout_s):
        job = by_key[future.key]
        row = summary_row(job, outcome, status="done" if outcome.ok else "failed")
        if outcome.ok:
            _commit(out_dir, job, outcome, row)
        rows[job.name] = row
        if on_done is not None:
            on_done(row)
    ordered = [rows[job.name] for job in jobs]
    csv_path, json_path = _write_summary(out_dir, ordered)
    shutil.rmtree(out_dir / PARTIAL_DIR, ignore_errors=True)
    return BatchSummary(ordered, csv_path, json_path)

