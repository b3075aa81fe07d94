"""Checking a submission with the library's own rules before it is queued.

A request the library would refuse is refused at once (422) with the library's message,
not queued to fail later: the machine by shipped name (never a path on the server), the
cutter spec, the dialect, the tolerances (``JobRequest.validated``), the finishing options
(``FinishingOptions`` and ``check_cutter``), the spindle speed (``PostOptions``) and the
sections (``read_sections`` / ``as_sections``, with the uploaded file's name and line in the
message).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Final

import numpy as np

from gcode.dialects import dialect_by_name
from gcode.errors import GCodeError
from gcode.post import PostOptions
from machines.errors import MachineError
from machines.machine import list_machines, load_machine
from toolpath import Sections, as_sections, read_sections
from toolpath.errors import DataFileError, ToolpathError
from toolpath.planning.cutters import parse_cutter
from toolpath.planning.options import FinishingOptions

from ..pipeline import JobRequest
from .schemas import JobParameters

__all__ = ["SubmissionError", "check_parameters", "check_sections_file", "safe_name",
           "write_sections_csv"]

#: Options the service sets itself (``progress``) or that a client must not raise.
_RESERVED_OPTIONS: Final = frozenset({"progress"})
_LIBRARY_ERRORS: Final = (ToolpathError, MachineError, GCodeError)


class SubmissionError(Exception):
    """A refused submission: ``field`` it is about, ``message`` from the library.

    Answered as 422 in FastAPI's validation-error shape, ``loc`` naming the field.
    """

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field
        self.message = message


def _field_named(message: str, fields: Sequence[str], default: str) -> str:
    """The first of ``fields`` the library's message names (it names the parameter)."""
    hits = [(message.find(f), f) for f in fields if re.search(rf"\b{re.escape(f)}\b", message)]
    return min(hits)[1] if hits else default


def check_parameters(params: JobParameters) -> dict[str, Any]:
    """Check the parameters with the library; returns the ``JobRequest`` keyword arguments.

    Raises
    ------
    SubmissionError
        Naming the field and quoting the library's message.
    """
    values = params.model_dump(include=set(JobParameters.model_fields))
    machines = list_machines()
    if params.machine not in machines:
        raise SubmissionError("machine", f"unknown machine {params.machine!r}; the service "
                              f"offers {', '.join(machines)}")
    try:
        load_machine(params.machine)
    except MachineError as exc:
        raise SubmissionError("machine", str(exc)) from None
    try:
        cutter = parse_cutter(params.cutter)
    except ToolpathError as exc:
        raise SubmissionError("cutter", str(exc)) from None
    if params.dialect is not None:
        try:
            dialect_by_name(params.dialect)
        except (GCodeError, LookupError, ValueError) as exc:
            raise SubmissionError("dialect", str(exc)) from None
    try:
        PostOptions(spindle_rpm=params.spindle_rpm)
    except ValueError as exc:
        raise SubmissionError("spindle_rpm", str(exc)) from None
    reserved = sorted(_RESERVED_OPTIONS & set(params.planning_options))
    if reserved:
        raise SubmissionError("planning_options",
                              f"option(s) {reserved} are set by the service, not by a request")
    try:
        JobRequest(sections_path=Path("-"), **values).validated()
        known = set(FinishingOptions.__dataclass_fields__) - {
            "scallop_mm", "chord_tol_mm", "axis_mode", "lead_deg", "tilt_deg", "linking"}
        unknown = sorted(set(params.planning_options) - known)
        if unknown:
            raise SubmissionError("planning_options", f"unknown option(s) {unknown}; known: "
                                  f"{sorted(known - _RESERVED_OPTIONS)}")
        five_axis = params.axis_mode != "3"
        options = FinishingOptions(
            scallop_mm=params.scallop_mm, chord_tol_mm=params.chord_tol_mm,
            axis_mode=params.axis_mode, lead_deg=params.lead_deg if five_axis else 0.0,
            tilt_deg=params.tilt_deg if five_axis else 0.0, linking=params.linking,
            **params.planning_options)
        options.check_cutter(cutter)
    except (*_LIBRARY_ERRORS, TypeError) as exc:
        fields = [*JobParameters.model_fields, *params.planning_options]
        field = _field_named(str(exc), fields, "planning_options")
        if field in params.planning_options:
            field = f"planning_options.{field}"
        raise SubmissionError(field, str(exc)) from None
    return values


def safe_name(name: str | None, default: str = "blade") -> str:
    """A file-name stem from a client's name: letters, digits, ``-``, ``_``, 1-40 chars."""
    stem = Path(name or "").stem
    cleaned = re.sub(r"[^A-Za-z0-9_-]+", "_", stem).strip("_")[:40]
    return cleaned or default


def check_sections_file(path: Path, shown_as: str) -> Sections:
    """Read and validate a sections CSV; errors show ``shown_as`` instead of the path.

    Raises
    ------
    SubmissionError
        ``file``: the reader's message with the file's line, or the sections' problem.
    """
    try:
        return as_sections(read_sections(path))
    except DataFileError as exc:
        raise SubmissionError("file", str(exc).replace(str(path), shown_as, 1)) from None
    except ToolpathError as exc:
        raise SubmissionError("file", f"{shown_as}: {exc}") from None


def write_sections_csv(sections: list[list[tuple[float, float, float]]], path: Path) -> Sections:
    """Validate JSON sections and write them as ``section,x,y,z`` CSV (exact floats).

    Raises
    ------
    SubmissionError
        ``sections``: the library's message (section and point indices).
    """
    try:
        checked = as_sections([np.asarray(s, dtype=float).reshape(-1, 3) for s in sections])
    except ToolpathError as exc:
        raise SubmissionError("sections", str(exc)) from None
    lines = ["section,x,y,z"]
    for j, section in enumerate(sections):
        lines += [f"{j},{x!r},{y!r},{z!r}" for x, y, z in section]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return checked
