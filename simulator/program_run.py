"""Whole-program execution in instant mode: the same physics, vectorized.

:func:`run_program` executes a parsed :class:`gcode.Program` on a :class:`Controller` as
a sender that keeps the planner full would (the queue is refilled as soon as a block
finishes): the program goes through :func:`gcode.interpret`, arcs are split into chords
within ``$12``, soft limits are checked, entry speeds come from
:func:`~simulator.planner.plan_entry_speeds_sq` with the controller's 15-block window,
and block times from the trapezoid. The journal gets one record per source line with
blocks, exactly as a streamed run would give it (tests compare the two).

Lines that synchronize (dwell, spindle, coolant, tool change, program end) stop the axes
before them and add their dwell. A line outside the soft limits stops the run before it,
with every earlier line executed, and raises ``ALARM:2`` (a streamed run would stop
inside the look-ahead window instead).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gcode import ModalState, Program
from gcode.block_sequence import MoveRun, block_runs
from gcode.interpreter import KIND_RAPID, interpret
from gcode.program import Arc, Dwell, Linear, Rapid
from simulator.controller import SYNC_BLOCK_TYPES, Alarm, Controller
from simulator.motion import block_kinematics_array, junction_speed_sq_array, trapezoid_time_s_array
from simulator.planner import plan_entry_speeds_sq

__all__ = ["ProgramRun", "run_program"]


@dataclass(frozen=True, slots=True)
class ProgramRun:
    """Summary of :func:`run_program`.

    Attributes
    ----------
    lines : int
        Lines journaled.
    blocks : int
        Planner blocks executed (arc chords counted one by one, zero-length moves not).
    duration_s : float
        Virtual time the program took, s.
    alarm : int or None
        ``2`` if a soft limit stopped the run.
    """

    lines: int
    blocks: int
    duration_s: float
    alarm: int | None


def run_program(controller: Controller, program: Program) -> ProgramRun:
    """Execute ``program`` on an idle ``controller`` at once (instant mode).

    Parameters
    ----------
    controller : Controller
        Idle, not in alarm or check mode; its clock, position, modal state and journal
        are updated as if the program had been streamed.
    program : Program
        Parsed blocks with ``source_lines``.

    Returns
    -------
    ProgramRun
        Lines, blocks, virtual duration and the alarm, if any.

    Raises
    ------
    RuntimeError
        If the controller is busy, in alarm or in check mode.
    ValueError
        If the program moves an axis the controller's mode does not have.
    """
    c = controller
    if c.planner or c.line_pending or c.alarm is not None or c.check_mode:
        raise RuntimeError(
            f"run_program needs an idle controller, state is {c.state.value} "
            f"with {len(c.planner)} blocks queued"
        )
    t0 = c.now_s
    st = c.parser_state
    seg = interpret(program, state=st, work_offsets=c.work_offsets)
    seg = seg.linearize(c.settings.arc_tolerance_mm)
    start, end = seg.start, seg.end
    allowed = np.zeros(6, dtype=bool)
    allowed[["XYZABC".index(a) for a in c.report_axes]] = True
    moved = (end != start).any(axis=0) & ~allowed
    if moved.any():
        bad = "".join(a for a, m in zip("XYZABC", moved, strict=True) if m)
        raise ValueError(f"program moves axis {bad} that {c.mode} mode on {c.machine.name} lacks")
    block_lines = _source_lines(program)
    src = block_lines  # the lines that run: cut short at a soft-limit stop
    # the first soft-limit violation stops the run before its line
    alarm = None
    n_rows = len(seg)
    if c.settings.soft_limits and n_rows:
        bad_rows = np.zeros(n_rows, dtype=bool)
        for i, lo, hi, _ in c._travel:
            v = end[:, i]
            bad_rows |= (v < lo) | (v > hi)
        if bad_rows.any():
            first = int(np.flatnonzero(bad_rows)[0])
            stop_line = int(seg.line[first])
            n_rows = int(np.searchsorted(seg.line, stop_line, side="left"))
            src = src[src < stop_line]
            alarm = Alarm.SOFT_LIMIT
    rows = slice(0, n_rows)
    line = seg.line[rows]
    length, unit, vn, accel, _ = block_kinematics_array(
        start[rows], end[rows], seg.feed[rows], seg.kind[rows] == KIND_RAPID,
        seg.inverse_time[rows], c.limits,
    )  # fmt: skip
    keep = length > 0.0
    length, unit, vn, accel, line = length[keep], unit[keep], vn[keep], accel[keep], line[keep]
    ends = end[rows][keep]
    n = int(length.shape[0])
    # synchronizing lines and their dwell
    sync_lines, dwell_s = _sync_lines(program, src, block_lines)
    prev_unit = np.concatenate((np.asarray(c._prev_unit)[None, :], unit[:-1]))
    prev_speed = np.concatenate(([c._prev_speed], vn[:-1]))
    j2 = junction_speed_sq_array(prev_unit, unit, c.limits, c.settings.junction_deviation_mm)
    max_entry = np.minimum(np.minimum(j2, vn * vn), prev_speed * prev_speed)
    prev_line = np.concatenate(([0], line[:-1]))
    barrier = np.searchsorted(sync_lines, line, "right") > np.searchsorted(
        sync_lines, prev_line, "right"
    )
    max_entry[barrier] = 0.0
    e2 = plan_entry_speeds_sq(max_entry, 2.0 * accel * length, planner_blocks=c.planner.capacity)
    e = np.sqrt(e2)
    times = trapezoid_time_s_array(length, e[:-1], e[1:], vn, accel)
    cum_dwell = np.concatenate(([0.0], np.cumsum(dwell_s)))
    dwell_before = cum_dwell[np.searchsorted(sync_lines, line, "right")]
    end_t = t0 + np.cumsum(times) + dwell_before
    # journal: one record per source line with blocks
    jl = src[np.concatenate(([True], src[1:] != src[:-1]))] if src.shape[0] else src
    idx = np.searchsorted(line, jl, "right") - 1
    k = len(c.report_axes)
    report_idx = ["XYZABC".index(a) for a in c.report_axes]
    pos0 = np.asarray(c.position6())
    pos = np.where((idx >= 0)[:, None], ends[np.maximum(idx, 0)] if n else pos0, pos0)[
        :, report_idx
    ]
    last_t = np.where(idx >= 0, end_t[np.maximum(idx, 0)] if n else t0, t0)
    moved_before = np.where(idx >= 0, line[np.maximum(idx, 0)] if n else 0, 0)
    extra = (
        cum_dwell[np.searchsorted(sync_lines, jl, "right")]
        - cum_dwell[np.searchsorted(sync_lines, moved_before, "right")]
    )
    jt = last_t + np.where(idx >= 0, extra, cum_dwell[np.searchsorted(sync_lines, jl, "right")])
    seqs = c._seq + 1 + np.arange(jl.shape[0], dtype=np.int64)
    c.journal.record_arrays(seq=seqs, line=jl, position=pos.reshape(-1, k), time_s=jt)
    c._seq += int(jl.shape[0])
    final_t = float(jt[-1]) if jl.shape[0] else t0
    final6 = tuple(ends[-1].tolist()) if n else c.position6()
    c.clock.advance_to(final_t)
    c._pos = c._plan_pos = final6
    if n:
        c._prev_unit = tuple(unit[-1].tolist())
        c._prev_speed = float(vn[-1])
    c._bp.state = _end_state(program, st, final6, c.work_offsets, src, block_lines)
    if alarm is not None:
        c._alarm_now(alarm)
    return ProgramRun(int(jl.shape[0]), n, final_t - t0, None if alarm is None else int(alarm))


def _source_lines(program: Program) -> np.ndarray:
    """Source line of every block (block index + 1 for programs that were not parsed)."""
    if program.source_lines is None:
        return np.arange(1, len(program) + 1, dtype=np.int64)
    return np.asarray(program.source_lines, dtype=np.int64)


def _sync_lines(
    program: Program, src: np.ndarray, lines: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Source lines that synchronize (sorted, unique) and the dwell of each, s.

    ``lines`` is the source line of every block. Move runs stored as columns are skipped
    without building their blocks: plain moves never synchronize.
    """
    found: dict[int, float] = {}
    limit = int(src.max()) if src.shape[0] else 0
    for first, part in block_runs(program.blocks):
        if isinstance(part, MoveRun):
            continue
        for b, ln in zip(part, lines[first : first + len(part)].tolist(), strict=True):
            t = type(b)
            if t is Linear or t is Rapid or ln > limit:
                continue
            if isinstance(b, SYNC_BLOCK_TYPES):
                found[ln] = found.get(ln, 0.0) + (b.seconds if t is Dwell else 0.0)
    keys = sorted(found)
    return np.asarray(keys, dtype=np.int64), np.asarray([found[k] for k in keys])


def _end_state(
    program: Program,
    st: ModalState,
    final6: tuple[float, ...],
    offsets: dict[int, tuple[float, ...]],
    src: np.ndarray,
    lines: np.ndarray,
) -> ModalState:
    """Modal state after the executed part of the program (non-motion blocks replayed).

    Blocks are taken in order up to the first whose source line (``lines``) lies beyond
    the executed ones; of a move run stored as columns only its last such move is built.
    """
    limit = int(src.max()) if src.shape[0] else 0
    last_motion = None
    for first, part in block_runs(program.blocks):
        rows = lines[first : first + len(part)]
        beyond = np.flatnonzero(rows > limit)
        stop = int(beyond[0]) if beyond.shape[0] else len(part)
        if isinstance(part, MoveRun):
            if stop:
                last_motion = part.blocks(stop - 1, stop)[0]
        else:
            for b in part[:stop]:
                t = type(b)
                if t is Linear or t is Rapid or t is Arc:
                    last_motion = b
                    continue
                st = st.apply(b)
        if stop < len(part):
            break
    if last_motion is not None:
        st = st.apply(last_motion)
    off = offsets[st.wcs]
    return replace(st, position=tuple(p - o for p, o in zip(final6, off, strict=True)))
