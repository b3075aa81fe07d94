"""The HTTP API's request and response bodies (pydantic; they make the OpenAPI schema).

Types and choices are checked here (so ``/docs`` lists them); ranges and everything that
needs the machine, the cutter or the planner are checked by the library itself
(:mod:`.validation`), so the service and the CLI refuse the same requests with the same words.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any, Literal

from fastapi import UploadFile
from pydantic import BaseModel, ConfigDict, Field, Json

__all__ = [
    "ErrorBody",
    "Health",
    "JobForm",
    "JobList",
    "JobParameters",
    "JobSubmission",
    "JobView",
    "Preview",
    "PreviewSegment",
    "PreviewSurface",
    "StreamRequest",
    "StreamView",
    "timestamp",
]

Point = tuple[float, float, float]


class JobParameters(BaseModel):
    """The job's parameters (the fields of ``JobRequest`` but the sections' file)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    machine: str = Field("grbl-router", description="shipped machine name (GET /machines)")
    cutter: str = Field("ball:6", description="ball:D, flat:D or bull:D:r; D the diameter, mm")
    scallop_mm: float = Field(0.005, description="scallop height between passes, mm")
    chord_tol_mm: float = Field(0.01, description="chord deviation along a pass, mm")
    fit_tol_mm: float = Field(0.01, description="surface fit tolerance, mm")
    method: Literal["streamline", "bspline"] = "streamline"
    axis_mode: Literal["3", "lead-tilt"] = Field("3", description="fixed axis or 5-axis")
    lead_deg: float = Field(10.0, description="lead angle, deg (lead-tilt only)")
    tilt_deg: float = Field(0.0, description="tilt angle, deg (lead-tilt only)")
    linking: Literal["auto", "zigzag", "oneway", "spiral"] = Field(
        "auto", description="auto: spiral round closed sections under lead-tilt, else zigzag")
    placement: Literal["auto", "flat", "upright", "none"] = "auto"
    base_mm: float = Field(5.0, description="height of the part's lowest point above the table, mm")
    dialect: str | None = Field(None, description="override the machine's G-code dialect")
    spindle_rpm: float = Field(12000.0, description="spindle speed, rev/min")
    closed: bool | None = Field(
        None, description="closed sections (true), open (false), or null: read from how "
        "the sections end")
    planning_options: dict[str, Any] = Field(
        default_factory=dict,
        description="more FinishingOptions fields (e.g. feed_mm_per_min, on_gouge, probe_t)")


class JobSubmission(JobParameters):
    """``POST /jobs``: the sections as JSON and the parameters beside them."""

    name: str = Field("blade", description="job name (the program's name)", max_length=64)
    sections: list[list[Point]] = Field(
        ..., description="sections hub to tip, each a list of [x, y, z] points (mm), the "
        "same count per section", min_length=1)


class JobForm(JobParameters):
    """``POST /jobs/upload``: the CSV file and the parameters as form fields."""

    file: UploadFile = Field(description="CSV section,x,y,z (mm), sections hub to tip")
    planning_options: Json[dict[str, Any]] = Field(  # type: ignore[assignment]
        default_factory=dict, description="a JSON object of more FinishingOptions fields")


class StreamView(BaseModel):
    """A request to stream a job's G-code to a target, with its live status while it runs.

    The live fields are null until the sender's first progress report, and after a restart
    of the service (they are kept in memory).
    """

    id: str
    job_id: str
    target: str
    state: Literal["queued", "running", "held", "done", "failed", "cancelled"] = Field(
        description="held: stopped by a feed hold, waiting for resume or cancel")
    created: datetime
    started: datetime | None
    finished: datetime | None
    result: dict[str, Any] | None = Field(None, description="the streamer's report")
    error: str | None
    position_mm: dict[str, float] | None = Field(
        None, description="work position (the program's coordinates) {x, y, z[, a, b, c]}, "
        "mm (rotary axes deg), from the controller's latest status report")
    position_source: str | None = Field(
        None, description="report, or planned (the report was stale: the planned end of the "
        "last acknowledged line)")
    machine_position_mm: dict[str, float] | None = Field(
        None, description="machine position (MPos) of the latest status report")
    controller_state: str | None = Field(None, description="Idle, Run, Hold, Alarm, ...")
    line: int | None = Field(None, description="program lines acknowledged")
    source_line: int | None = Field(None, description="program line number last acknowledged")
    total_lines: int | None = Field(None, description="program lines to send")
    percent: float | None = None
    eta_s: float | None = Field(None, description="time left at the rate so far, s")
    elapsed_s: float | None = None
    alarm: str | None = Field(None, description="the controller's alarm, if one stopped it")
    revision: int | None = Field(
        None, description="changes of the live status so far: of two views of this stream, "
        "the one with the higher revision is the newer (an answer to hold can arrive after "
        "the event that says the stream is held)")


class JobView(BaseModel):
    """A job's status: state, progress by stage, error, and where its results are."""

    id: str
    name: str
    state: Literal["queued", "running", "done", "failed", "cancelled"]
    created: datetime
    started: datetime | None
    finished: datetime | None
    attempts: int = Field(description="runs started (more than one after a restart)")
    stops: int = Field(0, description="runs ended by a graceful stop of the service and "
                       "re-queued (not counted as failed attempts)")
    stage: str | None = Field(description="stage of the last progress report")
    progress: dict[str, float] = Field(description="fraction done (0 to 1) by stage")
    error: str | None = Field(description="why the job failed")
    error_type: str | None
    verdict: Literal["pass", "exceeds"] | None = Field(
        None, description="a done job's program as the verifier measured it against the "
        "request: pass, or exceeds (the gouge beyond chord_tol_mm or the scallop beyond "
        "scallop_mm; its files are kept for inspection)")
    summary: str | None = Field(None, description="the verdict in one line, with the figures")
    parameters: dict[str, Any]
    links: dict[str, str] = Field(description="the job's resources, by name")
    streams: list[StreamView] = Field(default_factory=list)


class JobList(BaseModel):
    """Jobs, newest first, and the number of jobs in each state."""

    jobs: list[JobView]
    counts: dict[str, int]


class StreamRequest(BaseModel):
    """``POST /jobs/{id}/stream``."""

    model_config = ConfigDict(extra="forbid")

    target: str = Field("simulator", description="a configured target name (GET /health)")


class Health(BaseModel):
    """The service at a glance."""

    status: Literal["ok"]
    executor: str
    workers: int
    running: int
    counts: dict[str, int]
    stream_targets: list[str]
    streaming: str = Field(description="'available', or why streaming is not")
    max_upload_bytes: int


class PreviewSurface(BaseModel):
    """The fitted surface sampled on a ``rows`` x ``cols`` parameter grid."""

    rows: int
    cols: int
    points: list[float] = Field(description="flat [x, y, z, ...] row by row, mm")
    closed: bool = Field(description="rows wrap round (closed sections)")


class PreviewSegment(BaseModel):
    """A run of moves of one kind, decimated for display."""

    kind: Literal["cut", "link", "rapid"]
    pass_: int | None = Field(None, alias="pass", description="finishing pass (cut only)")
    points: list[float] = Field(description="flat [x, y, z, ...], mm")
    tool_axis: list[float] | None = Field(
        None, description="5-axis only: flat [i, j, k, ...], parallel to points")

    model_config = ConfigDict(populate_by_name=True)


class Preview(BaseModel):
    """``GET /jobs/{id}/preview``: what the 3-D view draws (display only, never the G-code)."""

    surface: PreviewSurface
    segments: list[PreviewSegment]
    bounds_mm: dict[str, list[float]] = Field(description="min and max [x, y, z] of it all")
    points: int = Field(description="toolpath points in the segments")
    source_points: int = Field(description="points of the full toolpath")
    five_axis: bool
    max_deviation_mm: float = Field(description="largest distance of a dropped point from "
                                    "the decimated polyline")


class ErrorBody(BaseModel):
    """A refused request: ``detail`` says what and names the field."""

    detail: str | list[dict[str, Any]]


def timestamp(value: float | None) -> datetime | None:
    """Unix time (s) as an aware UTC datetime."""
    return None if value is None else datetime.fromtimestamp(value, tz=UTC)
