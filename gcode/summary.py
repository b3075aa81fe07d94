r"""What a program does, in figures: blocks, moves, bounds, path lengths, estimated time.

:func:`summarize` interprets a program (:func:`gcode.interpreter.interpret`) and adds up
its motion. Without a machine, feed moves take their programmed time and rapids either a
given rapid rate or no time; with a machine, positions are machine coordinates (work
offsets from :mod:`gcode.machine_frame`), rapids run with every axis at its maximum rate,
and feed moves take the longer of their programmed time and the time the slowest axis
needs at its maximum rate (acceleration is ignored, so the estimate is a lower bound).

Examples
--------
>>> from gcode.parser import parse
>>> s = summarize(parse("G21\nG0 X0 Y0\nG1 X30 Y40 F600\nG4 P2\n"))
>>> s.blocks, s.feed_length_mm, s.time_s
(3, 50.0, 7.0)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gcode.interpreter import KIND_LINEAR, KIND_RAPID, interpret
from gcode.machine_frame import joint_columns, work_offsets
from gcode.numbers import format_number
from gcode.program import AXES, Program, Units
from machines import Machine
from machines.limits import min_segment_times

__all__ = ["CHORD_TOLERANCE_MM", "ProgramSummary", "summarize"]

#: Arcs are followed by chords this close (mm) for bounds and for timing against axis rates.
CHORD_TOLERANCE_MM = 0.01


@dataclass(frozen=True)
class ProgramSummary:
    """Figures of one program.

    Attributes
    ----------
    blocks : int
        IR blocks.
    units : Units
        Units of the text (G20/G21); every figure here is in mm.
    rapid_moves, linear_moves, arc_moves : int
        Moves by kind.
    lower, upper : ndarray, shape (6,)
        Smallest and largest X Y Z A B C reached, arcs included (mm, degrees); machine
        coordinates when a machine was given, program coordinates otherwise.
    used : ndarray of bool, shape (6,)
        Axes that move (their bounds differ).
    feed_length_mm, rapid_length_mm : float
        Tool-path length of feed moves (arcs along the arc) and of rapids, mm.
    time_s : float
        Estimated run time, s, dwells included.
    rapids_timed : bool
        Whether rapids are in ``time_s`` (a machine or a rapid rate was given).
    """

    blocks: int
    units: Units
    rapid_moves: int
    linear_moves: int
    arc_moves: int
    lower: npt.NDArray[np.float64]
    upper: npt.NDArray[np.float64]
    used: npt.NDArray[np.bool_]
    feed_length_mm: float
    rapid_length_mm: float
    time_s: float
    rapids_timed: bool

    def lines(self) -> list[str]:
        """The summary as report lines (``name: value``)."""
        out = [
            f"units: {self.units.name.lower()}",
            f"blocks: {self.blocks}",
            f"moves: {self.rapid_moves + self.linear_moves + self.arc_moves} (rapid "
            f"{self.rapid_moves}, feed {self.linear_moves}, arc {self.arc_moves})",
        ]
        for n, axis in enumerate(AXES):
            if self.used[n]:
                unit = "deg" if axis in "abc" else "mm"
                lo, hi = format_number(self.lower[n], 3), format_number(self.upper[n], 3)
                out.append(f"bounds {axis.upper()}: {lo} .. {hi} {unit}")
        out += [
            f"length feed: {format_number(self.feed_length_mm, 3)} mm",
            f"length rapid: {format_number(self.rapid_length_mm, 3)} mm",
            f"time: {format_number(self.time_s, 1)} s"
            + ("" if self.rapids_timed else " (feed moves and dwells; rapids not timed)"),
        ]
        return out


def summarize(
    program: Program,
    *,
    machine: Machine | None = None,
    rapid_rate_mm_per_min: float | None = None,
) -> ProgramSummary:
    """Blocks, moves, bounds, lengths and estimated time of a program.

    Parameters
    ----------
    program : Program
        The program (mm, degrees, mm/min).
    machine : Machine or None
        Gives work offsets, rapid rates and axis rate limits for the time estimate.
    rapid_rate_mm_per_min : float or None
        Without a machine: rapid rate for timing rapids, mm/min (rapids untimed if None).

    Returns
    -------
    ProgramSummary
        The figures.
    """
    offsets = work_offsets(machine) if machine is not None else None
    seg = interpret(program, work_offsets=offsets)
    length = seg.lengths()
    rapid = seg.kind == KIND_RAPID
    fine = seg.linearize(CHORD_TOLERANCE_MM)
    if machine is not None:
        points = joint_columns(machine, np.concatenate((fine.start[:1], fine.end)))
        limit_s = min_segment_times(machine, points)
        seconds = float(np.maximum(fine.durations(), limit_s).sum())
    else:
        seconds = float(seg.durations(rapid_rate_mm_per_min).sum())
    if len(seg):
        ends = np.concatenate((fine.start[:1], fine.end))
        lower, upper = ends.min(axis=0), ends.max(axis=0)
        used = upper > lower
    else:
        lower = upper = np.zeros(6)
        used = np.zeros(6, dtype=np.bool_)
    return ProgramSummary(
        blocks=len(program),
        units=program.units,
        rapid_moves=int(rapid.sum()),
        linear_moves=int((seg.kind == KIND_LINEAR).sum()),
        arc_moves=int((seg.kind > KIND_LINEAR).sum()),
        lower=lower,
        upper=upper,
        used=used,
        feed_length_mm=float(length[~rapid].sum()),
        rapid_length_mm=float(length[rapid].sum()),
        time_s=seconds + seg.dwell_s,
        rapids_timed=machine is not None or rapid_rate_mm_per_min is not None,
    )
