"""The HTTP endpoints (one router); the service's parts come from ``request.app.state``.

Endpoints are plain ``def``: FastAPI runs them in its thread pool, where SQLite calls and
file copies do not block the event loop. ``GET /events`` is the one ``async`` endpoint: a
Server-Sent Events stream fed by the service's :class:`~.events.EventHub`.
"""

from __future__ import annotations

import shutil
import uuid
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

from fastapi import (
    APIRouter,
    Depends,
    Form,
    HTTPException,
    Query,
    Request,
    Response,
)
from fastapi.responses import FileResponse, JSONResponse, StreamingResponse
from starlette.concurrency import run_in_threadpool

from gcode.dialects import dialect_names
from machines.machine import list_machines

from ..pipeline import STAGES
from ..verdict import report_verdict, verdict_summary
from . import artefacts, preview
from .config import ServiceConfig
from .events import CLOSED, EventHub, sse
from .pool import WorkerPool
from .runner import as_job_fields
from .schemas import (
    ErrorBody,
    Health,
    JobForm,
    JobList,
    JobParameters,
    JobSubmission,
    JobView,
    Preview,
    StreamRequest,
    StreamView,
    timestamp,
)
from .store import FINAL_STATES, JobRecord, JobState, JobStore, StreamRecord
from .streams import StreamingUnavailable, StreamRunner
from .validation import (
    SubmissionError,
    check_parameters,
    check_sections_file,
    safe_name,
    write_sections_csv,
)

__all__ = ["Service", "router"]

# The pipeline's stages the status shows (streaming has its own records).
_JOB_STAGES = tuple(s for s in STAGES if s != "stream")


@dataclass(frozen=True)
class Service:
    """The parts of one running service (on ``app.state.service``)."""

    config: ServiceConfig
    store: JobStore
    pool: WorkerPool
    streams: StreamRunner
    plot_lock: Any
    events: EventHub

    def job_view(self, record: JobRecord,
                 streams: list[StreamRecord] | None = None) -> JobView:
        """``GET /jobs/{id}``'s answer for ``record`` (its streams with their live status)."""
        return _job_view(record, streams, self.streams.live)

    def stream_view(self, record: StreamRecord) -> StreamView:
        """``GET /jobs/{id}/streams/{sid}``'s answer: the record and its live status."""
        return _stream_view(record, self.streams.live(record.id))


def _service(request: Request) -> Service:
    return request.app.state.service


ServiceDep = Annotated[Service, Depends(_service)]
_ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorBody} for code in (404, 409, 413, 422, 503)}

router = APIRouter(responses=_ERRORS)


# views ---------------------------------------------------------------------------------


def _stream_view(record: StreamRecord, live: dict[str, Any] | None = None) -> StreamView:
    live = dict(live or {})
    state = record.state.value
    if live.pop("held", False) and state == "running":
        state = "held"
    return StreamView(id=record.id, job_id=record.job_id, target=record.target,
                      state=state, created=timestamp(record.created),
                      started=timestamp(record.started), finished=timestamp(record.finished),
                      result=record.result, error=record.error, **live)


def _job_view(record: JobRecord, streams: list[StreamRecord] | None = None,
              live: Callable[[str], dict[str, Any]] | None = None) -> JobView:
    base = f"/jobs/{record.id}"
    links = {"self": base, "input": f"{base}/input"}
    if record.state is JobState.DONE:
        links |= {name: f"{base}/{name}" for name in artefacts.FILES}
        links |= {f"plot:{name}": f"{base}/plots/{name}" for name in artefacts.plot_names()}
        links["stream"] = f"{base}/stream"
        links["preview"] = f"{base}/preview"
    if record.state in (JobState.QUEUED, JobState.RUNNING):
        links["cancel"] = f"{base}/cancel"
    if streams:
        links["journal"] = f"{base}/journal"
    progress = {stage: 0.0 for stage in _JOB_STAGES} | record.progress
    if record.state is JobState.DONE:
        progress = {stage: 1.0 for stage in progress}
    verdict = report_verdict(record.report) if record.state is JobState.DONE else None
    return JobView(
        verdict=None if verdict is None else ("pass" if verdict["ok"] else "exceeds"),
        summary=None if verdict is None else as_job_fields(verdict_summary(verdict)),
        id=record.id, name=Path(record.input_name).stem, state=record.state.value,
        created=timestamp(record.created), started=timestamp(record.started),
        finished=timestamp(record.finished), attempts=record.attempts, stops=record.stops,
        stage=record.stage,
        progress=progress, error=record.error, error_type=record.error_type,
        parameters=record.parameters, links=links,
        streams=[_stream_view(s, live(s.id) if live else None) for s in streams or []])


def _job_or_404(service: Service, job_id: str) -> JobRecord:
    record = service.store.get(job_id)
    if record is None:
        raise HTTPException(404, f"no job {job_id!r}")
    return record


def _done_or_409(service: Service, job_id: str) -> JobRecord:
    record = _job_or_404(service, job_id)
    if record.state is JobState.DONE:
        return record
    if record.state is JobState.FAILED:
        raise HTTPException(409, f"job {job_id} failed, it has no results: {record.error}")
    if record.state is JobState.CANCELLED:
        raise HTTPException(409, f"job {job_id} was cancelled, it has no results")
    where = ""
    if record.stage is not None:
        where = f" (stage {record.stage}, {100 * record.progress.get(record.stage, 0):.0f}%)"
    raise HTTPException(409, f"job {job_id} is {record.state.value}{where}; its results are "
                        "not ready: poll GET /jobs/{id}")


# submission ----------------------------------------------------------------------------


def _submit(service: Service, params: JobParameters, name: str,
            write_input: Callable[[Path], object]) -> JobRecord:
    """Check, store the input, queue the job, and wake the pool."""
    queued = service.store.counts()[JobState.QUEUED]
    if queued >= service.config.max_queued:
        raise HTTPException(503, f"{queued} jobs are waiting (the limit is "
                            f"{service.config.max_queued}); try again later",
                            headers={"Retry-After": "60"})
    values = check_parameters(params)
    job_id = uuid.uuid4().hex
    job_dir = service.config.jobs_dir / job_id
    job_dir.mkdir(parents=True)
    input_name = f"{name}.csv"
    try:
        write_input(job_dir / input_name)
        record = service.store.add(values, input_name=input_name, job_id=job_id)
    except BaseException:
        shutil.rmtree(job_dir, ignore_errors=True)
        raise
    service.pool.dispatch()
    return record


def _accepted(record: JobRecord, response: Response) -> JobView:
    response.headers["Location"] = f"/jobs/{record.id}"
    return _job_view(record)


@router.post("/jobs/{job_id}/cancel", response_model=JobView, tags=["jobs"],
             summary="Cancel a queued or running job")
def cancel_job(job_id: str, service: ServiceDep) -> JobView:
    """Cancel the job: its state becomes ``cancelled``.

    A queued job never runs; a running one stops at its next progress report (within a
    fraction of a second: every stage reports its start, end and steps between). 409
    when the job has already finished (done, failed or cancelled).
    """
    record = service.store.cancel(job_id)
    if record is None:
        current = _job_or_404(service, job_id)
        raise HTTPException(409, f"job {job_id} is {current.state.value}; only a queued or "
                            "running job can be cancelled")
    return service.job_view(record, service.store.streams_of(job_id))


@router.post("/jobs", status_code=202, response_model=JobView, tags=["jobs"],
             summary="Submit a job: sections as JSON and the parameters")
def submit_json(submission: JobSubmission, service: ServiceDep,
                response: Response) -> JobView:
    """Queue a job for sections given as JSON; answers 202 with its status."""
    record = _submit(service, submission, safe_name(submission.name),
                     lambda path: write_sections_csv(submission.sections, path))
    return _accepted(record, response)


@router.post("/jobs/upload", status_code=202, response_model=JobView, tags=["jobs"],
             summary="Submit a job: a sections CSV file and the parameters as form fields")
def submit_csv(params: Annotated[JobForm, Form(media_type="multipart/form-data")],
               service: ServiceDep,
               response: Response) -> JobView:
    """Queue a job for an uploaded ``section,x,y,z`` CSV; answers 202 with its status."""
    file = params.file
    shown_as = file.filename or "the uploaded file"

    def write(path: Path) -> None:
        with path.open("wb") as out:
            shutil.copyfileobj(file.file, out)
        check_sections_file(path, shown_as)

    record = _submit(service, params, safe_name(file.filename), write)
    return _accepted(record, response)


# status and results --------------------------------------------------------------------


@router.get("/jobs", response_model=JobList, tags=["jobs"], summary="List jobs, newest first")
def list_jobs(service: ServiceDep, state: JobState | None = None,
              limit: Annotated[int, Query(ge=1, le=1000)] = 100,
              offset: Annotated[int, Query(ge=0)] = 0) -> JobList:
    """Jobs (optionally of one state) and the counts by state."""
    records = service.store.jobs(state=state, limit=limit, offset=offset)
    return JobList(jobs=[service.job_view(r) for r in records], counts=service.store.counts())


@router.get("/jobs/{job_id}", response_model=JobView, tags=["jobs"],
            summary="A job's state, progress by stage, error and links")
def get_job(job_id: str, service: ServiceDep) -> JobView:
    """Poll this until ``state`` is ``done`` or ``failed``."""
    record = _job_or_404(service, job_id)
    return service.job_view(record, service.store.streams_of(job_id))


@router.get("/jobs/{job_id}/report", tags=["results"],
            summary="The report: fit, plan, program, check (JSON)")
def get_report(job_id: str, service: ServiceDep) -> dict[str, Any]:
    """The pipeline's report of a finished job."""
    return _done_or_409(service, job_id).report or {}


def _file(service: Service, job_id: str, name: str) -> FileResponse:
    record = _done_or_409(service, job_id)
    artefact = artefacts.FILES[name]
    path = service.config.jobs_dir / job_id / artefact.file
    if not path.is_file():
        raise HTTPException(404, f"job {job_id} has no {artefact.file} (removed from the "
                            "data folder?)")
    download = Path(record.input_name).stem + artefact.suffix
    return FileResponse(path, media_type=artefact.media_type, filename=download)


@router.get("/jobs/{job_id}/gcode", response_class=FileResponse, tags=["results"],
            summary="The checked G-code program (.nc, text)")
def get_gcode(job_id: str, service: ServiceDep) -> FileResponse:
    """The program as posted for the job's machine and dialect."""
    return _file(service, job_id, "gcode")


@router.get("/jobs/{job_id}/toolpath", response_class=FileResponse, tags=["results"],
            summary="The toolpath (.npz: tool tips, axes, move kinds, feeds)")
def get_toolpath(job_id: str, service: ServiceDep) -> FileResponse:
    """Load with ``toolpath.Toolpath.load`` or ``numpy.load``."""
    return _file(service, job_id, "toolpath")


@router.get("/jobs/{job_id}/surface", response_class=FileResponse, tags=["results"],
            summary="The fitted surface (JSON, toolpath.surface_from_dict)")
def get_surface(job_id: str, service: ServiceDep) -> FileResponse:
    """The fitted surface in its ``to_dict`` form."""
    return _file(service, job_id, "surface")


@router.get("/jobs/{job_id}/input", response_class=FileResponse, tags=["results"],
            summary="The sections as submitted (CSV)")
def get_input(job_id: str, service: ServiceDep) -> FileResponse:
    """The job's input, as stored (JSON submissions are stored as CSV)."""
    record = _job_or_404(service, job_id)
    return FileResponse(service.config.jobs_dir / job_id / record.input_name,
                        media_type="text/csv; charset=utf-8", filename=record.input_name)


@router.get("/jobs/{job_id}/plots/{name}", response_class=FileResponse, tags=["results"],
            responses={200: {"content": {"image/png": {}}}},
            summary="A plot (PNG), drawn on the first request")
def get_plot(job_id: str, name: str, service: ServiceDep) -> FileResponse:
    """``surface``: sections, fitted streamlines and the error map."""
    names = artefacts.plot_names()
    if name.removesuffix(".png") not in names:
        raise HTTPException(404, f"no plot {name!r}; plots: {', '.join(names)}")
    record = _done_or_409(service, job_id)
    path = artefacts.render_plot(name.removesuffix(".png"), service.config.jobs_dir / job_id,
                                 record, service.plot_lock)
    return FileResponse(path, media_type="image/png")


# streaming -----------------------------------------------------------------------------


@router.post("/jobs/{job_id}/stream", status_code=202, response_model=StreamView,
             tags=["streaming"], summary="Stream the job's program to a configured target")
def stream_job(job_id: str, service: ServiceDep, response: Response,
               body: StreamRequest | None = None) -> StreamView:
    """Send the checked program to a target named in the service's configuration.

    503 when this installation has no streamer; 409 when the job is not done or its
    program failed the check.
    """
    body = body or StreamRequest()
    record = _done_or_409(service, job_id)
    if body.target not in service.config.stream_targets:
        raise SubmissionError("target", f"unknown target {body.target!r}; this service "
                              f"streams to {', '.join(service.config.stream_targets)}")
    errors = ((record.report or {}).get("check") or {}).get("errors", 0)
    if errors:
        raise HTTPException(409, f"job {job_id}'s program failed the check with {errors} "
                            "error(s); it is not streamed (see the report)")
    try:
        stream = service.streams.submit(record, body.target)
    except StreamingUnavailable as exc:
        raise HTTPException(503, str(exc)) from None
    if stream is None:
        raise HTTPException(409, f"job {job_id} is already being streamed; wait for that "
                            "stream to end (GET /jobs/{id})")
    response.headers["Location"] = f"/jobs/{job_id}/streams/{stream.id}"
    return service.stream_view(stream)


@router.get("/jobs/{job_id}/journal", response_class=FileResponse, tags=["streaming"],
            summary="The streamer's journal of the job's streams (JSON lines)")
def get_journal(job_id: str, service: ServiceDep) -> FileResponse:
    """Every line sent and answered, one JSON object per line (for a resume)."""
    record = _job_or_404(service, job_id)
    path = service.config.jobs_dir / job_id / "part.journal"
    if not path.is_file():
        raise HTTPException(404, f"job {job_id} has not been streamed")
    return FileResponse(path, media_type="application/x-ndjson",
                        filename=Path(record.input_name).stem + ".journal")


@router.get("/jobs/{job_id}/streams/{stream_id}", response_model=StreamView,
            tags=["streaming"], summary="A stream request's state and result")
def get_stream(job_id: str, stream_id: str, service: ServiceDep) -> StreamView:
    """Poll this (or listen to ``GET /events``) until ``state`` has ended.

    The ends are ``done``, ``failed`` and ``cancelled``; while it runs, the live fields
    give position, lines, percent and ETA.
    """
    return service.stream_view(_stream_or_404(service, job_id, stream_id))


def _stream_or_404(service: Service, job_id: str, stream_id: str) -> StreamRecord:
    stream = service.store.get_stream(stream_id)
    if stream is None or stream.job_id != job_id:
        raise HTTPException(404, f"job {job_id!r} has no stream {stream_id!r}")
    return stream


def _control(service: Service, job_id: str, stream_id: str, action: str,
             allowed: str) -> StreamView:
    """Ask the stream's sender for ``action``; 409 naming the state when it cannot be."""
    _stream_or_404(service, job_id, stream_id)
    if not getattr(service.streams, action)(stream_id):
        view = service.stream_view(_stream_or_404(service, job_id, stream_id))
        raise HTTPException(409, f"stream {stream_id} is {view.state}; only a {allowed} "
                            f"stream can be {'cancelled' if action == 'cancel' else action + 'ed'}")
    return service.stream_view(_stream_or_404(service, job_id, stream_id))


@router.post("/jobs/{job_id}/streams/{stream_id}/hold", status_code=202,
             response_model=StreamView, tags=["streaming"],
             summary="Feed hold (!): the machine decelerates to a stop on the path")
def hold_stream(job_id: str, stream_id: str, service: ServiceDep) -> StreamView:
    """Ask the sender for a feed hold.

    ``state`` becomes ``held`` once the controller reports the axes stopped (watch ``GET
    /events``). 409 unless the stream is running.
    """
    return _control(service, job_id, stream_id, "hold", "running")


@router.post("/jobs/{job_id}/streams/{stream_id}/resume", status_code=202,
             response_model=StreamView, tags=["streaming"],
             summary="Cycle start (~) after a feed hold")
def resume_stream(job_id: str, stream_id: str, service: ServiceDep) -> StreamView:
    """Go on with the held program where it stopped. 409 unless the stream is held."""
    return _control(service, job_id, stream_id, "resume", "held")


@router.post("/jobs/{job_id}/streams/{stream_id}/cancel", status_code=202,
             response_model=StreamView, tags=["streaming"],
             summary="Cancel a stream: feed hold, then soft reset (position kept)")
def cancel_stream(job_id: str, stream_id: str, service: ServiceDep) -> StreamView:
    """Cancel the stream.

    A queued stream never starts; a running or held one is stopped by the sender (feed
    hold, wait for the stop, soft reset) and ends ``cancelled`` with the line to resume
    from in its error. 409 once it has ended.
    """
    return _control(service, job_id, stream_id, "cancel", "queued, running or held")


# preview and live events ---------------------------------------------------------------


@router.get("/jobs/{job_id}/preview", response_class=JSONResponse, tags=["results"],
            responses={200: {"model": Preview}},
            summary="The fitted surface and the toolpath for a 3-D view (decimated)")
def get_preview(job_id: str, service: ServiceDep,
                max_points: Annotated[int, Query(ge=100, le=2_000_000)] = (
                    preview.DEFAULT_MAX_POINTS)) -> Response:
    """The surface on a grid and the toolpath in runs, decimated for display.

    Runs are ``cut`` (one per pass), ``link`` and ``rapid``, at most ``max_points`` points
    in all, every run's ends kept; ``max_deviation_mm`` says how far a dropped point lies
    from the line drawn. The G-code and the ``.npz`` toolpath are the full ones.
    """
    _done_or_409(service, job_id)
    job_dir = service.config.jobs_dir / job_id
    if not (job_dir / "toolpath.npz").is_file() or not (job_dir / "surface.json").is_file():
        raise HTTPException(404, f"job {job_id} has no toolpath.npz or surface.json (removed "
                            "from the data folder?)")
    return Response(preview.job_preview(job_dir, max_points), media_type="application/json")


#: Jobs sent when an ``/events`` connection opens (newest first).
EVENTS_FIRST_JOBS = 10_000


def _snapshot(service: Service) -> list[tuple[str, dict[str, Any]]]:
    """Every job (newest first), then the live streams: what a new listener gets first."""
    records = service.store.jobs(limit=EVENTS_FIRST_JOBS)
    streams = service.store.streams_of_jobs([r.id for r in records])
    events = [("job", service.job_view(r, streams.get(r.id, [])).model_dump(mode="json"))
              for r in records]
    for record in (s for r in records for s in streams.get(r.id, [])):
        if record.state.value not in FINAL_STATES:
            events.append(("stream", service.stream_view(record).model_dump(mode="json")))
    return events


#: How often an idle ``/events`` connection checks that its client is still there (s); at
#: least as often as the heartbeat (``ServiceConfig.heartbeat_s``) is due.
DISCONNECT_CHECK_S = 1.0


@router.get("/events", tags=["jobs"], response_class=StreamingResponse,
            responses={200: {"content": {"text/event-stream": {}}}},
            summary="Live job and stream changes (Server-Sent Events)")
async def events(request: Request, service: ServiceDep) -> StreamingResponse:
    """Server-Sent Events of the jobs and streams, pushed as they change.

    ``event: job`` (data: the job as ``GET /jobs/{id}`` answers) for every job at once,
    newest first, then whenever one changes; ``event: stream`` (data: as ``GET
    /jobs/{id}/streams/{sid}``, with position, line, percent, ETA, alarm) while a stream
    runs; a comment ``: ping`` every 15 s. Use ``new EventSource("/events")``.
    """
    subscription = service.events.subscribe()  # before the snapshot: nothing is missed
    heartbeat_s = service.config.heartbeat_s
    check_s = min(DISCONNECT_CHECK_S, heartbeat_s)

    async def body() -> AsyncIterator[str]:
        quiet_s = 0.0
        try:
            yield ": connected\n\n"
            for event, data in await run_in_threadpool(_snapshot, service):
                yield sse(event, data)
            while (item := await subscription.get(check_s)) != CLOSED:
                if item is None:
                    quiet_s += check_s
                    if await request.is_disconnected():
                        return
                    if quiet_s >= heartbeat_s:
                        quiet_s = 0.0
                        yield ": ping\n\n"
                else:
                    quiet_s = 0.0
                    yield sse(*item)
        finally:
            subscription.close()

    return StreamingResponse(body(), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})


# the service ---------------------------------------------------------------------------


@router.get("/health", response_model=Health, tags=["service"], summary="The service at a glance")
def health(service: ServiceDep) -> Health:
    """Workers, jobs by state, stream targets and whether streaming is available."""
    return Health(status="ok", executor=service.config.executor,
                  workers=service.config.workers, running=service.pool.running,
                  counts=service.store.counts(),
                  stream_targets=sorted(service.config.stream_targets),
                  streaming=service.streams.availability(),
                  max_upload_bytes=service.config.max_upload_bytes)


@router.get("/machines", tags=["service"], summary="Machines, dialects and plots on offer")
def machines() -> JSONResponse:
    """The values ``machine``, ``dialect`` and the plot names accept."""
    return JSONResponse({"machines": list_machines(), "dialects": list(dialect_names()),
                         "plots": artefacts.plot_names()})
