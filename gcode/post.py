"""The post: ``Toolpath`` + ``Machine`` + ``Dialect`` -> ``Program``.

Steps, each a plain array operation on the whole path:

1. **Joints.** Tool tips and tool axes go through the machine's inverse kinematics
   (:meth:`toolpath.Toolpath.to_machine`); the program words are the joints in program
   coordinates (:mod:`gcode.machine_frame`: linear joints minus the work origin, rotary
   joints as the controller takes them). A tilted tool axis on a 3-axis machine, or a
   machine axis the dialect has no word for, is refused with a :class:`PostError`.
2. **Time per move.** Each move takes ``max(60 L / feed, slowest axis at its max rate)``
   seconds (:meth:`toolpath.Toolpath.segment_times_s`, from
   :func:`machines.limits.min_segment_times`), ``L`` the tool-tip length.
3. **Feeds.** A feed move that turns a rotary axis is written in inverse time (G93,
   ``F = 60 / seconds``, 1/min) where the dialect has it; other feed moves in G94 with the
   feed that gives the same time for the XYZ distance the controller sees
   (``F = 60 L_xyz / seconds``, or the rotary distance in deg/min for rotary-only moves),
   so every block takes the time it should and no axis exceeds its rate.
4. **Arcs.** Runs of G94 feed moves with fixed rotary axes, one feed, and one coordinate
   fixed (a plane G17, G18 or G19) are fitted with arcs (:func:`gcode.arcfit.fit_arcs`)
   where the dialect has G2/G3: every original point within the tolerance of its arc.
5. **Safe start and end.** Header comments, G94 G17 G90 (those the dialect's preamble
   does not already write), the work offset, tool change, spindle and coolant on; then a
   Z-only rapid to the clearance height before any other axis moves, rotary axes at
   clearance, X Y at clearance, and down to the first point. At the end: back to G94 and
   G17, retract to the clearance height, spindle and coolant off, program end.

Axis words that do not change at the written resolution are left out, and moves that
change nothing at that resolution are dropped.

The stretches of rapid and linear moves between arcs and feed-mode switches are stored as
:class:`~gcode.block_sequence.MoveRun` columns (no object per move), so the program's
blocks are a :class:`~gcode.block_sequence.BlockSequence` that consumers such as the
emitter read column-wise; its blocks are those the post would build one by one.

Examples
--------
>>> import numpy as np
>>> from machines import load_machine
>>> from toolpath import MoveKind, Toolpath
>>> from gcode import GRBL, emit_lines
>>> tp = Toolpath(
...     positions_mm=[[0, 0, 5], [0, 0, -1], [10, 0, -1], [10, 0, 5]],
...     tool_axes=[0, 0, 1],
...     kinds=[MoveKind.RAPID, MoveKind.PLUNGE, MoveKind.CUT, MoveKind.RETRACT],
...     feeds_mm_per_min=[0, 300, 800, 1000],
...     pass_index=[-1, 0, 0, -1],
... )
>>> program = post(tp, load_machine("grbl-router"), options=PostOptions(coolant=None))
>>> emit_lines(program, GRBL)[-9:]
['G0Z10', 'X0Y0', 'Z5', 'G1Z-1F300', 'X10F800', 'Z5F1000', 'G0Z10', 'M5', 'M30']
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from gcode.arcfit import ARC_MIN_POINTS, DEFAULT_ARC_TOLERANCE_MM, arc_deviation_mm, fit_arcs
from gcode.block_sequence import KIND_LINEAR, KIND_RAPID, BlockSequence, MoveRun, Part
from gcode.dialects import Dialect, dialect_by_name
from gcode.errors import ErrorCode, PostError
from gcode.machine_frame import (
    joint_columns,
    machine_axis_names,
    program_values,
    work_offset_vector,
)
from gcode.numbers import MM_PER_INCH, format_number
from gcode.post_defaults import DEFAULT_CLEARANCE_MM
from gcode.program import (
    AXES,
    Arc,
    Block,
    Comment,
    Coolant,
    CoolantMode,
    DistanceMode,
    FeedMode,
    Plane,
    Program,
    ProgramEnd,
    Rapid,
    SetDistanceMode,
    SetFeedMode,
    SetPlane,
    SetWorkOffset,
    Spindle,
    SpindleDirection,
    ToolChange,
    Units,
)
from machines import Machine, UnreachableOrientationError, Wrap
from machines.limits import min_segment_times
from toolpath import MoveKind, Toolpath
from toolpath.joint_refine import path_joints, refine_with_joints
from toolpath.tolerances import ROUND_OFF

__all__ = ["DEFAULT_CLEARANCE_MM", "PostOptions", "post"]

#: Largest distance of the tool tip from the planned chord under joint interpolation, mm.
DEFAULT_JOINT_TOLERANCE_MM = 0.002
# Plane bits of a move: the plane's normal coordinate does not change.
_PLANE_BITS = ((Plane.XY, 1, 2), (Plane.ZX, 2, 1), (Plane.YZ, 4, 0))  # plane, bit, normal
_ROTARY_COLS = [AXES.index(a) for a in ("a", "b", "c")]
# Stretches of moves shorter than this are stored as block objects (columns cost more
# than they save there; the emitter formats such short runs one by one anyway).
_MIN_COLUMN_RUN = 32


@dataclass(frozen=True, slots=True, kw_only=True)
class PostOptions:
    """What the post writes besides the moves.

    Parameters
    ----------
    units : Units
        Units of the G-code text (G21 mm or G20 inch); the program itself is in mm.
    work_offset : int
        Work system 1-6 (G54-G59); the controller must hold the machine's work origin in
        it (see :mod:`gcode.machine_frame`).
    tool : int or None
        Tool to load (``T<n> M6``) on dialects with tool change; a comment otherwise.
    spindle_rpm : float
        Spindle speed, rev/min (>= 0).
    spindle_direction : SpindleDirection
        M3 (CW) or M4 (CCW).
    coolant : CoolantMode or None
        M7 or M8 at the start (M9 at the end); None writes no coolant command.
    clearance_mm : float
        Clearance height above the highest Z of the path, mm (>= 0), capped at the top
        of the Z travel.
    arcs : bool
        Fit G2/G3 arcs where the dialect has them.
    arc_tolerance_mm : float
        Largest distance of an original point from its arc, mm (> 0).
    inverse_time : bool
        Write moves that turn rotary axes in G93 where the dialect has it.
    name : str or None
        Program name (header comment, Fanuc O-line); the toolpath's ``name`` metadata
        when None.
    number : int or None
        Program number for dialects that write one.
    joint_tolerance_mm : float or None
        5-axis: moves are split until the controller's joint interpolation keeps the tool
        tip within this distance of the planned chord
        (:func:`toolpath.joint_refine.refine_for_joint_interpolation`); None: no split.
    """

    units: Units = Units.MM
    work_offset: int = 1
    tool: int | None = None
    spindle_rpm: float = 12000.0
    spindle_direction: SpindleDirection = SpindleDirection.CW
    coolant: CoolantMode | None = CoolantMode.FLOOD
    clearance_mm: float = DEFAULT_CLEARANCE_MM
    arcs: bool = True
    arc_tolerance_mm: float = DEFAULT_ARC_TOLERANCE_MM
    inverse_time: bool = True
    name: str | None = None
    number: int | None = None
    joint_tolerance_mm: float | None = DEFAULT_JOINT_TOLERANCE_MM

    def __post_init__(self) -> None:
        if not 1 <= self.work_offset <= 6:
            raise ValueError(f"work_offset must be 1..6 (G54..G59), got {self.work_offset!r}")
        if self.tool is not None and self.tool < 0:
            raise ValueError(f"tool must be >= 0, got {self.tool!r}")
        if not (math.isfinite(self.spindle_rpm) and self.spindle_rpm >= 0.0):
            raise ValueError(f"spindle_rpm must be finite and >= 0, got {self.spindle_rpm!r}")
        if self.spindle_direction is SpindleDirection.OFF:
            raise ValueError("spindle_direction must be CW or CCW")
        if self.coolant is CoolantMode.OFF:
            raise ValueError("coolant must be MIST, FLOOD or None")
        if not (math.isfinite(self.clearance_mm) and self.clearance_mm >= 0.0):
            raise ValueError(f"clearance_mm must be finite and >= 0, got {self.clearance_mm!r}")
        if not (math.isfinite(self.arc_tolerance_mm) and self.arc_tolerance_mm > 0.0):
            raise ValueError(f"arc_tolerance_mm must be > 0, got {self.arc_tolerance_mm!r}")
        tol = self.joint_tolerance_mm
        if tol is not None and not (math.isfinite(tol) and tol > 0.0):
            raise ValueError(f"joint_tolerance_mm must be > 0 or None, got {tol!r}")


def _check_machine_dialect(machine: Machine, dialect: Dialect) -> None:
    missing = [a.upper() for a in machine_axis_names(machine) if a not in dialect.axes]
    if missing:
        raise PostError(
            ErrorCode.UNSUPPORTED_COMMAND,
            f"machine {machine.name!r} has axes {machine.letters!r} but dialect "
            f"{dialect.name!r} has no {', '.join(missing)} words: a "
            f"{len(machine.letters)}-axis program cannot be written for it",
        )


def _joints(toolpath: Toolpath, machine: Machine) -> npt.NDArray[np.float64]:
    try:
        return path_joints(toolpath, machine).joints  # (those the planner solved, if any)
    except UnreachableOrientationError as exc:
        raise PostError(
            ErrorCode.UNSUPPORTED_COMMAND,
            f"5-axis toolpath refused for a 3-axis machine: {exc}",
        ) from None


def _round_to(values: npt.NDArray[np.float64], scale: Any, unit: Any) -> npt.NDArray[np.float64]:
    # same operations as the emitter (value / MM_PER_INCH, then * 10**decimals, rint) and
    # the parser (digits / 10**decimals, then * MM_PER_INCH): the result reads back exactly
    return (np.rint((values / unit) * scale) / scale) * unit


@dataclass(frozen=True)
class _Grid:
    """The values text can hold: ``(q / 10**decimals) * per_text_unit`` for integers ``q``.

    The post rounds every word to this grid itself, so the program holds exactly what the
    emitter writes and the parser reads back, and the times it plans are the times the
    controller (and :mod:`gcode.check`) computes from the text.
    """

    decimals: npt.NDArray[np.int64]  # per column
    per_text_unit: npt.NDArray[np.float64]  # mm (or degrees) per text unit, per column

    def round(self, values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Nearest grid values (half to even, as the formatter rounds), per column."""
        return _round_to(values, 10.0**self.decimals, self.per_text_unit)

    def round_column(self, values: npt.NDArray[np.float64], k: int) -> npt.NDArray[np.float64]:
        """Nearest grid values of column ``k`` (X..C) for a 1-D array."""
        return _round_to(values, 10.0 ** int(self.decimals[k]), float(self.per_text_unit[k]))

    def floor(self, values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Largest grid values not above ``values`` (one grid step at least)."""
        scale = 10.0**self.decimals
        q = np.floor((values / self.per_text_unit) * scale * (1.0 + ROUND_OFF))
        return (np.maximum(q, 1.0) / scale) * self.per_text_unit


def _word_grid(dialect: Dialect, units: Units) -> _Grid:
    dec = dialect.decimals
    inch = units is Units.INCH
    linear = dec.coord_inch if inch else dec.coord_mm
    return _Grid(
        np.array([linear] * 3 + [dec.angle] * 3),
        np.array([MM_PER_INCH if inch else 1.0] * 3 + [1.0] * 3),
    )


def _feed_grid(dialect: Dialect, units: Units, inverse: npt.NDArray[np.bool_]) -> _Grid:
    dec = dialect.decimals
    inch = units is Units.INCH
    upm = dec.feed_inch if inch else dec.feed_mm
    return _Grid(
        np.where(inverse, dec.inverse_time, upm),
        np.where(inverse, 1.0, MM_PER_INCH if inch else 1.0),
    )


@dataclass(frozen=True)
class _Moves:
    """Per-move arrays (move ``i`` arrives at point ``i``; row 0 is the start point)."""

    words: npt.NDArray[np.float64]  # (n, 6) program values on the grid, NaN where absent
    changed: npt.NDArray[np.bool_]  # (n, 6) word differs from the previous point's
    rapid: npt.NDArray[np.bool_]  # (n,)
    inverse: npt.NDArray[np.bool_]  # (n,) feed move written in G93
    feed: npt.NDArray[np.float64]  # (n,) F in mm/min (G94) or 1/min (G93), on the grid
    planes: npt.NDArray[np.int64]  # (n,) bits of the planes a move lies in (arc runs)


def _grid_words(
    machine: Machine, joints: npt.NDArray[np.float64], grid: _Grid
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Program words on the grid, and the machine positions X..C they move the axes to.

    Positions keep rotary axes unwrapped (real motion, also on modulo-360 axes).
    """
    words = grid.round(program_values(machine, joints))
    positions = words + work_offset_vector(machine)
    for col, axis in enumerate(machine.axes):
        if axis.is_rotary:
            k = AXES.index(axis.letter.lower())
            positions[:, k] = grid.round_column(joints[:, col], k)
            if axis.wrap is Wrap.SHORTEST:  # 359.9996 rounds to 360
                words[words[:, k] >= 360.0, k] -= 360.0
    return words, positions


def _plan_moves(
    toolpath: Toolpath,
    machine: Machine,
    joints: npt.NDArray[np.float64],
    dialect: Dialect,
    opts: PostOptions,
) -> _Moves:
    words, positions = _grid_words(machine, joints, _word_grid(dialect, opts.units))
    n = words.shape[0]
    changed = np.zeros((n, 6), dtype=np.bool_)
    changed[1:] = words[1:] != words[:-1]
    changed &= ~np.isnan(words)
    moved = changed.any(axis=1)
    rotary_moves = changed[:, _ROTARY_COLS].any(axis=1)
    rapid = np.asarray(toolpath.kinds) == MoveKind.RAPID
    inverse = ~rapid & rotary_moves & dialect.inverse_time & opts.inverse_time
    inverse[0] = False

    # seconds per move: the asked tool-tip feed, or the slowest axis at its max rate
    asked = np.asarray(toolpath.feeds_mm_per_min, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_feed = np.concatenate(([0.0], 60.0 * toolpath.segment_lengths_mm / asked[1:]))
    limit = min_segment_times(machine, joint_columns(machine, positions))
    t_limit = np.concatenate(([0.0], limit))
    seconds = np.maximum(np.nan_to_num(t_feed), t_limit)
    step = np.diff(np.nan_to_num(positions), axis=0, prepend=np.nan_to_num(positions[:1]))
    xyz = np.sqrt((step[:, :3] ** 2).sum(axis=1))
    rot = np.sqrt((step[:, _ROTARY_COLS] ** 2).sum(axis=1))
    distance = np.where(xyz > 0.0, xyz, rot)  # what a G94 F applies to (LinuxCNC)
    with np.errstate(divide="ignore", invalid="ignore"):
        feed = np.where(inverse, 60.0 / seconds, 60.0 * distance / seconds)
        # linear moves the asked feed keeps within every axis's rate: write it as asked
        keep = ~rotary_moves & (60.0 * xyz / asked >= t_limit)
    feed[keep] = asked[keep]
    feed[rapid | ~moved] = np.nan
    feed[0] = np.nan
    feed = _feed_grid(dialect, opts.units, inverse).floor(feed)

    planes = np.zeros(n, dtype=np.int64)
    for _, bit, normal in _PLANE_BITS:
        planes |= np.where(changed[:, normal], 0, bit)
    arc_ok = ~rapid & ~inverse & ~rotary_moves & moved
    arc_ok[0] = False
    planes[~arc_ok] = 0
    return _Moves(words, changed, rapid, inverse, feed, planes)


def _arc_runs(moves: _Moves) -> list[tuple[int, int, Plane]]:
    """Runs of moves ``first .. last`` in one plane with one feed, long enough for an arc."""
    runs = []
    planes = moves.planes.tolist()
    keys = moves.feed.tolist()
    n = len(planes)
    i = 1
    while i < n:
        mask = planes[i]
        if not mask:
            i += 1
            continue
        j = i + 1
        while j < n and planes[j] & mask and keys[j] == keys[i]:
            mask &= planes[j]
            j += 1
        if j - i + 1 >= ARC_MIN_POINTS:
            plane = next(p for p, bit, _ in _PLANE_BITS if mask & bit)
            runs.append((i, j - 1, plane))
        i = j
    return runs


def _fit_run_arcs(
    moves: _Moves, runs: Sequence[tuple[int, int, Plane]], tol_mm: float, grid: _Grid
) -> dict[int, tuple[int, Arc]]:
    """Arc blocks by their first move, with the move after them.

    Centre offsets are rounded to the grid like every word, and each arc is verified again
    with its rounded centre (radius from the start point, as controllers take it): every
    point of the span within ``tol_mm``. An arc that fails stays lines.
    """
    out: dict[int, tuple[int, Arc]] = {}
    for first, last, plane in runs:
        u, v, _ = plane.axes
        cols = [AXES.index(u), AXES.index(v)]
        pts = moves.words[first - 1 : last + 1][:, cols]
        for span in fit_arcs(pts, tol_mm):
            start, end = pts[span.start], pts[span.end]
            offsets = [
                float(grid.round_column(np.array([span.centre[m] - start[m]]), cols[m])[0])
                for m in range(2)
            ]
            centre = start + np.array(offsets)
            if arc_deviation_mm(pts[span.start : span.end + 1], centre) > tol_mm:
                continue
            ou, ov = plane.offsets
            arc = Arc(
                clockwise=span.clockwise,
                plane=plane,
                feed=float(moves.feed[first + span.start]),
                **{u: float(end[0]), v: float(end[1]), ou: offsets[0], ov: offsets[1]},
            )
            out[first + span.start] = (first + span.end, arc)
    return out


class _Writer:
    """Collects blocks and move runs, and the modal state the post has set (feed mode, plane)."""

    def __init__(self) -> None:
        self.parts: list[Part] = []
        self.pending: list[Block] = []  # blocks since the last move run
        self.feed_mode = FeedMode.UNITS_PER_MINUTE
        self.plane = Plane.XY

    def add(self, block: Block) -> None:
        self.pending.append(block)

    def add_moves(self, run: MoveRun) -> None:
        """Append a stretch of moves: as columns if long enough, else as blocks."""
        if len(run) < _MIN_COLUMN_RUN:
            self.pending.extend(run.blocks())
            return
        self.parts.append(tuple(self.pending))
        self.pending.clear()
        self.parts.append(run)

    def feed_mode_to(self, mode: FeedMode) -> None:
        if mode is not self.feed_mode:
            self.add(SetFeedMode(mode))
            self.feed_mode = mode

    def plane_to(self, plane: Plane) -> None:
        if plane is not self.plane:
            self.add(SetPlane(plane))
            self.plane = plane

    def blocks(self) -> tuple[Block, ...] | BlockSequence:
        """Everything added, in order: a tuple unless some moves are columns."""
        if not self.parts:
            return tuple(self.pending)
        return BlockSequence([*self.parts, tuple(self.pending)])


@dataclass(frozen=True)
class _MoveColumns:
    """The moves the post writes as Rapid/Linear blocks, in order, as columns.

    ``index`` are their move numbers (into :class:`_Moves`); row ``r`` of ``kind``,
    ``axes`` (changed words, NaN elsewhere) and ``feed`` (NaN for rapids) is the block
    of move ``index[r]``.
    """

    index: npt.NDArray[np.int64]
    kind: npt.NDArray[np.int8]
    axes: npt.NDArray[np.float64]
    feed: npt.NDArray[np.float64]

    def run(self, first_move: int, stop_move: int) -> MoveRun:
        """The written moves among moves ``first_move .. stop_move-1``."""
        lo, hi = np.searchsorted(self.index, (first_move, stop_move))
        return MoveRun.checked(self.kind[lo:hi], self.axes[lo:hi], self.feed[lo:hi])


def _written_moves(moves: _Moves, arcs: dict[int, tuple[int, Arc]]) -> _MoveColumns:
    """Columns of the moves written as lines: not inside an arc, changing some word."""
    keep = moves.changed.any(axis=1)
    keep[0] = False  # the start point: reached by the approach
    for first, (after, _) in arcs.items():
        keep[first:after] = False
    index = np.flatnonzero(keep)
    changed = moves.changed[index]
    rapid = moves.rapid[index]
    return _MoveColumns(
        index,
        np.where(rapid, KIND_RAPID, KIND_LINEAR).astype(np.int8),
        np.where(changed, moves.words[index], np.nan),
        np.where(rapid, np.nan, moves.feed[index]),
    )


def _feed_mode_switches(
    moves: _Moves, written: _MoveColumns, arcs: dict[int, tuple[int, Arc]]
) -> npt.NDArray[np.int64]:
    """Moves written as lines that need a feed-mode block (G93/G94) before them.

    Linear moves set the mode they are written in, arcs G94, rapids keep it; the post
    starts in G94.
    """
    n = moves.words.shape[0]
    mode = np.full(n, -1, dtype=np.int8)  # mode set by the move, -1: unchanged
    mode[0] = 0
    lines = written.index[written.kind == KIND_LINEAR]
    mode[lines] = moves.inverse[lines]
    mode[np.fromiter(arcs, np.int64, len(arcs))] = 0
    at = np.where(mode >= 0, np.arange(n), 0)
    np.maximum.accumulate(at, out=at)
    before = np.empty(n, dtype=np.int8)
    before[0] = 0
    before[1:] = mode[at[:-1]]
    return lines[moves.inverse[lines] != before[lines].astype(np.bool_)]


def _write_moves(w: _Writer, moves: _Moves, arcs: dict[int, tuple[int, Arc]]) -> None:
    """Moves 1 .. n-1: arcs and feed-mode switches as blocks, the lines between as runs."""
    written = _written_moves(moves, arcs)
    switches = _feed_mode_switches(moves, written, arcs)
    events = np.union1d(np.fromiter(arcs, np.int64, len(arcs)), switches).tolist()
    inverse = moves.inverse
    i = 1
    for e in events:
        w.add_moves(written.run(i, e))
        if e in arcs:
            after, arc = arcs[e]
            w.feed_mode_to(FeedMode.UNITS_PER_MINUTE)
            w.plane_to(arc.plane)
            w.add(arc)
            i = after
        else:
            w.feed_mode_to(FeedMode.INVERSE_TIME if inverse[e] else FeedMode.UNITS_PER_MINUTE)
            i = e
    w.add_moves(written.run(i, moves.words.shape[0]))


def _header(
    toolpath: Toolpath, machine: Machine, dialect: Dialect, opts: PostOptions, name: str | None
) -> list[Block]:
    origin = " ".join(
        f"{a}{format_number(v, 3)}" for a, v in zip("XYZ", machine.work_origin, strict=True)
    )
    blocks: list[Block] = []
    if name:
        blocks.append(Comment(name))
    kin = machine.kinematics.value
    blocks.append(Comment(f"machine {machine.name}, kinematics {kin}, dialect {dialect.name}"))
    blocks.append(Comment(f"G{53 + opts.work_offset} must hold the work origin {origin} mm"))
    blocks.extend(
        Comment(f"{k}: {v}") for k, v in sorted(toolpath.metadata.items()) if v != name
    )
    return blocks


def _safe_start(dialect: Dialect, opts: PostOptions) -> list[Block]:
    modal: list[Block] = [
        SetFeedMode(FeedMode.UNITS_PER_MINUTE),
        SetPlane(Plane.XY),
        SetDistanceMode(DistanceMode.ABSOLUTE),
    ]
    blocks = [b for b in modal if b not in dialect.preamble]
    blocks.append(SetWorkOffset(opts.work_offset))
    if opts.tool is not None:
        if dialect.tool_change:
            blocks.append(ToolChange(opts.tool))
        else:
            blocks.append(Comment(f"load tool {opts.tool} by hand: {dialect.name} has no M6"))
    blocks.append(Spindle(opts.spindle_direction, opts.spindle_rpm))
    if opts.coolant is not None:
        blocks.append(Coolant(opts.coolant))
    return blocks


def _clearance_z(
    machine: Machine, words: npt.NDArray[np.float64], opts: PostOptions, grid: _Grid
) -> float:
    """Program Z of the clearance height (mm, on the grid): above the path, within Z travel."""
    highest = float(words[:, 2].max())
    top = machine.axis("Z").max - float(work_offset_vector(machine)[2])
    target = min(highest + opts.clearance_mm, top)
    z = float(grid.round_column(np.array([target]), 2)[0])
    if z > target:  # rounded up past the travel: one grid step down
        z = float(grid.round_column(np.array([2.0 * target - z]), 2)[0])
    return max(highest, z)


def _approach(w: _Writer, first: Sequence[float], safe_z: float) -> None:
    """Z up first, then rotary axes, then X Y at clearance, then down to the first point."""
    w.add(Rapid(z=safe_z))
    rotary = {
        a: first[k] for a, k in zip("abc", _ROTARY_COLS, strict=True) if not math.isnan(first[k])
    }
    if rotary:
        w.add(Rapid(**rotary))
    w.add(Rapid(x=first[0], y=first[1]))
    w.add(Rapid(z=first[2]))


def post(
    toolpath: Toolpath,
    machine: Machine,
    dialect: Dialect | None = None,
    *,
    options: PostOptions | None = None,
) -> Program:
    """Turn a toolpath into a G-code program for a machine and dialect.

    Parameters
    ----------
    toolpath : Toolpath
        Tool tips (mm, workpiece frame), tool axes, move kinds and feeds (mm/min).
    machine : Machine
        The machine; its kinematics give the joint values.
    dialect : Dialect or None
        Target controller; the machine's own dialect (``machine.dialect``) when None.
    options : PostOptions or None
        Units, work offset, tool, spindle, coolant, clearance, arcs, inverse time.

    Returns
    -------
    Program
        Blocks in mm, degrees, mm/min (1/min in G93), with ``units``, ``name`` and
        ``number`` from the options.

    Raises
    ------
    PostError
        For an empty toolpath, a tilted tool axis on a 3-axis machine (naming the first
        such point), or a machine axis the dialect cannot write (A/B/C on GRBL).
    """
    opts = options if options is not None else PostOptions()
    d = dialect if dialect is not None else dialect_by_name(machine.dialect)
    if len(toolpath) == 0:
        raise PostError(ErrorCode.NO_AXIS_WORDS, "the toolpath has no points")
    _check_machine_dialect(machine, d)
    joints = None  # (the refinement's last round solved them for the path it returns)
    if opts.joint_tolerance_mm is not None:
        toolpath, joints = refine_with_joints(toolpath, machine, opts.joint_tolerance_mm)
    if joints is None:
        joints = _joints(toolpath, machine)
    moves = _plan_moves(toolpath, machine, joints, d, opts)
    arcs: dict[int, tuple[int, Arc]] = {}
    grid = _word_grid(d, opts.units)
    if opts.arcs and d.arcs:
        arcs = _fit_run_arcs(moves, _arc_runs(moves), opts.arc_tolerance_mm, grid)

    name = opts.name if opts.name is not None else toolpath.metadata.get("name")
    w = _Writer()
    for b in (*_header(toolpath, machine, d, opts, name), *_safe_start(d, opts)):
        w.add(b)
    safe_z = _clearance_z(machine, moves.words, opts, grid)
    _approach(w, moves.words[0].tolist(), safe_z)
    _write_moves(w, moves, arcs)

    w.feed_mode_to(FeedMode.UNITS_PER_MINUTE)
    w.plane_to(Plane.XY)
    if safe_z > float(moves.words[-1, 2]):
        w.add(Rapid(z=safe_z))
    w.add(Spindle(SpindleDirection.OFF, opts.spindle_rpm))
    if opts.coolant is not None:
        w.add(Coolant(CoolantMode.OFF))
    w.add(ProgramEnd(rewind=True))
    return Program(w.blocks(), name=name, number=opts.number, units=opts.units)
