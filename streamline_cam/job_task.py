"""One pipeline job packed to run in another process or on another machine.

:func:`streamline_cam.pipeline.run_job` is the one job function; this module only carries it
across a process boundary that shares no disk: :func:`pack_job` turns a
:class:`~streamline_cam.pipeline.JobRequest` into a :class:`PackedJob` (the sections file's
bytes and the request's fields, a few tens of kB), :func:`run_packed_job` runs it in a scratch
folder where it lands (a Dask worker, :mod:`streamline_cam.batch`, the service's
``--scheduler``) and answers a :class:`JobOutcome`: the report and every file the job wrote, as
bytes, or the job's one-line error. It never raises for a failing job, so a task's failure
is always the job's, never the transport's; the caller writes the files where it keeps them.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import socket
import tempfile
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from gcode.errors import GCodeError
from machines.errors import MachineError
from toolpath.errors import DataFileError, ToolpathError

from .pipeline import JobRequest, run_job

__all__ = [
    "USER_ERRORS",
    "JobInterrupted",
    "JobOutcome",
    "PackedJob",
    "ThrottledProgress",
    "pack_job",
    "run_packed_job",
    "write_files",
]

#: The library's own error families: bad input or a request the library refuses.
USER_ERRORS: Final = (ToolpathError, MachineError, GCodeError)

Progress = Callable[[str, float], None]


class ThrottledProgress:
    """``progress(stage, fraction)`` passed on at most once per ``interval_s`` per stage.

    A stage's start (fraction <= 0) and end (>= 1) always pass; subclasses say where to
    (:meth:`emit`): the service's job store, a Dask worker's event log.
    """

    def __init__(self, interval_s: float) -> None:
        self._interval_s = interval_s
        self._last: dict[str, float] = {}

    def __call__(self, stage: str, fraction: float) -> None:
        """Pass ``fraction`` of ``stage`` on if it starts or ends the stage or is due."""
        now = time.monotonic()
        ends = fraction <= 0.0 or fraction >= 1.0
        if not ends and now - self._last.get(stage, -1e9) < self._interval_s:
            return
        self._last[stage] = now
        self.emit(stage, fraction)

    def emit(self, stage: str, fraction: float) -> None:
        """Deliver one progress figure (the subclass's destination)."""
        raise NotImplementedError


class JobInterrupted(Exception):
    """The engine running a job stopped before the job ended: it has no outcome (not failed)."""


@dataclass(frozen=True)
class PackedJob:
    """A job that needs nothing from the sender's disk.

    Attributes
    ----------
    input_name : str
        The sections file's name (the job's G-code program is named after its stem).
    input_bytes : bytes
        The sections file's content.
    request_fields : dict
        The :class:`JobRequest`'s other fields (plain values).
    shown_path : str
        The sections file as the sender knows it: error messages name it, not the scratch copy.
    verify, plots : bool
        As :func:`~streamline_cam.pipeline.run_job`'s.
    """

    input_name: str
    input_bytes: bytes
    request_fields: dict[str, Any]
    shown_path: str
    verify: bool = False
    plots: bool = False


@dataclass(frozen=True)
class JobOutcome:
    """What a packed job gives back.

    Attributes
    ----------
    report : dict or None
        The job's JSON report (None when it failed).
    files : dict
        File name -> bytes: what the job wrote into its folder (``report.json`` included).
    error : str or None
        The one-line error of a failed job.
    error_type : str or None
        Its class name (``InternalError`` for a bug, with ``traceback``).
    traceback : str or None
    seconds : float
        Wall time on the worker.
    worker : str
        ``host:pid`` of the process that ran it.
    """

    report: dict[str, Any] | None
    files: dict[str, bytes] = field(default_factory=dict)
    error: str | None = None
    error_type: str | None = None
    traceback: str | None = None
    seconds: float = 0.0
    worker: str = ""

    @property
    def ok(self) -> bool:
        """The job ran to its report (its program may still have check errors)."""
        return self.error is None


def pack_job(request: JobRequest, *, verify: bool = False, plots: bool = False) -> PackedJob:
    """``request`` with its sections file read in (a missing file is named here)."""
    path = Path(request.sections_path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataFileError(f"cannot read the sections file ({exc.strerror})",
                            path=str(path)) from None
    fields = {f.name: getattr(request, f.name) for f in dataclasses.fields(request)
              if f.name != "sections_path"}
    return PackedJob(input_name=path.name, input_bytes=data, request_fields=fields,
                     shown_path=str(path), verify=verify, plots=plots)


def worker_name() -> str:
    """``host:pid`` of this process."""
    return f"{socket.gethostname()}:{os.getpid()}"


def run_packed_job(job: PackedJob, *, scratch_dir: str | os.PathLike[str] | None = None,
                   progress: Progress | None = None) -> JobOutcome:
    """Run ``job`` with :func:`~streamline_cam.pipeline.run_job` in a scratch folder.

    The folder (under ``scratch_dir``, default the system's temporary folder) is removed
    afterwards whatever happens; a process killed meanwhile leaves it behind, never a result.
    The library's errors come back as the outcome's one-line ``error``; any other exception
    as an ``InternalError`` with its traceback.
    """
    start = time.perf_counter()
    folder = Path(tempfile.mkdtemp(prefix="toolpath-job-", dir=scratch_dir))
    scratch_input = folder / "input" / job.input_name
    try:
        scratch_input.parent.mkdir()
        scratch_input.write_bytes(job.input_bytes)
        out_dir = folder / "out"
        request = JobRequest(sections_path=scratch_input, **job.request_fields)
        try:
            result = run_job(request, out_dir, progress=progress, plots=job.plots,
                             verify=job.verify)
        except USER_ERRORS as exc:
            message = str(exc).replace(str(scratch_input), job.shown_path)
            return JobOutcome(None, error=message.replace("\n", " "),
                              error_type=type(exc).__name__,
                              seconds=time.perf_counter() - start, worker=worker_name())
        except Exception as exc:  # a bug: the batch or the service goes on, the trace kept
            return JobOutcome(None, error=f"internal error ({type(exc).__name__}: {exc})",
                              error_type="InternalError", traceback=traceback.format_exc(),
                              seconds=time.perf_counter() - start, worker=worker_name())
        files = {p.name: p.read_bytes() for p in sorted(out_dir.iterdir()) if p.is_file()}
        # the report names the sections file where the sender keeps it, not the scratch copy
        report = result.report | {"request": result.report["request"]
                                  | {"sections_path": job.shown_path}}
        files[result.files["report"].name] = json.dumps(report, indent=2).encode()
        return JobOutcome(report, files=files, seconds=time.perf_counter() - start,
                          worker=worker_name())
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def write_files(files: dict[str, bytes], folder: Path) -> None:
    """Write an outcome's files into ``folder`` (each through a temporary name)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        if Path(name).name != name:  # only ever plain names: never outside the folder
            raise ValueError(f"not a plain file name: {name!r}")
        part = folder / f".{name}.part"
        part.write_bytes(data)
        part.replace(folder / name)
