r"""Whole-program pre-flight check: a report of every issue, not the first exception.

:func:`check_program` reads a G-code file (or emits a ``Program`` the way the dialect
would) and reports, each with its 1-based line:

* blocks the controller would reject: malformed text, words or commands the dialect or
  the machine does not have (A/B/C or G93 on GRBL, a B word on an A/C machine), lines
  over the dialect's length limit, feed moves with no feed (or no F in G93) - the
  parser's errors, each bad block skipped as a controller would skip it;
* soft-limit (travel) violations of the linear axes and travel violations of limited
  rotary axes, on the interpreter's motion with arcs followed within
  :data:`CHECK_CHORD_TOLERANCE_MM` (arcs bulging past a limit are found);
* feed moves that ask an axis for more than its maximum rate (a warning: controllers
  slow down, so the program runs but takes longer than planned);
* lines longer than the dialect's limit only with their comments and spaces (a warning:
  the controller strips them, but a sender that forwards comments counts them in its
  receive buffer, and one longer than the buffer can never be sent by character counting).

Positions are machine coordinates: program values plus the work offset, by default the
machine's work origin in every work system (:mod:`gcode.machine_frame`).

Examples
--------
>>> from machines import load_machine
>>> from gcode.check import check_text
>>> issues = check_text("G21 G90\nG0 X500 Y0\nG1 X0 A10\n", load_machine("grbl-router"))
>>> [(i.line, i.code.value) for i in issues]
[(2, 'soft-limit'), (3, 'unsupported')]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from enum import StrEnum
from pathlib import Path

import numpy as np
import numpy.typing as npt

from gcode.dialects import Dialect, dialect_by_name
from gcode.errors import DialectError, ErrorCode, GCodeError
from gcode.interpreter import KIND_RAPID, Segments, interpret
from gcode.machine_frame import joint_columns, machine_axis_names, work_offsets
from gcode.parser import parse_with_errors
from gcode.program import AXES, Program
from gcode.writer import Writer
from machines import Machine, Wrap
from machines.limits import RATE_TOLERANCE, TRAVEL_TOLERANCE

__all__ = [
    "CHECK_CHORD_TOLERANCE_MM",
    "Issue",
    "IssueCode",
    "Severity",
    "check_file",
    "check_program",
    "check_text",
    "machine_dialect",
]

#: Arcs are followed by chords this close to them when checking travel and rates (mm):
#: 0.01 mm finds any arc bulging past a limit by more than that, at a cost of a few
#: hundred chords per full circle of 100 mm radius.
CHECK_CHORD_TOLERANCE_MM = 0.01


class Severity(StrEnum):
    """Whether the controller would refuse or fail (error) or run it differently (warning)."""

    ERROR = "error"
    WARNING = "warning"


class IssueCode(StrEnum):
    """Kinds of issues (stable names, used in reports and by the senders)."""

    SYNTAX = "syntax"  #: a malformed or invalid block (the parser's error code is kept)
    UNSUPPORTED = "unsupported"  #: a word or command the controller or machine lacks
    LINE_TOO_LONG = "line-too-long"  #: longer than the controller's line buffer
    MISSING_FEED = "missing-feed"  #: a feed move with no feed rate (or no F in G93)
    SOFT_LIMIT = "soft-limit"  #: a linear axis beyond its travel
    ROTARY_TRAVEL = "rotary-travel"  #: a limited rotary axis beyond its travel
    FEED_ABOVE_MAX_RATE = "feed-above-max-rate"  #: an axis asked beyond its max rate


@dataclass(frozen=True, slots=True)
class Issue:
    """One problem found in a program.

    Attributes
    ----------
    line : int or None
        1-based line of the G-code text (of the first offending line for a run).
    code : IssueCode
        What kind of problem.
    message : str
        Detail, naming the axis, value and limit where there is one.
    severity : Severity
        Error (the controller refuses or alarms) or warning.
    error_code : ErrorCode or None
        The parser's numbered code for blocks it rejects.
    """

    line: int | None
    code: IssueCode
    message: str
    severity: Severity = Severity.ERROR
    error_code: ErrorCode | None = None

    def __str__(self) -> str:
        where = f"line {self.line}: " if self.line is not None else ""
        return f"{where}{self.severity.value} {self.code.value}: {self.message}"


_CODE_OF_ERROR = {
    ErrorCode.LINE_OVERFLOW: IssueCode.LINE_TOO_LONG,
    ErrorCode.UNDEFINED_FEED_RATE: IssueCode.MISSING_FEED,
    ErrorCode.UNSUPPORTED_COMMAND: IssueCode.UNSUPPORTED,
}


def _issue_of_error(err: GCodeError) -> Issue:
    code = _CODE_OF_ERROR.get(err.code, IssueCode.SYNTAX)
    if isinstance(err, DialectError):
        code = IssueCode.UNSUPPORTED
    return Issue(err.line, code, f"error {int(err.code)} ({err.code.name}): {err.message}",
                 error_code=err.code)  # fmt: skip


def _runs(mask: npt.NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Index ranges ``[first, last]`` of the runs of True in ``mask``."""
    m = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(m))
    return list(zip(edges[::2].tolist(), (edges[1::2] - 1).tolist(), strict=True))


def _line_span(lines: npt.NDArray[np.int64], first: int, last: int) -> str:
    a, b = int(lines[first]), int(lines[last])
    return "" if a == b else f" (lines {a}-{b})"


def _long_line_issues(text: str, dialect: Dialect, flagged: set[int]) -> list[Issue]:
    """Lines longer than ``dialect.max_line_length`` with comments and spaces (warnings).

    Lines in ``flagged`` (already over the limit without them) are left to the parser's
    error.
    """
    limit = dialect.max_line_length
    if limit is None or not text:
        return []
    data = np.frombuffer(text.encode("utf-8", "replace"), dtype=np.uint8)
    ends = np.flatnonzero(data == 10)
    if data[-1] != 10:
        ends = np.append(ends, data.shape[0])
    starts = np.concatenate(([0], ends[:-1] + 1))
    long_rows = np.flatnonzero(ends - starts > limit)
    issues = []
    for row in long_rows.tolist():
        line = row + 1
        raw = bytes(data[starts[row] : ends[row]]).decode("utf-8", "replace").rstrip()
        length = len(raw)
        if line in flagged or length <= limit:
            continue
        issues.append(
            Issue(
                line,
                IssueCode.LINE_TOO_LONG,
                f"{length} characters with comments and spaces, over the {dialect.name} "
                f"limit of {limit}: a sender that forwards comments counts them in the "
                f"controller's receive buffer ({raw[:30]!r}...)",
                Severity.WARNING,
            )
        )
    return issues


def _travel_issues(machine: Machine, seg: Segments) -> list[Issue]:
    joints = joint_columns(machine, seg.end)
    issues = []
    for col, axis in enumerate(machine.axes):
        if not axis.is_limited:
            continue
        v = joints[:, col]
        code = IssueCode.ROTARY_TRAVEL if axis.is_rotary else IssueCode.SOFT_LIMIT
        for side, bad, limit in (
            ("minimum", v < axis.min - TRAVEL_TOLERANCE, axis.min),
            ("maximum", v > axis.max + TRAVEL_TOLERANCE, axis.max),
        ):
            for first, last in _runs(bad):
                run = v[first : last + 1]
                worst = float(run.min() if side == "minimum" else run.max())
                issues.append(
                    Issue(
                        int(seg.line[first]),
                        code,
                        f"axis {axis.letter} reaches {worst:.6g} {axis.unit} in machine "
                        f"coordinates, beyond its {side} {limit:.6g} {axis.unit}"
                        f"{_line_span(seg.line, first, last)}",
                    )
                )
    return issues


def _rate_issues(machine: Machine, seg: Segments) -> list[Issue]:
    feed_rows = np.flatnonzero(seg.kind != KIND_RAPID)
    if feed_rows.shape[0] == 0:
        return []
    seconds = seg.durations()[feed_rows]
    step = joint_columns(machine, seg.end[feed_rows]) - joint_columns(
        machine, seg.start[feed_rows]
    )
    issues = []
    lines = seg.line[feed_rows]
    for col, axis in enumerate(machine.axes):
        d = np.abs(step[:, col])
        if axis.wrap is Wrap.SHORTEST:  # the controller goes the short way round
            d = np.minimum(d % 360.0, 360.0 - d % 360.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = np.where(d > 0.0, 60.0 * d / seconds, 0.0)
        for first, last in _runs(rate > axis.max_rate * (1.0 + RATE_TOLERANCE)):
            worst = float(rate[first : last + 1].max())
            issues.append(
                Issue(
                    int(lines[first]),
                    IssueCode.FEED_ABOVE_MAX_RATE,
                    f"the feed asks axis {axis.letter} for {worst:.6g} {axis.unit}/min, above "
                    f"its maximum rate {axis.max_rate:.6g} {axis.unit}/min; the controller "
                    f"will slow down{_line_span(lines, first, last)}",
                    Severity.WARNING,
                )
            )
    return issues


def machine_dialect(machine: Machine, dialect: Dialect) -> Dialect:
    """The dialect restricted to the axes the machine has (for parsing its programs).

    Parameters
    ----------
    machine : Machine
        The machine.
    dialect : Dialect
        What its controller accepts.

    Returns
    -------
    Dialect
        ``dialect`` without axis words the machine lacks, named ``"<dialect> on <machine>"``.
    """
    names = set(machine_axis_names(machine))
    axes = tuple(a for a in dialect.axes if a in names)
    if axes == dialect.axes:
        return dialect
    return replace(dialect, axes=axes, name=f"{dialect.name} on {machine.name}")


class _StringWriter(Writer):
    def __init__(self) -> None:
        self.parts: list[str] = []

    def write(self, text: str) -> None:
        self.parts.append(text)


def _program_text(program: Program, dialect: Dialect) -> tuple[str, Issue | None]:
    """Text the dialect would get, written with every check relaxed so the parse finds them."""
    relaxed = replace(
        dialect, axes=AXES, max_line_length=None, arcs=True, inverse_time=True, tool_change=True
    )
    from gcode.emitter import emit  # a program object only: checking a file needs no emitter

    out = _StringWriter()
    try:
        emit(program, relaxed, out)
    except GCodeError as err:
        return "".join(out.parts), _issue_of_error(err)
    return "".join(out.parts), None


def check_text(
    text: str,
    machine: Machine,
    dialect: Dialect | None = None,
    *,
    offsets: Mapping[int, Sequence[float]] | None = None,
) -> list[Issue]:
    """Check G-code text for a machine; see :func:`check_program`.

    Parameters
    ----------
    text : str
        The program.
    machine : Machine
        The machine that will run it.
    dialect : Dialect or None
        Its controller's dialect (``machine.dialect`` when None).
    offsets : mapping of int to sequence of float, optional
        Work offsets G54-G59, X Y Z A B C (mm, degrees); the machine's work origin in
        every system when None.

    Returns
    -------
    list of Issue
        Sorted by line.
    """
    return _check_parsed(text, machine, dialect, offsets)[0]


def _check_parsed(
    text: str,
    machine: Machine,
    dialect: Dialect | None,
    offsets: Mapping[int, Sequence[float]] | None,
) -> tuple[list[Issue], Program, bool]:
    """:func:`check_text`'s issues, the program parsed, and whether every block parsed."""
    d = dialect if dialect is not None else dialect_by_name(machine.dialect)
    program, errors = parse_with_errors(text, machine_dialect(machine, d))
    issues = [_issue_of_error(e) for e in errors]
    flagged = {i.line for i in issues if i.code is IssueCode.LINE_TOO_LONG}
    issues += _long_line_issues(text, d, flagged)
    try:
        seg = interpret(program, work_offsets=offsets or work_offsets(machine))
        seg = seg.linearize(CHECK_CHORD_TOLERANCE_MM)
    except GCodeError as err:  # pragma: no cover - the parser rejects such arcs first
        issues.append(_issue_of_error(err))
    else:
        issues += _travel_issues(machine, seg) + _rate_issues(machine, seg)
    order = {c: n for n, c in enumerate(IssueCode)}
    issues.sort(key=lambda i: (i.line if i.line is not None else 0, order[i.code]))
    return issues, program, not errors


def check_file(
    path: str | Path,
    machine: Machine,
    dialect: Dialect | None = None,
    *,
    offsets: Mapping[int, Sequence[float]] | None = None,
) -> tuple[list[Issue], Program | None]:
    """Check a G-code file (:func:`check_program`), and hand on the program it parsed.

    The check parses the file strictly for the machine's dialect, as
    :func:`gcode.parser.parse_file` with :func:`machine_dialect` does: where every block
    parsed, that program is the very one such a parse returns (a job's verification
    replays it instead of reading the file twice); where a block failed, None (the strict
    parse would stop there).

    Parameters
    ----------
    path : str or Path
        The G-code file.
    machine, dialect, offsets
        As for :func:`check_program`.

    Returns
    -------
    issues : list of Issue
        As :func:`check_program` returns them.
    program : Program or None
        The parsed program, blocks in execution order, lines of the file; None when a
        block failed to parse.

    Raises
    ------
    OSError
        When the file cannot be read.
    """
    text = Path(path).read_text(encoding="utf-8", errors="replace")
    issues, program, parsed = _check_parsed(text, machine, dialect, offsets)
    return issues, program if parsed else None


def check_program(
    program_or_path: Program | str | Path,
    machine: Machine,
    dialect: Dialect | None = None,
    *,
    offsets: Mapping[int, Sequence[float]] | None = None,
) -> list[Issue]:
    """Check a program against a machine and its controller: a report of every issue.

    Parameters
    ----------
    program_or_path : Program, str or Path
        A G-code file, or a ``Program`` (checked as the text the dialect would get, so
        line numbers are lines of that text).
    machine : Machine
        The machine that will run it (travel, rates, axes).
    dialect : Dialect or None
        Its controller's dialect (``machine.dialect`` when None).
    offsets : mapping of int to sequence of float, optional
        Work offsets G54-G59 (mm, degrees); the machine's work origin when None.

    Returns
    -------
    list of Issue
        Every issue, sorted by line; empty when the program is fine. Errors have
        ``severity`` ERROR, rate-limit findings WARNING.

    Raises
    ------
    OSError
        When the file cannot be read.
    """
    d = dialect if dialect is not None else dialect_by_name(machine.dialect)
    if isinstance(program_or_path, Program):
        text, emit_issue = _program_text(program_or_path, d)
        issues = check_text(text, machine, d, offsets=offsets)
        return issues if emit_issue is None else [*issues, emit_issue]
    return check_file(program_or_path, machine, d, offsets=offsets)[0]
