r"""Resume a job from line N: restore the modal state, retract, move over, plunge, continue.

A job stopped by an error, an alarm, a cancel, a lost link or a crash is resumed only when
the user asks (``--resume-from N``); nothing here runs by itself. Two pieces:

:func:`plan_resume`
    The preamble that puts the controller where line N expects it, in this order:
    a known baseline (``G21 G90 G94 G17`` and the program's work system), a retract to the
    clearance height (never downward: the current height when that is higher), the move
    over at that height to the start point of line N (the programmed position before it,
    with any rotary axes the dialect has), spindle and coolant as they were, a rapid to
    ``APPROACH_MM`` above the start and a feed plunge to it, then the modal state in force
    at line N (plane, units, distance mode, feed mode, motion mode and feed). The clearance
    height defaults to the highest Z the program itself reaches.

    Resuming *at an arc* is refused (:class:`~gcode.senders.errors.ResumeError`): an arc
    line's geometry hangs on its start point and on the arcs around it (arc-fitted
    toolpaths are chains of tangent arcs), and a straight plunge into the middle of such a
    chain is not what the program cut. The error names the nearest earlier line that is
    not an arc (:func:`safe_resume_line`), the line the automatic suggestions use.

:func:`locate_resume_line`
    After a stop, the first line not known to have run: the controller's position (read
    after it stopped) is matched against the program's path over a window of lines that
    may not have run. The scan goes forward and takes the first line whose path passes
    through the position: if the position is that line's end the line ran (resume after
    it), otherwise it was cut short (resume at it). Picking the *first* match can only
    repeat lines (an air cut in absolute mode), never skip one.

Examples
--------
>>> from gcode.senders.job import Job
>>> job = Job.from_text("G21 G90\nG0 Z5\nG0 X0 Y0\nM3 S1000\nG1 Z-1 F200\nG1 X10 F600\nG1 Y10\n")
>>> plan = plan_resume(job, 7)
>>> [ln.text for ln in plan.preamble]
['G21G90G94G17G54', 'G0Z5', 'G0X10Y0', 'M3S1000', 'M9', 'G0Z0', 'G1Z-1F200', 'G1F600']
>>> locate_resume_line(job, (10.0, 4.0, -1.0), first_line=5, last_line=7)
7
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gcode.blockparser import BlockParser
from gcode.dialects import GENERIC, Dialect
from gcode.errors import GCodeError
from gcode.interpreter import KIND_RAPID, Segments, interpret
from gcode.modal import ModalState
from gcode.numbers import MM_PER_INCH, format_number
from gcode.parser import parse
from gcode.program import (
    Arc,
    DistanceMode,
    FeedMode,
    Plane,
    SpindleDirection,
    Units,
)
from gcode.senders.errors import ResumeError
from gcode.senders.job import Job, JobLine

__all__ = [
    "APPROACH_MM",
    "DEFAULT_PLUNGE_FEED_MM_PER_MIN",
    "POSITION_TOLERANCE_MM",
    "ResumePlan",
    "locate_resume_line",
    "modal_state_before",
    "plan_resume",
    "planned_line_ends",
    "safe_resume_line",
]

#: Rapid down to this height above the start point before the feed plunge, mm.
APPROACH_MM = 1.0
#: Plunge feed when the program's feed at line N cannot be used (G93 or undefined), mm/min.
DEFAULT_PLUNGE_FEED_MM_PER_MIN = 100.0
#: A controller position within this distance of the path is on it, mm (status reports
#: carry 3 decimals; our programs too).
POSITION_TOLERANCE_MM = 0.002

_AXIS_LETTERS = "XYZABC"


@dataclass(frozen=True)
class ResumePlan:
    """How to resume at one line.

    Attributes
    ----------
    line : int
        First source line executed after the preamble.
    preamble : tuple of JobLine
        Lines to send first (source number 0).
    state : ModalState
        The modal state in force at ``line`` (program values: mm, degrees, mm/min).
    clearance_z_mm : float
        The retract height used, work coordinates, mm.
    notes : tuple of str
        Things the operator must know (a tool that must be in the spindle, ...).
    """

    line: int
    preamble: tuple[JobLine, ...]
    state: ModalState
    clearance_z_mm: float
    notes: tuple[str, ...] = ()


def _num(v: float) -> str:
    return format_number(v, 3)


def _source_lines(job: Job) -> list[str]:
    return job.source.splitlines()


def _blocks_of_line(job: Job, number: int, state: ModalState, dialect: Dialect) -> list:
    lines = _source_lines(job)
    if not 1 <= number <= len(lines):
        return []
    bp = BlockParser(dialect, state=state)
    try:
        return bp.parse_line(lines[number - 1], number)
    except GCodeError:
        return []


def modal_state_before(job: Job, line: int, dialect: Dialect = GENERIC) -> ModalState:
    """The modal state in force when source line ``line`` starts.

    Parameters
    ----------
    job : Job
        The program.
    line : int
        1-based source line.
    dialect : Dialect
        Dialect to parse with.

    Returns
    -------
    ModalState
        Units, plane, distance and feed modes, feed, spindle, coolant, tool and the
        programmed position (work coordinates, mm and degrees) before ``line``.

    Raises
    ------
    ResumeError
        When a line before it does not parse (naming it).
    """
    head = "\n".join(_source_lines(job)[: max(line - 1, 0)])
    try:
        program = parse(head + "\n", dialect)
    except GCodeError as err:
        raise ResumeError(
            f"cannot restore the modal state for line {line}: {err}", line=err.line, text=err.text
        ) from None
    st = ModalState(units=program.units)
    for block in program.blocks:
        st = st.apply(block)
    return st


def _is_arc_line(job: Job, number: int, dialect: Dialect) -> bool:
    state = modal_state_before(job, number, dialect)
    return any(isinstance(b, Arc) for b in _blocks_of_line(job, number, state, dialect))


def safe_resume_line(job: Job, line: int, dialect: Dialect = GENERIC) -> int:
    """``line``, or the nearest earlier job line that is not an arc.

    Parameters
    ----------
    job : Job
        The program.
    line : int
        Candidate source line.
    dialect : Dialect
        Dialect to parse with.

    Returns
    -------
    int
        A source line at which :func:`plan_resume` does not refuse for an arc.
    """
    i = job.index_of(line)
    if i >= len(job.lines):
        return line
    while i > 0 and _is_arc_line(job, job.lines[i].number, dialect):
        i -= 1
    return job.lines[i].number


def _program_segments(job: Job, dialect: Dialect) -> Segments:
    return interpret(parse(job.source, dialect))


def planned_line_ends(job: Job, dialect: Dialect = GENERIC) -> tuple[np.ndarray, np.ndarray]:
    """Where each source line's motion ends, in program (work) coordinates.

    Returns
    -------
    (ndarray of int, ndarray of float)
        Source line numbers of the program's motion segments, ascending, and the
        ``(n, 6)`` end points (X Y Z mm, A B C degrees) of each line's last segment;
        empty arrays for a program that cannot be read. The planned position after a
        line ``L`` is the end of the last row with a line number ``<= L``.
    """
    try:
        seg = _program_segments(job, dialect)
    except GCodeError:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 6))
    lines = np.asarray(seg.line, dtype=np.int64)
    if lines.shape[0] == 0:
        return lines, np.zeros((0, 6))
    last = np.flatnonzero(np.append(lines[1:] != lines[:-1], True))
    return lines[last], np.asarray(seg.end, dtype=float)[last]


def _highest_z(job: Job, dialect: Dialect) -> float | None:
    seg = _program_segments(job, dialect)
    if len(seg) == 0:
        return None
    return float(max(seg.start[:, 2].max(), seg.end[:, 2].max()))


def _plunge_feed(job: Job, line: int, state: ModalState, dialect: Dialect) -> float:
    """Feed of the program's last downward feed move before ``line`` (G94), mm/min."""
    seg = _program_segments(job, dialect)
    down = np.flatnonzero(
        (seg.line < line)
        & (seg.kind != KIND_RAPID)
        & ~seg.inverse_time
        & (seg.end[:, 2] < seg.start[:, 2])
    )
    if down.shape[0]:
        return float(seg.feed[down[-1]])
    if state.feed_mode is FeedMode.UNITS_PER_MINUTE and state.feed:
        return state.feed
    return DEFAULT_PLUNGE_FEED_MM_PER_MIN


def plan_resume(
    job: Job,
    line: int,
    *,
    dialect: Dialect = GENERIC,
    clearance_z_mm: float | None = None,
    current_z_mm: float | None = None,
    plunge_feed_mm_per_min: float | None = None,
) -> ResumePlan:
    """Plan the preamble that resumes ``job`` at source line ``line``.

    Parameters
    ----------
    job : Job
        The program.
    line : int
        1-based source line to resume at (the first line executed after the preamble).
    dialect : Dialect
        The controller's dialect (which axis words may be written, G93).
    clearance_z_mm : float or None
        Retract height in work coordinates, mm; the highest Z of the program when None.
    current_z_mm : float or None
        The tool's current height in work coordinates, mm, if known: the retract never
        goes below it.
    plunge_feed_mm_per_min : float or None
        Feed of the final plunge, mm/min; when None, the feed of the program's last
        downward feed move before ``line``, else its feed at ``line`` (G94), else
        :data:`DEFAULT_PLUNGE_FEED_MM_PER_MIN`.

    Returns
    -------
    ResumePlan
        The preamble and what it restores.

    Raises
    ------
    ResumeError
        When ``line`` is not in the program, is an arc (mid-arc), or no clearance height
        is known.
    """
    if not job.lines:
        raise ResumeError("the program has no lines to resume")
    if line < 1 or line > job.last_line_number:
        raise ResumeError(
            f"cannot resume at line {line}: the program's lines to send are "
            f"{job.lines[0].number}-{job.last_line_number}",
            line=line,
        )
    first = job.lines[job.index_of(line)]
    if first.number != line:
        line = first.number  # a blank or comment line: start at the next real one
    state = modal_state_before(job, line, dialect)
    blocks = _blocks_of_line(job, line, state, dialect)
    if any(isinstance(b, Arc) for b in blocks):
        safe = safe_resume_line(job, line, dialect)
        raise ResumeError(
            f"line {line} is an arc ({first.text!r}): resuming mid-arc is refused; "
            f"resume from line {safe}, the nearest earlier line that is not an arc",
            line=line,
            text=first.text,
            resume_line=safe,
        )
    if clearance_z_mm is None:
        clearance_z_mm = _highest_z(job, dialect)
        if clearance_z_mm is None:
            raise ResumeError("the program has no motion: give a clearance height", line=line)
    x, y, z = state.position[:3]
    retract = clearance_z_mm if current_z_mm is None else max(clearance_z_mm, current_z_mm)
    if retract < z:
        raise ResumeError(
            f"the clearance height {retract:g} mm is below the start of line {line} "
            f"(Z {z:g} mm): give a higher clearance",
            line=line,
        )
    wcs = 53 + state.wcs
    out: list[str] = [f"G21G90G94G17G{wcs}", f"G0Z{_num(retract)}"]
    over = f"G0X{_num(x)}Y{_num(y)}"
    for k in range(3, 6):
        name = "xyzabc"[k]
        if name in dialect.axes and state.position[k] != 0.0:
            over += f"{_AXIS_LETTERS[k]}{_num(state.position[k])}"
    out.append(over)
    notes: list[str] = []
    if state.spindle is SpindleDirection.OFF:
        out.append("M5")
    else:
        out.append(f"M{int(state.spindle)}S{_num(state.rpm)}")
    if state.mist:
        out.append("M7")
    if state.flood:
        out.append("M8")
    if not state.mist and not state.flood:
        out.append("M9")
    if state.tool:
        notes.append(
            f"tool T{state.tool} must be in the spindle (the program changed to it "
            f"before line {line})"
        )
    approach = z + APPROACH_MM
    if approach < retract:
        out.append(f"G0Z{_num(approach)}")
    if plunge_feed_mm_per_min is None:
        plunge_feed_mm_per_min = _plunge_feed(job, line, state, dialect)
    if not (plunge_feed_mm_per_min and plunge_feed_mm_per_min > 0.0):
        raise ResumeError(f"plunge feed must be > 0 mm/min, got {plunge_feed_mm_per_min!r}")
    out.append(f"G1Z{_num(z)}F{_num(plunge_feed_mm_per_min)}")
    # the modal state in force at `line`
    if state.plane is not Plane.XY:
        out.append(f"G{int(state.plane)}")
    if state.units is Units.INCH:
        out.append("G20")
    if state.distance is DistanceMode.INCREMENTAL:
        out.append("G91")
    if state.feed_mode is FeedMode.INVERSE_TIME:
        out.append("G93")
    motion = f"G{int(state.motion)}"
    if state.feed_mode is FeedMode.UNITS_PER_MINUTE and state.feed is not None:
        f = state.feed / MM_PER_INCH if state.units is Units.INCH else state.feed
        motion += f"F{_num(f)}"
    out.append(motion)
    preamble = tuple(JobLine.of(0, t) for t in out)
    return ResumePlan(line, preamble, state, float(retract), tuple(notes))


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from ``p`` to every segment ``a[i]-b[i]`` (rows), mm."""
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.where(dd > 0.0, np.einsum("ij,ij->i", p[None, :] - a, d) / np.where(dd > 0, dd, 1), 0)
    t = np.clip(t, 0.0, 1.0)
    q = a + d * t[:, None]
    return np.linalg.norm(q - p[None, :], axis=1)


def locate_resume_line(
    job: Job,
    position_mm: Sequence[float],
    *,
    first_line: int,
    last_line: int,
    dialect: Dialect = GENERIC,
    tolerance_mm: float = POSITION_TOLERANCE_MM,
) -> int | None:
    """The first line of ``first_line..last_line`` that has not (completely) run.

    Parameters
    ----------
    job : Job
        The program.
    position_mm : sequence of float
        Where the controller stopped, X Y Z in work coordinates (machine position minus
        the work offset), mm.
    first_line, last_line : int
        Source lines that may not have run (every line before ``first_line`` has).
    dialect : Dialect
        Dialect to parse with.
    tolerance_mm : float
        How close to the path counts as on it, mm.

    Returns
    -------
    int or None
        The source line to resume at (``job.last_line_number + 1`` when everything ran);
        None when the position is on no path of the window (it cannot be known).
    """
    seg = _program_segments(job, dialect).linearize(tolerance_mm / 4.0)
    rows = np.flatnonzero((seg.line >= first_line) & (seg.line <= last_line))
    if rows.shape[0] == 0:
        return None
    p = np.asarray(position_mm, dtype=np.float64)[:3]
    a = seg.start[rows, :3]
    b = seg.end[rows, :3]
    dist = _point_segment_distance(p, a, b)
    hits = np.flatnonzero(dist <= tolerance_mm)
    if hits.shape[0] == 0:
        return None
    r = int(hits[0])
    number = int(seg.line[rows[r]])
    last_row_of_line = r + 1 >= rows.shape[0] or int(seg.line[rows[r + 1]]) != number
    at_end = math.dist(p.tolist(), b[r].tolist()) <= tolerance_mm
    if at_end and last_row_of_line:
        nxt = job.index_of(number + 1)
        return job.lines[nxt].number if nxt < len(job.lines) else job.last_line_number + 1
    return number
