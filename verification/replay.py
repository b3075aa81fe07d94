"""Replay a program through the machine: where the tool really is, between blocks too.

A controller interpolates every *joint* linearly within a block (G0/G1; arcs in their
plane), so on a 5-axis machine the tool tip between two blocks follows the curve
``forward(J0 + u (J1 - J0))``, ``u in [0, 1]``, not the straight line between the two end
tips. :func:`replay`:

1. expands the program with :func:`gcode.interpreter.interpret` (the interpreter the
   checker and the simulator use), with the machine's work offsets
   (:func:`gcode.machine_frame.work_offsets`), and turns arcs into chords within the
   replay tolerance;
2. takes the machine's joint columns; modulo-360 rotary axes (``Wrap.SHORTEST``) are
   unwrapped the way the controller moves them, the short way round;
3. samples every block that turns a rotary axis finely in joint space: ``n`` equal steps
   of ``u``, ``n`` doubled-and-more until the midpoint of every step of the ball-centre
   path and of the tip path lies within ``chord_tol_mm`` of its chord (the deviation of
   a smooth arc from its chord shrinks as ``1/n^2``). Blocks that move linear axes only
   are straight lines in the workpiece frame and stay one step;
4. maps all samples through :func:`machines.forward` to tool tips and tool axes in the
   workpiece frame (the design surface's frame).

Where the tool is before the program runs is not known (the interpreter starts at
program zero, which may lie on the part), so the sweep starts at the end of the first
motion block by which every axis of the machine has been programmed; the moves before it
(typically the safe-start rapids to clearance) are counted, not swept.

Per block it also records the largest distance of the true tip path from the straight
line between the block's end tips: the joint-interpolation error a post that plans only
the block ends does not see.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Final

import numpy as np
from numpy.typing import NDArray

from gcode.block_sequence import MoveRun, block_runs
from gcode.interpreter import KIND_RAPID, interpret
from gcode.machine_frame import joint_columns, work_offsets
from gcode.program import AXES, Arc, Linear, Program, Rapid
from machines import Machine, Wrap, forward

from .errors import VerificationError
from .vectors import row_norms

__all__ = ["MAX_SUBSTEPS", "JointRows", "ToolMotion", "replay", "replay_rows"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

MAX_SUBSTEPS: Final[int] = 100_000
"""Most steps one block is cut into (a full turn of C at 200 mm radius to 0.1 um needs
about 5000); reaching it means the tolerance cannot be met and raises."""

_INITIAL_STEP_DEG: Final[float] = 2.0
"""First guess of the rotary step per sample (deg); refined by the midpoint test."""

_MOTION = (Rapid, Linear, Arc)


@dataclass(frozen=True, eq=False)
class ToolMotion:
    """Tool instances along the program, and what each motion block did.

    Instance ``i > 0`` is reached by block ``move_of_instance[i]``; instance 0 is where the
    first motion block starts.

    Attributes
    ----------
    tips_mm : ndarray, shape (m, 3)
        Tool tips in the workpiece frame, mm.
    axes : ndarray, shape (m, 3)
        Unit tool axes (tip towards spindle).
    move_of_instance : ndarray of int64, shape (m,)
        Motion-block number (0-based, in motion order) of the move arriving at each
        instance (0 for instance 0).
    block_index : ndarray of int64, shape (n,)
        Position of each motion block in ``Program.blocks``.
    line : ndarray of int64, shape (n,)
        1-based source line of each motion block (block index + 1 when not parsed).
    rapid : ndarray of bool, shape (n,)
        The block is a rapid (G0).
    substeps : ndarray of int64, shape (n,)
        Joint-space steps the block was sampled with (arcs: chords).
    rotary_deg : ndarray, shape (n,)
        Largest rotary-axis travel of the block, deg.
    tip_deviation_mm : ndarray, shape (n,)
        Largest distance of the true tip path from the straight line between the block's
        end tips, mm (0 for blocks moving linear axes only).
    chord_tol_mm : float
        Tolerance the sampling met, mm.
    first_swept : int
        Motion blocks before this one (in motion order) start from an unknown position
        and are not swept.
    rows : JointRows or None
        The joint-space segments the instances sample (None: not kept), so that any
        stretch of the path can be sampled again more finely (:func:`replay_rows`).
    """

    tips_mm: FloatArray
    axes: FloatArray
    move_of_instance: IntArray
    block_index: IntArray
    line: IntArray
    rapid: NDArray[np.bool_]
    substeps: IntArray
    rotary_deg: FloatArray
    tip_deviation_mm: FloatArray
    chord_tol_mm: float
    first_swept: int = 0
    rows: JointRows | None = None

    @property
    def n_moves(self) -> int:
        """Motion blocks."""
        return int(self.block_index.shape[0])

    @property
    def n_instances(self) -> int:
        """Tool instances (sampled positions)."""
        return int(self.tips_mm.shape[0])


@dataclass(frozen=True, eq=False)
class JointRows:
    """The joint-space segments of a replay (blocks, arcs cut into chords), in order.

    Attributes
    ----------
    start, end : ndarray, shape (k, n_axes)
        Joint values at each segment's ends (machine units: mm, deg; rotary axes
        unwrapped as the controller moves them).
    move : ndarray of int64, shape (k,)
        Motion block (0-based, motion order) of each segment.
    of_instance : ndarray of int64, shape (m,)
        Segment each tool instance ends (instance 0, where the first segment starts: 0).
    """

    start: FloatArray
    end: FloatArray
    move: IntArray
    of_instance: IntArray


def _first_known(program: Program, machine: Machine) -> int:
    """Motion-block number (motion order) by whose end every machine axis was programmed.

    Runs of moves held as columns are read column-wise (no block objects built).
    """
    letters = [a.letter.lower() for a in machine.axes]
    cols = [AXES.index(a) for a in letters]
    seen = np.zeros(len(letters), dtype=np.bool_)
    k = 0
    for _, part in block_runs(program.blocks):
        if isinstance(part, MoveRun):
            known = np.logical_or.accumulate(~np.isnan(part.axes[:, cols]), axis=0) | seen
            full = np.flatnonzero(known.all(axis=1))
            if full.size:
                return k + int(full[0])
            seen, k = known[-1], k + len(part)
            continue
        for b in part:
            if type(b) in _MOTION:
                seen |= np.array([getattr(b, a) is not None for a in letters])
                if seen.all():
                    return k
                k += 1
    missing = [a for a, ok in zip(letters, seen, strict=True) if not ok]
    raise VerificationError(
        f"no motion block programs axis {', '.join(a.upper() for a in missing)} of machine "
        f"{machine.name!r}: where the tool is cannot be known, so nothing can be verified")


def _motion_mask(program: Program) -> NDArray[np.bool_]:
    """Which blocks move the tool (columns of moves are all motion)."""
    parts = [np.ones(len(part), dtype=np.bool_) if isinstance(part, MoveRun) else
             np.fromiter((type(b) in _MOTION for b in part), dtype=np.bool_, count=len(part))
             for _, part in block_runs(program.blocks)]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.bool_)


def _wrap180(a: FloatArray) -> FloatArray:
    return np.mod(a + 180.0, 360.0) - 180.0


def _joints(machine: Machine, start: FloatArray, end: FloatArray
            ) -> tuple[FloatArray, FloatArray]:
    """Joint values at the start and end of every move, rotary axes as the controller moves."""
    j0 = joint_columns(machine, start)
    j1 = joint_columns(machine, end)
    for col, axis in enumerate(machine.axes):
        if axis.wrap is Wrap.SHORTEST:
            step = _wrap180(j1[:, col] - j0[:, col])
            ends = j0[0, col] + np.cumsum(step)
            j1[:, col] = ends
            j0[1:, col] = ends[:-1]
    return j0, j1


def _sample_u(counts: IntArray) -> tuple[IntArray, FloatArray]:
    """Move index and ``u`` of samples ``u = j / n``, ``j = 1..n`` of every move."""
    move = np.repeat(np.arange(counts.shape[0], dtype=np.int64), counts)
    first = np.cumsum(counts) - counts
    j = np.arange(move.shape[0], dtype=np.int64) - first[move] + 1
    return move, j / counts[move]


def _pose(machine: Machine, j0: FloatArray, j1: FloatArray, move: IntArray, u: FloatArray,
          radius_mm: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    joints = j0[move] + u[:, None] * (j1[move] - j0[move])
    tips, axes = forward(machine, joints)
    return tips, axes, tips + radius_mm * axes


def _midpoint_errors(machine: Machine, j0: FloatArray, j1: FloatArray, moves: IntArray,
                     counts: IntArray, radius_mm: float
                     ) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    """Largest midpoint-to-chord distance over the steps of each listed move (tip, centre).

    Also the instances it posed on the way (the steps' ends ``u = j / n``, by move and
    ``j``, :func:`_sample_u` of the listed moves): the list's index of each, tips, axes.
    """
    c = counts[moves]
    move_local, u = _sample_u(c)
    move = moves[move_local]
    du = 1.0 / c[move_local]
    tip1, axis1, cen1 = _pose(machine, j0, j1, move, u, radius_mm)
    tip0, _, cen0 = _pose(machine, j0, j1, move, u - du, radius_mm)
    tipm, _, cenm = _pose(machine, j0, j1, move, u - 0.5 * du, radius_mm)
    err = np.maximum(row_norms(tipm - 0.5 * (tip0 + tip1)),
                     row_norms(cenm - 0.5 * (cen0 + cen1)))
    out = np.zeros(moves.shape[0])
    np.maximum.at(out, move_local, err)
    return out, move_local, tip1, axis1


#: Instances posed while counting a move's steps, at its final count: the moves (sorted),
#: then their instances' tips and axes in :func:`_sample_u` order.
_Posed = tuple[IntArray, FloatArray, FloatArray]


def _substeps(machine: Machine, j0: FloatArray, j1: FloatArray, chord_tol_mm: float,
              radius_mm: float) -> tuple[IntArray, FloatArray, list[_Posed]]:
    """Steps per move, each move's rotary travel, and the instances posed at the counts.

    A move whose steps keep the tolerance in a round keeps its count from then on: the
    instances that round posed for it are its instances (the same joints and ``u`` in,
    the same poses out), handed on so that :func:`replay` does not pose them again.
    """
    n = j0.shape[0]
    counts = np.ones(n, dtype=np.int64)
    rot_cols = [i for i, a in enumerate(machine.axes) if a.is_rotary]
    rotary = (np.abs(j1[:, rot_cols] - j0[:, rot_cols]).max(axis=1) if rot_cols
              else np.zeros(n))
    todo = np.flatnonzero(rotary > 0.0)
    counts[todo] = np.maximum(1, np.ceil(rotary[todo] / _INITIAL_STEP_DEG)).astype(np.int64)
    posed: list[_Posed] = []
    while todo.shape[0]:
        err, local, tips, axes = _midpoint_errors(machine, j0, j1, todo, counts, radius_mm)
        bad = err > chord_tol_mm
        kept = ~bad[local]
        posed.append((todo[~bad], tips[kept], axes[kept]))
        if not bad.any():
            break
        todo = todo[bad]
        grow = np.ceil(counts[todo] * np.sqrt(err[bad] / chord_tol_mm) * 1.25).astype(np.int64)
        counts[todo] = np.maximum(grow, 2 * counts[todo])
        if counts[todo].max() > MAX_SUBSTEPS:
            raise VerificationError(
                f"a block cannot be sampled within chord_tol_mm={chord_tol_mm!r}: it would "
                f"need more than {MAX_SUBSTEPS} steps (rotary travel "
                f"{float(rotary[todo].max()):.6g} deg)")
    return counts, rotary, posed


def _instances(machine: Machine, j0: FloatArray, j1: FloatArray, counts: IntArray,
               posed: list[_Posed], radius_mm: float
               ) -> tuple[IntArray, FloatArray, FloatArray]:
    """Every move's instances (``u = j / n``, :func:`_sample_u`): move index, tips, axes.

    Those :func:`_substeps` posed at the final counts are placed, the others (moves that
    turn no rotary axis) posed here: the values :func:`_pose` gives for all of them.
    """
    move, u = _sample_u(counts)
    tips = np.empty((move.shape[0], 3))
    axes = np.empty((move.shape[0], 3))
    first = np.cumsum(counts) - counts  # each move's first instance
    placed = np.zeros(counts.shape[0], dtype=bool)
    for moves, t, a in posed:
        c = counts[moves]
        rows = np.arange(t.shape[0]) + np.repeat(first[moves] - (np.cumsum(c) - c), c)
        tips[rows], axes[rows] = t, a
        placed[moves] = True
    rest = np.flatnonzero(~placed[move])
    tips[rest], axes[rest], _ = _pose(machine, j0, j1, move[rest], u[rest], radius_mm)
    return move, tips, axes


def _chord_deviation(tips: FloatArray, move: IntArray, counts: IntArray) -> FloatArray:
    """Largest distance of each move's sampled tips from the chord between its end tips."""
    n = counts.shape[0]
    out = np.zeros(n)
    multi = np.flatnonzero(counts > 1)
    if multi.shape[0] == 0:
        return out
    ends = np.cumsum(counts)  # instance index of each move's end
    p0 = tips[ends - counts]
    p1 = tips[ends]
    rows = np.flatnonzero(counts[move] > 1) + 1  # instances inside multi-step moves
    k = move[rows - 1]
    d = p1[k] - p0[k]
    rel = tips[rows] - p0[k]
    dd = np.einsum("ij,ij->i", d, d)
    f = np.clip(np.einsum("ij,ij->i", rel, d) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
    dist = row_norms(rel - f[:, None] * d)
    np.maximum.at(out, k, dist)
    return out


def replay(program: Program, machine: Machine, *, chord_tol_mm: float, radius_mm: float,
           offsets: dict[int, tuple[float, ...]] | None = None) -> ToolMotion:
    """Tool instances of a program on a machine, joints interpolated as the controller does.

    Parameters
    ----------
    program : Program
        The program (mm, degrees).
    machine : Machine
        The machine that runs it.
    chord_tol_mm : float
        Largest distance of the true tip and ball-centre paths from the chords between
        consecutive instances, mm (also the arc linearization tolerance).
    radius_mm : float
        Cutter radius, mm: the ball centre ``tip + R axis`` is held to the tolerance too.
    offsets : dict, optional
        Work offsets G54-G59 (X Y Z A B C, mm and degrees); the machine's work origin in
        every system when None (:func:`gcode.machine_frame.work_offsets`).

    Returns
    -------
    ToolMotion
        Instances from the end of the first block by which every axis is programmed.

    Raises
    ------
    VerificationError
        When the program has no motion block, never programs some axis, or a block cannot
        be sampled finely enough.
    """
    if not (chord_tol_mm > 0.0):
        raise VerificationError(f"chord_tol_mm must be > 0 mm, got {chord_tol_mm!r}")
    seg = interpret(program, work_offsets=offsets or work_offsets(machine))
    n_seg = len(seg)
    if n_seg == 0:
        raise VerificationError("the program has no motion block (G0/G1/G2/G3) to verify")
    lines = seg.line.astype(np.int64)
    rapid = seg.kind == KIND_RAPID
    known = _first_known(program, machine)
    seg = replace(seg, line=np.arange(n_seg, dtype=np.int64)).linearize(chord_tol_mm)
    keep = seg.line > known
    start = seg.end[np.flatnonzero(seg.line == known)[-1]][None, :]
    rows = np.flatnonzero(keep)
    source = seg.line[rows]  # row -> motion block
    j0, j1 = _joints(machine, np.concatenate((start, seg.start[rows])),
                     np.concatenate((start, seg.end[rows])))
    j0, j1 = j0[1:], j1[1:]
    if j0.shape[0] and np.abs(j0[0] - joint_columns(machine, start)[0]).max() > 0.0:
        j0[0] = joint_columns(machine, start)[0]  # pragma: no cover - contiguous segments
    counts, rotary, posed = _substeps(machine, j0, j1, chord_tol_mm, radius_mm)
    move, tips, axes = _instances(machine, j0, j1, counts, posed, radius_mm)
    tip0, axis0 = forward(machine, joint_columns(machine, start))
    tips = np.concatenate((tip0, tips))
    axes = np.concatenate((axis0, axes))
    row_dev = _chord_deviation(tips, move, counts)
    dev = np.zeros(n_seg)
    np.maximum.at(dev, source, row_dev)
    rot = np.zeros(n_seg)
    np.maximum.at(rot, source, rotary)
    steps = np.bincount(source, weights=counts, minlength=n_seg).astype(np.int64)
    is_motion = _motion_mask(program)
    return ToolMotion(
        tips_mm=tips, axes=axes,
        move_of_instance=np.concatenate(([known], source[move])).astype(np.int64),
        block_index=np.flatnonzero(is_motion).astype(np.int64), line=lines, rapid=rapid,
        substeps=steps, rotary_deg=rot, tip_deviation_mm=dev, chord_tol_mm=float(chord_tol_mm),
        first_swept=known + 1,
        rows=JointRows(j0, j1, source.astype(np.int64),
                       np.concatenate(([0], move)).astype(np.int64)))


def replay_rows(motion: ToolMotion, machine: Machine, rows: IntArray, *,
                chord_tol_mm: float, radius_mm: float) -> tuple[ToolMotion, IntArray]:
    """Some segments of a replay sampled again, to ``chord_tol_mm``, in one batch.

    The same joint interpolation as :func:`replay` (steps doubled-and-more until every
    step's tip and ball-centre midpoints lie within the tolerance of its chord), on
    stretches of the path only: a finer model of the tool where it matters, at the cost
    of those stretches.

    Parameters
    ----------
    motion : ToolMotion
        A replay that kept its segments (``motion.rows``).
    machine : Machine
        The machine it was replayed on.
    rows : ndarray of int64
        Segments (indices into ``motion.rows``), sorted, unique; each run of consecutive
        ones is a stretch.
    chord_tol_mm, radius_mm : float
        As for :func:`replay`.

    Returns
    -------
    motion : ToolMotion
        Per stretch: an instance where its first segment starts, then its segments'
        instances; moves, blocks and lines numbered as in ``motion`` (``rows`` None).
        Consecutive instances of two stretches are not joined by the tool.
    starts : ndarray of int64
        The instance each stretch starts at (the first is 0).

    Raises
    ------
    VerificationError
        When ``motion`` kept no segments, or a segment cannot be sampled finely enough.
    """
    kept = motion.rows
    if kept is None:
        raise VerificationError("this replay kept no joint segments to sample again")
    if not (chord_tol_mm > 0.0):
        raise VerificationError(f"chord_tol_mm must be > 0 mm, got {chord_tol_mm!r}")
    j0, j1 = kept.start[rows], kept.end[rows]
    counts, _, posed = _substeps(machine, j0, j1, chord_tol_mm, radius_mm)
    move, tips, axes = _instances(machine, j0, j1, counts, posed, radius_mm)
    first = np.flatnonzero(np.r_[True, np.diff(rows) > 1])  # each stretch's first segment
    tip0, axis0 = forward(machine, j0[first])
    # a stretch's start goes before its first segment's instances
    ends = np.cumsum(counts) - counts  # instance (without starts) of each segment's first
    at = ends[first]
    source = kept.move[rows]
    starts = at + np.arange(first.shape[0])
    return replace(motion, tips_mm=np.insert(tips, at, tip0, axis=0),
                   axes=np.insert(axes, at, axis0, axis=0),
                   move_of_instance=np.insert(source[move], at, source[first]),
                   chord_tol_mm=float(chord_tol_mm), rows=None), starts.astype(np.int64)
