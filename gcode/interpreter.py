"""The expanding interpreter: ``Program`` -> absolute motion segments (arrays).

Each rapid, linear or arc block becomes one segment with absolute start and end
positions X Y Z A B C (mm, degrees) in machine coordinates (program coordinates plus the
active work offset), its feed (mm/min, or 1/min in inverse time), kind, arc centre and
plane, and the source line. Arcs stay arcs; :meth:`Segments.linearize` turns them into
chords within a chord tolerance. Runs of rapid and linear moves are expanded with numpy,
straight from the columns of parsed programs (:mod:`gcode.block_sequence`);
modal bookkeeping uses :class:`gcode.modal.ModalState`, shared with parser and emitter.

Examples
--------
>>> from gcode.interpreter import interpret
>>> from gcode.program import Linear, Program, Rapid
>>> seg = interpret(Program((Rapid(x=0.0, y=0.0), Linear(x=3.0, y=4.0, feed=600.0))))
>>> seg.lengths().tolist(), seg.durations().tolist()
([0.0, 5.0], [0.0, 0.5])
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from gcode.block_sequence import KIND_LINEAR, MoveRun, block_runs
from gcode.errors import ArcError, ErrorCode
from gcode.modal import ModalState, MotionMode
from gcode.program import Arc, DistanceMode, Dwell, FeedMode, Linear, Program, Rapid
from toolpath.tolerances import TINY

__all__ = [
    "DEFAULT_CHORD_TOLERANCE_MM",
    "KIND_ARC_CCW",
    "KIND_ARC_CW",
    "KIND_LINEAR",
    "KIND_RAPID",
    "Segments",
    "interpret",
]

KIND_RAPID, KIND_ARC_CW, KIND_ARC_CCW = 0, 2, 3  # KIND_LINEAR = 1 as in MoveRun
#: Default chord tolerance for :meth:`Segments.linearize` (mm): 1 um, the resolution of
#: the coordinates we write, so linearizing adds no error visible in the text.
DEFAULT_CHORD_TOLERANCE_MM = 0.001
_PLANE_IDX = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
#: An arc whose sweep (rad) from start to end is within this of 0 ends where it starts: a
#: full circle, as G2/G3 with end == start means (round-off of two ``atan2``).
_SAME_ANGLE_RAD = 1e-12

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Segments:
    """Motion segments as parallel arrays (one row per move).

    Attributes
    ----------
    start, end : ndarray, shape (n, 6)
        Absolute machine positions X Y Z A B C (mm, degrees).
    kind : ndarray of int8, shape (n,)
        0 rapid, 1 linear, 2 arc clockwise, 3 arc counter-clockwise.
    feed : ndarray, shape (n,)
        mm/min, or 1/min where ``inverse_time``; NaN for rapids.
    inverse_time : ndarray of bool, shape (n,)
        Feed is inverse time (G93).
    centre : ndarray, shape (n, 3)
        Absolute arc centre X Y Z (mm; the normal coordinate is the start's); NaN if
        not an arc.
    plane : ndarray of int8, shape (n,)
        17, 18 or 19.
    line : ndarray of int64, shape (n,)
        Source line (1-based), or block index + 1 for programs that were not parsed.
    dwell_s : float
        Total dwell time in the program, s.
    """

    start: FloatArray
    end: FloatArray
    kind: npt.NDArray[np.int8]
    feed: FloatArray
    inverse_time: npt.NDArray[np.bool_]
    centre: FloatArray
    plane: npt.NDArray[np.int8]
    line: npt.NDArray[np.int64]
    dwell_s: float = 0.0

    def __len__(self) -> int:
        return int(self.kind.shape[0])

    def _arc_geometry(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Radius (mm), signed sweep (rad) and normal travel (mm) of every row."""
        n = len(self)
        radius = np.zeros(n)
        sweep = np.zeros(n)
        normal = np.zeros(n)
        for p, (u, v, w) in _PLANE_IDX.items():
            rows = np.flatnonzero((self.kind >= KIND_ARC_CW) & (self.plane == p))
            if rows.shape[0] == 0:
                continue
            cu, cv = self.centre[rows, u], self.centre[rows, v]
            su, sv = self.start[rows, u] - cu, self.start[rows, v] - cv
            eu, ev = self.end[rows, u] - cu, self.end[rows, v] - cv
            a0 = np.arctan2(sv, su)
            a1 = np.arctan2(ev, eu)
            ccw = self.kind[rows] == KIND_ARC_CCW
            d = np.where(ccw, a1 - a0, a0 - a1)
            d = np.mod(d, 2.0 * np.pi)
            d = np.where(d <= _SAME_ANGLE_RAD, 2.0 * np.pi, d)  # end == start: full circle
            radius[rows] = np.hypot(su, sv)
            sweep[rows] = np.where(ccw, d, -d)
            normal[rows] = self.end[rows, w] - self.start[rows, w]
        return radius, sweep, normal

    def lengths(self) -> FloatArray:
        """Tool-path length of every segment (mm): XYZ distance, arc length for arcs.

        Rotary-only moves have length 0 (their travel is in degrees).
        """
        d = self.end[:, :3] - self.start[:, :3]
        out = np.sqrt((d * d).sum(axis=1))
        arcs = self.kind >= KIND_ARC_CW
        if arcs.any():
            radius, sweep, normal = self._arc_geometry()
            out[arcs] = np.hypot(radius[arcs] * sweep[arcs], normal[arcs])
        return out

    def durations(self, rapid_rate: float | None = None) -> FloatArray:
        """Time of every segment at programmed feeds (s).

        Parameters
        ----------
        rapid_rate : float or None
            Rapid traverse rate, mm/min; rapids take 0 when None (no machine known).

        Returns
        -------
        ndarray
            Seconds per segment: 60 length/feed, 60/F in inverse time. As in LinuxCNC,
            a units-per-minute feed move with no XYZ travel takes its rotary distance
            (degrees, all rotary axes together) at F degrees/min.
        """
        length = self.lengths()
        rotary = self.end[:, 3:] - self.start[:, 3:]
        travel = np.where(length > 0.0, length, np.sqrt((rotary * rotary).sum(axis=1)))
        out = np.zeros(len(self))
        feed_rows = self.kind != KIND_RAPID
        upm = feed_rows & ~self.inverse_time
        out[upm] = 60.0 * travel[upm] / self.feed[upm]
        inv = feed_rows & self.inverse_time
        out[inv] = 60.0 / self.feed[inv]
        if rapid_rate is not None:
            rap = ~feed_rows
            out[rap] = 60.0 * length[rap] / rapid_rate
        return out

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        """Lowest and highest X Y Z A B C visited by segment end points (mm, degrees)."""
        if len(self) == 0:
            z = np.zeros(6)
            return z, z
        pts = np.concatenate((self.start[:1], self.end))
        return pts.min(axis=0), pts.max(axis=0)

    def linearize(self, chord_tolerance: float = DEFAULT_CHORD_TOLERANCE_MM) -> Segments:
        """Replace arcs by linear chords deviating at most ``chord_tolerance`` (mm).

        Parameters
        ----------
        chord_tolerance : float
            Largest distance between an arc and its chords, mm (> 0).

        Returns
        -------
        Segments
            Same rows with every arc split into ``ceil(sweep / (2 acos(1 - tol/r)))``
            equal chords (helical travel and other axes interpolated linearly); chord
            feeds in inverse time are scaled so the arc keeps its time.
        """
        if chord_tolerance <= 0.0:
            raise ValueError(f"chord_tolerance must be > 0 mm, got {chord_tolerance!r}")
        arcs = np.flatnonzero(self.kind >= KIND_ARC_CW)
        if arcs.shape[0] == 0:
            return self
        radius, sweep, _ = self._arc_geometry()
        counts = np.ones(len(self), dtype=np.int64)
        r = radius[arcs]
        half = np.arccos(np.clip(1.0 - chord_tolerance / np.maximum(r, TINY), -1.0, 1.0))
        counts[arcs] = np.maximum(1, np.ceil(np.abs(sweep[arcs]) / (2.0 * half))).astype(np.int64)
        total = int(counts.sum())
        rep = np.repeat(np.arange(len(self)), counts)
        first = np.cumsum(counts) - counts
        k = np.arange(total) - first[rep]
        n_of = counts[rep]
        t0 = k / n_of
        t1 = (k + 1) / n_of
        start = self.start[rep] + (self.end[rep] - self.start[rep]) * t0[:, None]
        end = self.start[rep] + (self.end[rep] - self.start[rep]) * t1[:, None]
        is_arc = self.kind[rep] >= KIND_ARC_CW
        for p, (u, v, _w) in _PLANE_IDX.items():
            rows = np.flatnonzero(is_arc & (self.plane[rep] == p))
            if rows.shape[0] == 0:
                continue
            src = rep[rows]
            cu, cv = self.centre[src, u], self.centre[src, v]
            a0 = np.arctan2(self.start[src, v] - cv, self.start[src, u] - cu)
            rr = radius[src]
            for arr, t in ((start, t0[rows]), (end, t1[rows])):
                ang = a0 + sweep[src] * t
                arr[rows, u] = cu + rr * np.cos(ang)
                arr[rows, v] = cv + rr * np.sin(ang)
            last = k[rows] == n_of[rows] - 1  # land exactly on the programmed end
            end[rows[last]] = self.end[src[last]]
            first_rows = k[rows] == 0
            start[rows[first_rows]] = self.start[src[first_rows]]
        feed = self.feed[rep].copy()
        inv = self.inverse_time[rep] & is_arc
        feed[inv] = feed[inv] * n_of[inv]
        kind = np.where(is_arc, KIND_LINEAR, self.kind[rep]).astype(np.int8)
        centre = np.where(is_arc[:, None], np.nan, self.centre[rep])
        return Segments(
            start, end, kind, feed, self.inverse_time[rep], centre, self.plane[rep],
            self.line[rep], self.dwell_s,
        )  # fmt: skip


class _Out:
    def __init__(self) -> None:
        self.parts: list[dict[str, np.ndarray]] = []

    def add(self, **cols: np.ndarray) -> None:
        self.parts.append(cols)


def _arc_centre(
    b: Arc, start: Sequence[float], end: Sequence[float], line: int
) -> tuple[float, float, float]:
    u, v, _ = _PLANE_IDX[int(b.plane)]
    c = [float(start[0]), float(start[1]), float(start[2])]
    if b.r is None:
        offs = (b.i or 0.0, b.j or 0.0, b.k or 0.0)
        c[u] = start[u] + offs[u]
        c[v] = start[v] + offs[v]
        return c[0], c[1], c[2]
    # R form (grbl gcode.c): centre on the perpendicular bisector of the chord.
    du, dv = end[u] - start[u], end[v] - start[v]
    chord2 = du * du + dv * dv
    if chord2 == 0.0:
        raise ArcError(ErrorCode.INVALID_TARGET, "R arc with end equal to start", line=line)
    h2 = max(4.0 * b.r * b.r - chord2, 0.0)
    h = -math.sqrt(h2) / math.sqrt(chord2)
    if not b.clockwise:
        h = -h
    if b.r < 0.0:
        h = -h
    c[u] = start[u] + 0.5 * (du - dv * h)
    c[v] = start[v] + 0.5 * (dv + du * h)
    return c[0], c[1], c[2]


def interpret(
    program: Program,
    *,
    work_offsets: Mapping[int, Sequence[float]] | None = None,
    state: ModalState | None = None,
) -> Segments:
    """Expand a program into absolute motion segments.

    Parameters
    ----------
    program : Program
        Blocks in mm, degrees, mm/min.
    work_offsets : mapping of int to sequence of float, optional
        Offsets of work systems 1-6 (G54-G59), X Y Z A B C in mm and degrees, added to
        programmed positions; zero when missing.
    state : ModalState, optional
        Initial modal state (GRBL defaults if None).

    Returns
    -------
    Segments
        One row per rapid, linear or arc block.
    """
    st = state if state is not None else ModalState()
    offsets = {k: np.asarray(v, dtype=np.float64) for k, v in (work_offsets or {}).items()}
    zero = np.zeros(6)
    n = len(program.blocks)
    if program.source_lines is None:
        lines = np.arange(1, n + 1, dtype=np.int64)
    else:
        lines = np.asarray(program.source_lines, dtype=np.int64)
    out = _Out()
    dwell = 0.0
    for first, part in block_runs(program.blocks):
        if isinstance(part, MoveRun):
            end = first + len(part)
            st = _motion_run(part, lines[first:end], st, offsets.get(st.wcs, zero), out)
            continue
        m = len(part)
        i = 0
        while i < m:
            b = part[i]
            if type(b) in (Rapid, Linear):
                j = i + 1
                while j < m and type(part[j]) in (Rapid, Linear):
                    j += 1
                run = MoveRun.from_blocks(part[i:j])  # type: ignore[arg-type]
                rows = lines[first + i : first + j]
                st = _motion_run(run, rows, st, offsets.get(st.wcs, zero), out)
                i = j
                continue
            if isinstance(b, Arc):
                off = offsets.get(st.wcs, zero)
                start = np.asarray(st.position) + off
                new = st.apply(b)
                end_pos = np.asarray(new.position) + off
                line = int(lines[first + i])
                centre = _arc_centre(b, start, end_pos, line)
                out.add(
                    start=start[None],
                    end=end_pos[None],
                    kind=np.array([KIND_ARC_CW if b.clockwise else KIND_ARC_CCW], dtype=np.int8),
                    feed=np.array([b.feed]),
                    inverse_time=np.array([st.feed_mode is FeedMode.INVERSE_TIME]),
                    centre=np.array([centre]),
                    plane=np.array([int(b.plane)], dtype=np.int8),
                    line=np.array([line], dtype=np.int64),
                )
                st = new
            else:
                if isinstance(b, Dwell):
                    dwell += b.seconds
                st = st.apply(b)
            i += 1
    return _collect(out, dwell)


def _motion_run(
    run: MoveRun,
    lines: npt.NDArray[np.int64],
    st: ModalState,
    offset: FloatArray,
    out: _Out,
) -> ModalState:
    """Expand a run of rapid/linear moves (columns) from state ``st``; return the state after."""
    m = len(run)
    present = ~np.isnan(run.axes)
    vals = np.where(present, run.axes, 0.0)
    pos0 = np.asarray(st.position, dtype=np.float64)
    if st.distance is DistanceMode.INCREMENTAL:
        ends = np.cumsum(np.concatenate((pos0[None], vals)), axis=0)[1:]
    else:
        at = np.where(present, np.arange(m)[:, None], -1)
        np.maximum.accumulate(at, axis=0, out=at)
        ends = np.where(at >= 0, vals[np.maximum(at, 0), np.arange(6)[None, :]], pos0[None, :])
    starts = np.concatenate((pos0[None], ends[:-1]))
    is_lin = run.kind == KIND_LINEAR
    out.add(
        start=starts + offset,
        end=ends + offset,
        kind=is_lin.astype(np.int8),
        feed=np.array(run.feed),
        inverse_time=np.full(m, st.feed_mode is FeedMode.INVERSE_TIME),
        centre=np.full((m, 3), np.nan),
        plane=np.full(m, int(st.plane), dtype=np.int8),
        line=np.array(lines, dtype=np.int64),
    )
    lin_at = np.flatnonzero(is_lin)
    return replace(
        st,
        motion=MotionMode.LINEAR if is_lin[-1] else MotionMode.RAPID,
        feed=float(run.feed[lin_at[-1]]) if lin_at.shape[0] else st.feed,
        position=tuple(ends[-1].tolist()),  # type: ignore[arg-type]
    )


def _collect(out: _Out, dwell: float) -> Segments:
    names = ("start", "end", "kind", "feed", "inverse_time", "centre", "plane", "line")
    if not out.parts:
        return Segments(
            np.zeros((0, 6)), np.zeros((0, 6)), np.zeros(0, dtype=np.int8), np.zeros(0),
            np.zeros(0, dtype=np.bool_), np.zeros((0, 3)), np.zeros(0, dtype=np.int8),
            np.zeros(0, dtype=np.int64), dwell,
        )  # fmt: skip
    cols = {k: np.concatenate([p[k] for p in out.parts]) for k in names}
    return Segments(**cols, dwell_s=dwell)
